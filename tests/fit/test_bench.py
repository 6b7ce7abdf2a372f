"""The fit benchmark's timings and projections, on objectives whose durations are known."""

import json
import time

import pytest

from rheo.experiments.rheometer import RESULT_KEYS
from rheo.fit import bench

SECONDS = {"ref_Paste_2.0_2.0_1": 0.4, "ref_Paste_7.0_7.0_2": 0.1}


def sleeping_comparisons(setups, simulation, law=None):
    return {name: (lambda x, s=SECONDS[name]: time.sleep(s)) for name in setups}


def test_bench_times_each_setup_and_projects_the_fit_between_shared_and_serial_evaluations(tmp_path, monkeypatch):
    monkeypatch.setattr(bench, "comparisons", sleeping_comparisons)
    for name in SECONDS:
        folder = tmp_path / "setups" / name
        folder.mkdir(parents=True)
        (folder / "setup.json").write_text(json.dumps({"folder": f"data/{name}"}))
        (folder / "masks.npz").write_bytes(b"")
    fit = tmp_path / "Paste" / "fit"
    fit.mkdir(parents=True)
    (fit / "params.json").write_text(json.dumps({key: {"value": 1.0} for key in RESULT_KEYS.values()}))
    (fit / "history.csv").write_text("loss\n" + "0.1\n" * 300)

    record = bench.measure_material("Paste", tmp_path, tmp_path / "benchmarks", {}, workers=2)

    assert record["fit_evaluations"] == 300
    assert record["seconds_per_setup"] == pytest.approx(SECONDS, abs=0.1)
    assert record["seconds_per_evaluation"] == pytest.approx(0.4, abs=0.1)  # the longest setup sets the pace
    # 300 evaluations of 0.5 s of simulation on two workers (1.25 min), or of 0.4 s each one at a time (2 min)
    assert record["projected_fit_min"]["side_by_side"] == pytest.approx(1.25, abs=0.15)
    assert record["projected_fit_min"]["one_at_a_time"] == pytest.approx(2.0, abs=0.3)
    assert "measured_fit_min" not in record
