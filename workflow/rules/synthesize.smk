# synthesize: the virtual lab. Simulates a virtual experiment with finer particles than the fit's and films it with
# the lab renderer.


rule synthesize:
    output:
        recordings=directory("results/{experiment}/recordings"),
        truth="results/{experiment}/truth.json",
        figure=report("results/{experiment}/synthesize.png", caption="../report/synthesize.rst", category="Recording",
                      subcategory="{experiment}"),
    wildcard_constraints:
        experiment=experiments_of_kind("virtual"),
    resources:
        mem_mb=worker_memory(800, 500),
        runtime=30,
    log:
        "logs/{experiment}/synthesize.log",
    benchmark:
        "benchmarks/{experiment}/synthesize.tsv"
    threads: job_threads()
    params:
        experiment=lambda w: virtual_experiment(w.experiment),
    script:
        "../../stages/synthesize.py"
