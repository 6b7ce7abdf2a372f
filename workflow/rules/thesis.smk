# Thesis Tables 4.1 and 4.2: column collapse, elastic constants calibrated on Table 4.1, Table 4.2 predicted.


rule thesis_calibration_run:
    output:
        "results/thesis/calibration/mu{mu}_lam{lam}/sigma_y{sigma_y}.json",
    resources:
        mem_mb=1500,
        runtime=30,
    log:
        "logs/thesis/calibration/mu{mu}_lam{lam}/sigma_y{sigma_y}.log",
    benchmark:
        "benchmarks/thesis/calibration/mu{mu}_lam{lam}/sigma_y{sigma_y}.tsv"
    params:
        setup=simulation_setup(),
        sigma_y=lambda w: float(w.sigma_y),
        eta=collapse_config()["table_4_1"]["eta"],
        elastic=lambda w: [float(w.mu), float(w.lam)],
    script:
        "../../stages/thesis_collapse_run.py"


rule thesis_calibrate:
    input:
        [
            f"results/thesis/calibration/mu{mu}_lam{lam}/sigma_y{sigma_y}.json"
            for mu, lam in elastic_candidates()
            for sigma_y in table_rows("table_4_1")
        ],
    output:
        "results/thesis/calibration.json",
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/thesis/calibrate.log",
    params:
        thesis_rows=collapse_config()["table_4_1"]["rows"],
    script:
        "../../stages/thesis_calibrate.py"


rule thesis_predict:
    input:
        calibration="results/thesis/calibration.json",
    output:
        "results/thesis/prediction/ratio{ratio}.json",
    resources:
        mem_mb=1500,
        runtime=30,
    log:
        "logs/thesis/prediction/ratio{ratio}.log",
    benchmark:
        "benchmarks/thesis/prediction/ratio{ratio}.tsv"
    params:
        setup=simulation_setup(),
        sigma_y=collapse_config()["table_4_2"]["sigma_y"],
        eta=lambda w: float(w.ratio) * collapse_config()["table_4_2"]["sigma_y"],
    script:
        "../../stages/thesis_collapse_run.py"


rule thesis_collapse_report:
    input:
        calibration="results/thesis/calibration.json",
        calibration_runs=rules.thesis_calibrate.input,
        predictions=expand("results/thesis/prediction/ratio{ratio}.json", ratio=table_rows("table_4_2")),
    output:
        csv="results/thesis/collapse.csv",
        html="results/thesis/collapse.html",
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/thesis/collapse_report.log",
    params:
        rows_41=collapse_config()["table_4_1"]["rows"],
        rows_42=collapse_config()["table_4_2"]["rows"],
    script:
        "../../stages/thesis_collapse_report.py"


def recovery_tables() -> dict:
    return config["thesis"].get("recovery", {})


rule thesis_report:
    input:
        collapse="results/thesis/collapse.csv",
        params=[f"results/{t['experiment']}/fit/params.json" for t in recovery_tables().values()],
    output:
        "results/thesis/report.html",
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/thesis/report.log",
    params:
        tables=recovery_tables(),
    script:
        "../../stages/thesis_report.py"
