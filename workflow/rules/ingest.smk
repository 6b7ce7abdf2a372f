# ingest: a real recording (video or image folder per camera) into the recordings layout that synthesize also writes.


rule ingest:
    input:
        lambda w: recording_sources(w.experiment),
    output:
        recordings=directory("results/{experiment}/recordings"),
        figure=report("results/{experiment}/ingest.png", caption="../report/ingest.rst", category="Recording",
                      subcategory="{experiment}"),
    wildcard_constraints:
        experiment=experiments_of_kind("real"),
    resources:
        mem_mb=1000,
        runtime=10,
    log:
        "logs/{experiment}/ingest.log",
    benchmark:
        "benchmarks/{experiment}/ingest.tsv"
    params:
        recording=lambda w: recording_config(w.experiment),
    script:
        "../../stages/ingest.py"
