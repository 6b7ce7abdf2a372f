# matte: material masks from the frames and the clean plate (classical, no learned weights).


rule matte:
    input:
        recordings="results/{experiment}/recordings",
    output:
        masks=directory("results/{experiment}/matte"),
        report="results/{experiment}/matte.json",
        figure=report("results/{experiment}/matte.png", caption="../report/matte.rst", category="Masks",
                      subcategory="{experiment}"),
    resources:
        mem_mb=1000,
        runtime=10,
    log:
        "logs/{experiment}/matte.log",
    benchmark:
        "benchmarks/{experiment}/matte.tsv"
    params:
        settings=lambda w: experiment(w.experiment)["matte"],
    script:
        "../../stages/matte.py"
