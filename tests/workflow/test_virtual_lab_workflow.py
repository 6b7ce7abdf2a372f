"""The virtual lab and the calibration of its cameras, through Snakemake on the tiny experiment."""

import json

import cv2
import imageio.v2 as imageio
import numpy as np
import yaml

from rheo.vision.calibration import pose_errors


def test_tiny_virtual_lab_and_calibration(workflow):
    run = workflow.run("results/tiny/calibration/cameras.json")
    assert run.returncode == 0, run.stderr[-3000:]
    root = workflow.root / "results/tiny"
    truth = json.loads((root / "truth.json").read_text())
    assert truth["material"]["tau_y"] == 20.0 and len(truth["times"]) == 4 and len(truth["cameras"]) == 3
    for cam in truth["cameras"]:
        rec = root / "recordings" / cam
        frames = sorted((rec / "frames").glob("*.png"))
        masks = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) > 127 for p in sorted((rec / "masks").glob("*.png"))]
        assert len(frames) == len(masks) == 4
        assert all(0.001 < m.mean() < 0.5 for m in masks)  # the material is in view, not filling it
        first = cv2.imread(str(frames[0]))
        plate = cv2.imread(str(rec / "clean_plate.png"))
        differs = np.abs(first.astype(int) - plate.astype(int)).max(axis=2) > 30
        assert (differs & masks[0]).sum() > 0.9 * masks[0].sum()  # the plate is the scene without the material
        video = imageio.mimread(rec / "video.mp4")
        assert len(video) == 4 and video[0].shape == first.shape
        assert len(list((rec / "checkerboard").glob("*.png"))) == 12 and (rec / "ground_board.png").is_file()
    # tiny's 320 x 240 images calibrate less precisely than the lab's (see test_lab_calibration for the targets)
    calibration = json.loads((root / "calibration/cameras.json").read_text())
    for name, cam in calibration["cameras"].items():
        errors = pose_errors(cam, truth["cameras"][name], look_at=[0.5, 0.1, 0.5])
        assert cam["errors_vs_truth"]["fx"] == errors["fx"]  # the stage scores itself against the lab's truth
        assert max(abs(errors[k]) for k in ("fx", "fy", "cx", "cy")) < 0.02, errors
        assert errors["rotation_deg"] < 0.5 and errors["translation_rel"] < 0.02, errors
    assert calibration["ground_boards"][0]["cameras"] == sorted(calibration["cameras"])  # adjusted together
    assert (root / "synthesize.png").is_file() and (root / "calibration/cameras.png").is_file()


def test_tiny_matte_and_rerun_scope(workflow):
    run = workflow.run("results/tiny/matte.json")
    assert run.returncode == 0, run.stderr[-3000:]
    report = json.loads((workflow.root / "results/tiny/matte.json").read_text())
    assert report["mean_iou"] > 0.95 and len(report["views"]) == 3
    masks = sorted((workflow.root / "results/tiny/matte/cam00/masks").glob("*.png"))
    assert len(masks) == 4 and (workflow.root / "results/tiny/matte.png").is_file()
    # a matting parameter reruns matte and nothing upstream
    path = workflow.root / "config/experiments/tiny.yaml"
    exp = yaml.safe_load(path.read_text())
    exp["matte"] = {"close_px": 3}
    path.write_text(yaml.safe_dump(exp))
    plan = workflow.run("-n", "results/tiny/matte.json")
    assert plan.returncode == 0, plan.stderr[-3000:]
    assert "rule matte" in plan.stdout or "matte" in plan.stdout.split("Job stats")[-1]
    assert "synthesize" not in plan.stdout
    # and one stage can be rerun on request
    again = workflow.run("results/tiny/matte.json", "-R", "matte", "-n")
    assert again.returncode == 0 and "synthesize" not in again.stdout


def test_dag_lists_every_stage_through_the_report(workflow):
    plan = workflow.run("-n", "results/cup/report.html")
    assert plan.returncode == 0, plan.stderr[-3000:]
    stats = plan.stdout.split("Job stats")[1]
    for stage in ("synthesize", "calibrate", "matte", "proxy", "seed", "velocity", "fit_warmup", "fit", "report"):
        assert f"\n{stage} " in stats, stage
