# report: one self-contained HTML file per experiment.


rule report:
    input:
        fit="results/{experiment}/fit/params.json",
        calibration="results/{experiment}/calibration/cameras.json",
        matte="results/{experiment}/matte.json",
        proxy="results/{experiment}/proxy/proxy.json",
    output:
        "results/{experiment}/report.html",
    log:
        "logs/{experiment}/report.log",
    benchmark:
        "benchmarks/{experiment}/report.tsv"
    run:
        raise NotImplementedError("stage report: not implemented yet")
