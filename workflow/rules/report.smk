# report: one self-contained HTML file per experiment.


def report_benchmarks(name):
    """The benchmark files of every stage behind an experiment's report, in pipeline order."""
    first = ["synthesize"] if experiment(name)["kind"] == "virtual" else ["ingest"]
    stages = first + ["calibrate", "matte", "proxy", "seed", "velocity", "fit_warmup", "fit", "novel"]
    return [f"benchmarks/{name}/{stage}.tsv" for stage in stages]


rule report:
    input:
        recordings="results/{experiment}/recordings",
        matte="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
        seed="results/{experiment}/seed/particles.npz",
        velocity="results/{experiment}/velocity/velocity.json",
        params="results/{experiment}/fit/params.json",
        history="results/{experiment}/fit/history.csv",
        novel="results/{experiment}/novel/bunny.png",
        benchmarks=lambda w: report_benchmarks(w.experiment),
    output:
        report=report("results/{experiment}/report.html", caption="../report/experiment_report.rst",
                      category="Results", subcategory="{experiment}"),
    resources:
        mem_mb=1500,
        runtime=15,
    log:
        "logs/{experiment}/report.log",
    benchmark:
        "benchmarks/{experiment}/report.tsv"
    params:
        experiment=lambda w: experiment(w.experiment),
    script:
        "../../stages/report.py"
