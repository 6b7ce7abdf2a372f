# novel: the recovered material on a new shape (the Stanford bunny), filmed by a calibrated camera.


rule novel:
    input:
        params="results/{experiment}/fit/params.json",
        cameras="results/{experiment}/calibration/cameras.json",
        recordings="results/{experiment}/recordings",
    output:
        video="results/{experiment}/novel/bunny.mp4",
        strip=report("results/{experiment}/novel/bunny.png", caption="../report/novel.rst", category="Prediction",
                     subcategory="{experiment}"),
    resources:
        mem_mb=1500,
        runtime=15,
    log:
        "logs/{experiment}/novel.log",
    benchmark:
        "benchmarks/{experiment}/novel.tsv"
    params:
        experiment=lambda w: experiment(w.experiment),
    script:
        "../../stages/novel.py"
