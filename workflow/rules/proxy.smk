# proxy: the starting shape (primitive or mesh file) voxelised into an occupancy grid and particles.


rule proxy:
    input:
        lambda w: [experiment(w.experiment)["proxy"]["mesh"]] if experiment(w.experiment)["proxy"]["shape"] == "mesh" else [],
    output:
        particles="results/{experiment}/proxy/particles.npz",
        summary="results/{experiment}/proxy/proxy.json",
        figure=report("results/{experiment}/proxy/particles.png", caption="../report/proxy.rst", category="Fit",
                      subcategory="{experiment}"),
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/{experiment}/proxy.log",
    benchmark:
        "benchmarks/{experiment}/proxy.tsv"
    params:
        proxy=lambda w: experiment(w.experiment)["proxy"],
    script:
        "../../stages/proxy.py"
