"""Your own video, end to end: the example phone recording (a video, a clean plate, checkerboard photos and the
board on the floor) through every stage to the report, on a coarse grid with a short fit."""

import json

import yaml

COARSE = {"simulation": {"domain_size": 1.0, "resolution": 16},
          "fit": {"rays_per_view": 256, "velocity": {"iterations": 2}, "seed": {"levels": 1, "iterations": 20},
                  "warmup": {"frames": 2, "samples": 4, "velocity_evaluations": 2},
                  "full": {"evaluations": 4, "starts": 1, "rounds": 1}}}


def test_the_example_phone_video_goes_from_an_mp4_to_a_report(workflow):
    path = workflow.root / "config/experiments/example_phone.yaml"
    exp = yaml.safe_load(path.read_text())
    exp.update(COARSE)
    exp["proxy"]["spacing"] = 0.02
    path.write_text(yaml.safe_dump(exp))
    run = workflow.run("results/example_phone/report.html")
    assert run.returncode == 0, run.stderr[-3000:]
    root = workflow.root / "results/example_phone"
    recording = json.loads((root / "recordings/recording.json").read_text())
    assert recording["phone"]["frames"] == 12 and recording["phone"]["fps"] == 22.0
    camera = json.loads((root / "calibration/cameras.json").read_text())["cameras"]["phone"]
    assert camera["rms_px"] < 0.5  # the lens, from the checkerboard photos
    params = json.loads((root / "fit/params.json").read_text())
    assert set(params["parameters"]) == {"mu", "lam", "tau_y", "K", "n"}
    assert all(entry.get("truth") is None for entry in params["parameters"].values())  # a stranger's video
    assert (root / "novel/bunny.mp4").stat().st_size > 0
    page = (root / "report.html").read_text()
    assert "τ_y" in page and "example_phone" in page
