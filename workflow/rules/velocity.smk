# velocity: the initial velocity from the first frames, the material at its initial guess.


rule velocity:
    input:
        recordings="results/{experiment}/recordings",
        matte="results/{experiment}/matte",
        cameras="results/{experiment}/calibration/cameras.json",
        seed="results/{experiment}/seed/particles.npz",
    output:
        velocity="results/{experiment}/velocity/velocity.json",
    resources:
        mem_mb=3000,
        runtime=30,
    log:
        "logs/{experiment}/velocity.log",
    benchmark:
        "benchmarks/{experiment}/velocity.tsv"
    params:
        experiment=lambda w: experiment(w.experiment),
    script:
        "../../stages/velocity.py"
