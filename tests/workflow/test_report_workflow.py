"""The whole pipeline on the tiny virtual experiment: recordings to report, in a scratch copy of the workflow."""

import csv
import json
import re
import zipfile
from pathlib import Path

import imageio.v2 as imageio
import pytest


def test_tiny_report_end_to_end(workflow):
    run = workflow.run("results/tiny/report.html")
    assert run.returncode == 0, run.stderr[-3000:]
    root = workflow.root / "results/tiny"
    params = json.loads((root / "fit/params.json").read_text())
    assert params["convention"] == "rheo" and list(params["parameters"]) == ["mu", "lam", "tau_y", "K", "n"]
    for name, entry in params["parameters"].items():
        low, high = entry["interval"]
        assert low <= entry["value"] <= high, name
        assert isinstance(entry["determined"], bool) and "truth" in entry and "error" in entry, name
    assert params["parameters"]["tau_y"]["initial"] == 10.0  # the configured guess, never the truth
    with open(root / "fit/history.csv") as f:
        history = list(csv.DictReader(f))
    phases = [h["phase"] for h in history]
    # 8 survey points with the velocity stage's initial velocity, the same at rest, then the initial velocity
    assert phases[:17] == ["survey"] * 8 + ["survey, from rest"] * 8 + ["velocity"]
    assert phases.index("start 1") < phases.index("surface")
    assert {"loss", "best_loss", "mu", "tau_y", "vx"} <= set(history[0])
    held = [n for n, p in params["parameters"].items() if p["held_at_initial_guess"]]
    assert all(not params["parameters"][n]["determined"] for n in held)
    assert all(params["parameters"][n]["value"] == params["parameters"][n]["initial"] for n in held)
    # the reported material was simulated, and its loss is the one reported
    reported = [h for h in history if all(float(h[n]) == pytest.approx(p["value"], rel=1e-12)
                                          for n, p in params["parameters"].items())]
    assert reported and float(reported[-1]["loss"]) == params["final_loss"]
    # finished stages leave no checkpoint or stored evaluations behind
    assert not list(root.rglob("*.checkpoint")) and not list(root.rglob("*.evaluations.json"))
    page = (root / "report.html").read_text()
    assert len(re.findall(r'src="data:image/(png|gif);base64,', page)) >= 6  # tables, plots, frames, animations
    assert "http://" not in page and "Stage runtimes" in page and "τ_y" in page
    # Snakemake's own report collects the figures with their captions
    collected = workflow.run("--report", "report.zip", "results/tiny/report.html")
    assert collected.returncode == 0, collected.stderr[-3000:]
    with zipfile.ZipFile(workflow.root / "report.zip") as archive:
        names = {Path(n).name for n in archive.namelist()}
        index = archive.read(next(n for n in archive.namelist() if n.endswith("report/report.html"))).decode()
    assert {"synthesize.png", "cameras.png", "matte.png", "bunny.png", "report.html"} <= names
    assert "the virtual lab" in index.lower() or "virtual lab" in index
    assert len(imageio.mimread(root / "novel/bunny.mp4")) == 4
    assert "seed (radiance)" in (workflow.root / "logs/tiny/seed.log").read_text()
