# diagnose: where simulation and recording still disagree, and which physics the model left out.


def not_implemented(stage):
    raise NotImplementedError(f"stage {stage}: not implemented yet")


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
