# fit: the constitutive parameters, a warm-up on the first frames and then every frame (checkpointed, resumable).


rule fit_warmup:
    input:
        unpack(lambda w: truth_input(w.experiment)),
        recordings="results/{experiment}/recordings",
        matte="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
        seed="results/{experiment}/seed/particles.npz",
        velocity="results/{experiment}/velocity/velocity.json",
    output:
        warmup="results/{experiment}/fit/warmup.json",
    resources:
        mem_mb=worker_memory(800, 500),
        runtime=60,
    log:
        "logs/{experiment}/fit_warmup.log",
    benchmark:
        "benchmarks/{experiment}/fit_warmup.tsv"
    threads: job_threads()
    params:
        experiment=lambda w: experiment(w.experiment),
        phase="warmup",
    script:
        "../../stages/fit.py"


rule fit:
    input:
        unpack(lambda w: truth_input(w.experiment)),
        recordings="results/{experiment}/recordings",
        matte="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
        seed="results/{experiment}/seed/particles.npz",
        velocity="results/{experiment}/velocity/velocity.json",
        warmup="results/{experiment}/fit/warmup.json",
    output:
        params="results/{experiment}/fit/params.json",
        history="results/{experiment}/fit/history.csv",
    resources:
        mem_mb=worker_memory(800, 500),
        runtime=120,
    log:
        "logs/{experiment}/fit.log",
    benchmark:
        "benchmarks/{experiment}/fit.tsv"
    threads: job_threads()
    params:
        experiment=lambda w: experiment(w.experiment),
        phase="full",
    script:
        "../../stages/fit.py"
