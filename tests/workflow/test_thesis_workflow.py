"""End-to-end: the thesis collapse target on a tiny configuration, run by Snakemake in a scratch copy of the
workflow whose config/config.yaml is the tiny one."""

import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[2]

TINY = {"thesis": {"collapse": {
    "domain_size": 1.0, "resolution": 16, "duration": 0.05, "frames": 2, "mu_candidates": [5000.0, 10000.0],
    "lam_over_mu_candidates": [1.0],
    "table_4_1": {"eta": 10.0, "rows": {500: 0.11758, 2000: 0.28506}},
    "table_4_2": {"sigma_y": 1000.0, "rows": {0.01: 0.19640}},
}}}


def _snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    executable = shutil.which("snakemake") or str(Path(sys.executable).parent / "snakemake")
    return subprocess.run([executable, *args, "-j2"],
                          cwd=workdir, env=env, capture_output=True, text=True, timeout=600)


def test_collapse_target_runs_and_resumes(tmp_path):
    for item in ("Snakefile", "workflow", "stages", "config"):
        src = REPO / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tmp_path / item)
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(TINY))  # replaces, not merges with, the default
    run = _snakemake(tmp_path, "results/thesis/collapse.html")
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
    again = _snakemake(tmp_path, "results/thesis/collapse.html")
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr
    # a changed reference value reruns only the report, not the simulations
    changed = yaml.safe_load(yaml.safe_dump(TINY))
    changed["thesis"]["collapse"]["table_4_2"]["rows"] = {0.01: 0.2}
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(changed))
    plan = _snakemake(tmp_path, "-n", "results/thesis/collapse.html")
    assert plan.returncode == 0, plan.stderr[-3000:]
    assert "thesis_collapse_report" in plan.stdout
    assert "thesis_calibration_run" not in plan.stdout and "thesis_predict" not in plan.stdout


def test_bad_config_value_is_refused(tmp_path):
    shutil.copy(REPO / "Snakefile", tmp_path / "Snakefile")
    for item in ("workflow", "stages", "config"):
        shutil.copytree(REPO / item, tmp_path / item)
    bad = {"thesis": {"collapse": {"resolution": 2}}}
    (tmp_path / "config/config.yaml").write_text(yaml.safe_dump(bad))
    run = _snakemake(tmp_path, "-n", "results/thesis/collapse.html")
    assert run.returncode != 0
    assert "2 is less than the minimum of 8" in run.stdout + run.stderr
