# seed: the particles a fit starts from (voxel radiance field, or the proxy coloured from one view).


rule seed:
    input:
        unpack(lambda w: truth_input(w.experiment)),
        recordings="results/{experiment}/recordings",
        matte="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
        proxy="results/{experiment}/proxy/particles.npz",
    output:
        particles="results/{experiment}/seed/particles.npz",
        summary="results/{experiment}/seed/seed.json",
        figure=report("results/{experiment}/seed/seed.png", caption="../report/seed.rst", category="Fit",
                      subcategory="{experiment}"),
    resources:
        mem_mb=2000,
        runtime=30,
    log:
        "logs/{experiment}/seed.log",
    benchmark:
        "benchmarks/{experiment}/seed.tsv"
    params:
        settings=lambda w: experiment(w.experiment)["fit"]["seed"],
        simulation=lambda w: experiment(w.experiment)["simulation"],
    script:
        "../../stages/seed.py"
