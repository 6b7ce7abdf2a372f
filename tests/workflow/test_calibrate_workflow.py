"""The calibrate stage through Snakemake on OpenCV's real sample images; a bad experiment key is refused."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

OPENCV_LEFT = Path(__file__).resolve().parents[3] / "shared" / "data" / "calibration" / "opencv_left"


def _experiment(workflow, **changes):
    path = workflow.root / "config/experiments/opencv_left.yaml"
    exp = yaml.safe_load(path.read_text())
    cam = exp["calibration"]["cameras"]["left"]
    cam["images"] = str(OPENCV_LEFT / "left*.jpg")
    cam["ground_image"] = str(OPENCV_LEFT / "left01.jpg")
    exp["calibration"].update(changes)
    path.write_text(yaml.safe_dump(exp))


def test_calibrate_opencv_left(workflow):
    _experiment(workflow)
    run = workflow.run("results/opencv_left/calibration/cameras.json")
    assert run.returncode == 0, run.stderr[-3000:]
    cameras = json.loads((workflow.root / "results/opencv_left/calibration/cameras.json").read_text())["cameras"]
    left = cameras["left"]
    K, c2w = np.array(left["K"]), np.array(left["c2w"])
    assert K[0, 0] == pytest.approx(535.92, rel=0.005) and left["rms_px"] <= 0.45
    assert len(left["dist"]) == 5 and (left["width"], left["height"]) == (640, 480)
    assert np.allclose(c2w[:3, :3] @ c2w[:3, :3].T, np.eye(3), atol=1e-9) and c2w[1, 3] > 0  # above the floor
    assert (workflow.root / "results/opencv_left/calibration/cameras.png").stat().st_size > 10_000
    assert "camera left: fx=" in (workflow.root / "logs/opencv_left/calibrate.log").read_text()


def test_bad_experiment_key_is_named(workflow):
    _experiment(workflow, fix_aspect=True)
    run = workflow.run("-n", "results/opencv_left/calibration/cameras.json")
    assert run.returncode != 0
    assert "config/experiments/opencv_left.yaml: calibration" in run.stdout
    assert "'fix_aspect' (did you mean 'fix_aspect_ratio'?) is not a key here" in run.stdout
