# The inverse half of the pipeline: seed, velocity, fit (warm-up, full), diagnose, report. Declared so that the DAG
# is complete; until they exist each fails with "not implemented yet" and writes nothing.


def not_implemented(stage):
    raise NotImplementedError(f"stage {stage}: not implemented yet")


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
        figure="results/{experiment}/seed/seed.png",
    log:
        "logs/{experiment}/seed.log",
    benchmark:
        "benchmarks/{experiment}/seed.tsv"
    params:
        settings=lambda w: experiment(w.experiment)["fit"]["seed"],
        simulation=lambda w: experiment(w.experiment)["simulation"],
    script:
        "../../stages/seed.py"


rule velocity:
    input:
        seed="results/{experiment}/seed/particles.npz",
        masks="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
    output:
        "results/{experiment}/velocity/velocity.json",
    log:
        "logs/{experiment}/velocity.log",
    benchmark:
        "benchmarks/{experiment}/velocity.tsv"
    run:
        not_implemented("velocity")


rule fit_warmup:
    input:
        seed="results/{experiment}/seed/particles.npz",
        velocity="results/{experiment}/velocity/velocity.json",
        masks="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
    output:
        "results/{experiment}/fit/warmup.json",
    log:
        "logs/{experiment}/fit_warmup.log",
    benchmark:
        "benchmarks/{experiment}/fit_warmup.tsv"
    run:
        not_implemented("fit (warm-up)")


rule fit:
    input:
        warmup="results/{experiment}/fit/warmup.json",
        masks="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
    output:
        "results/{experiment}/fit/params.json",
    log:
        "logs/{experiment}/fit.log",
    benchmark:
        "benchmarks/{experiment}/fit.tsv"
    run:
        not_implemented("fit")


rule diagnose:
    input:
        fit="results/{experiment}/fit/params.json",
        recordings="results/{experiment}/recordings",
    output:
        "results/{experiment}/diagnose/diagnosis.json",
    log:
        "logs/{experiment}/diagnose.log",
    benchmark:
        "benchmarks/{experiment}/diagnose.tsv"
    run:
        not_implemented("diagnose")


rule report:
    input:
        fit="results/{experiment}/fit/params.json",
        diagnosis="results/{experiment}/diagnose/diagnosis.json",
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
        not_implemented("report")
