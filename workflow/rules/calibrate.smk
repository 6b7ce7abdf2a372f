# calibrate: intrinsics and distortion from checkerboard images, extrinsics from the board on the floor.


rule calibrate:
    input:
        unpack(lambda w: calibration_inputs(w.experiment)),
    output:
        cameras="results/{experiment}/calibration/cameras.json",
        figure=report("results/{experiment}/calibration/cameras.png", caption="../report/calibrate.rst",
                      category="Calibration", subcategory="{experiment}"),
    resources:
        mem_mb=1000,
        runtime=10,
    log:
        "logs/{experiment}/calibrate.log",
    benchmark:
        "benchmarks/{experiment}/calibrate.tsv"
    params:
        calibration=lambda w: calibration_config(w.experiment),
    script:
        "../../stages/calibrate.py"
