"""End-to-end: the thesis collapse target on a tiny configuration, run by Snakemake in a scratch copy of the
workflow whose config/config.yaml is the tiny one."""

import csv

import yaml

TINY = {"thesis": {"collapse": {
    "domain_size": 1.0, "resolution": 16, "duration": 0.05, "frames": 2, "mu_candidates": [5000.0, 10000.0],
    "lam_over_mu_candidates": [1.0],
    "table_4_1": {"eta": 10.0, "rows": {500: 0.11758, 2000: 0.28506}},
    "table_4_2": {"sigma_y": 1000.0, "rows": {0.01: 0.19640}},
}}}


def test_collapse_target_runs_and_resumes(workflow):
    tmp_path = workflow.root
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(TINY))  # replaces, not merges with, the default
    run = workflow.run("results/thesis/collapse.html")
    assert run.returncode == 0, run.stderr[-3000:]
    with open(tmp_path / "results/thesis/collapse.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["table"] for r in rows] == ["4.1", "4.1", "4.2"]
    for r in rows:
        # after 0.05 s the column has barely moved: the height is still close to the initial 0.4
        assert 0.3 < float(r["rheo_height"]) < 0.45
    page = (tmp_path / "results/thesis/collapse.html").read_text()
    assert "Figures 4.2 and 4.4" in page and page.count("data:image/png;base64,") == 4
    assert (tmp_path / "logs/thesis/calibrate.log").read_text().count("RMS relative difference") == 2
    again = workflow.run("results/thesis/collapse.html")
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr
    # a changed reference value reruns only the report, not the simulations
    changed = yaml.safe_load(yaml.safe_dump(TINY))
    changed["thesis"]["collapse"]["table_4_2"]["rows"] = {0.01: 0.2}
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(changed))
    plan = workflow.run("-n", "results/thesis/collapse.html")
    assert plan.returncode == 0, plan.stderr[-3000:]
    assert "thesis_collapse_report" in plan.stdout
    assert "thesis_calibration_run" not in plan.stdout and "thesis_predict" not in plan.stdout


def test_bad_config_value_is_refused(workflow):
    tmp_path = workflow.root
    bad = {"thesis": {"collapse": {"resolution": 2}}}
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(bad))
    run = workflow.run("-n", "results/thesis/collapse.html")
    assert run.returncode != 0
    assert "config/config.yaml (with --config): thesis.collapse.resolution" in run.stdout
    assert "2 must be at least 8" in run.stdout
