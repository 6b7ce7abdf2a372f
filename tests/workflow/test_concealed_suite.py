"""A small suite drawn from a seed, filmed, fitted, diagnosed and scored on tiny grids, whose score may not fall below
the one measured when this guard was set: on grids this coarse the recordings do not show the drawn effects (the
truth in the fit's simulation loses more than the base fit: none named, 0 of 2), so the guard is that nothing is
named where nothing should be (the null case and the miscalibrated camera)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SEED, COUNT = 2026, 4
FALSE_ALARMS_CEILING = 0  # of the null and out-of-library cases (measured: 0 of 2)


@pytest.mark.slow
def test_a_small_drawn_suite_scores_at_least_its_floor(workflow):
    cases = workflow.root / "suite"
    subprocess.run([sys.executable, "-m", "rheo.experiments.suite", "--seed", str(SEED), "--count", str(COUNT),
                    "--out", str(cases)], check=True, cwd=workflow.root,
                   env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])})
    (workflow.root / "tiny.yaml").write_text(
        "virheometry: {simulation: {cells_per_height: 4, cells_across: 4, max_offset: 0.05}}\n"
        "concealed:\n  cases: suite\n  scene: {frames: 6}\n  lab: {cells_per_height: 6, cells_across: 6}\n"
        "  fit: {stress_evaluations: 3, shares: [0.3, 0.7], moduli: [100.0, 300.0], evaluations: 6, starts: 1, "
        "rounds: 1}\n"
        "diagnose: {rung_evaluations: 2, refit_evaluations: 2, open_evaluations: 8}\n")
    run = workflow.run("results/concealed/summary.json", "--configfile", "tiny.yaml", timeout=3600)
    assert run.returncode == 0, run.stderr[-3000:]
    scores = json.loads((workflow.root / "results/concealed/summary.json").read_text())
    assert (scores["cases"], scores["null"], scores["outside"]) == (COUNT, 1, 1)
    assert scores["suite"]["seed"] == SEED and scores["code_version"]
    assert scores["false_alarms"] <= FALSE_ALARMS_CEILING, scores
