"""ingest through Snakemake: a real recording (a video the test encodes) into the recordings layout, then matte."""

import json

import imageio.v2 as imageio
import numpy as np
import yaml


def test_ingest_video_then_matte(workflow, tmp_path):
    plate = np.full((60, 80, 3), (150, 120, 90), np.uint8)
    frames = []
    for k in range(12):
        frame = plate.copy()
        frame[20:40, 5 + 5 * k:20 + 5 * k] = (200, 30, 20)  # a red blob moving right
        frames.append(frame)
    video = tmp_path / "clip.mp4"
    imageio.mimwrite(video, frames, fps=24, macro_block_size=1, quality=10)
    imageio.imwrite(tmp_path / "plate.png", plate)
    exp = {"name": "clip", "kind": "real",
           "recording": {"cameras": {"phone": {"source": str(video), "start_frame": 2, "stop_frame": 10, "fps": 12,
                                               "clean_plate": str(tmp_path / "plate.png")}}}}
    (workflow.root / "config/experiments/clip.yaml").write_text(yaml.safe_dump(exp))
    run = workflow.run("results/clip/matte.json")
    assert run.returncode == 0, run.stderr[-3000:]
    rec = workflow.root / "results/clip/recordings"
    assert json.loads((rec / "recording.json").read_text())["phone"] == {"frames": 4, "fps": 12.0, "source": str(video)}
    assert len(list((rec / "phone/frames").glob("*.png"))) == 4 and (rec / "phone/clean_plate.png").is_file()
    assert (workflow.root / "results/clip/ingest.png").stat().st_size > 5_000  # the contact sheet
    mask = imageio.imread(workflow.root / "results/clip/matte/phone/masks/000.png") > 127
    assert abs(mask.sum() - 20 * 15) < 60  # the blob of source frame 2
    cols = np.flatnonzero(mask.any(axis=0))
    assert abs(cols.min() - 15) <= 2


def test_real_experiment_without_recording_is_refused(workflow):
    run = workflow.run("-n", "results/opencv_left/matte.json")
    assert run.returncode != 0
    assert "a real experiment needs a recording section to ingest" in run.stdout + run.stderr


def test_real_recording_with_silhouette_refinement(workflow):
    """The tiny lab's camera 0 treated as a real recording: ingest, matte, proxy, calibrate with the silhouette."""
    lab = workflow.run("results/tiny/truth.json")
    assert lab.returncode == 0, lab.stderr[-3000:]
    rec = workflow.root / "results/tiny/recordings/cam00"
    tiny = yaml.safe_load((workflow.root / "config/experiments/tiny.yaml").read_text())
    exp = {"name": "tinyreal", "kind": "real", "proxy": tiny["proxy"],
           "recording": {"cameras": {"cam00": {"source": str(rec / "frames"), "source_fps": 15.0,
                                               "clean_plate": str(rec / "clean_plate.png")}}},
           "calibration": {"board": {"columns": 9, "rows": 6, "square": 0.1}, "fix_aspect_ratio": True,
                           "silhouette_refinement": True,
                           "cameras": {"cam00": {"images": str(rec / "checkerboard/*.png"),
                                                 "ground_image": str(rec / "ground_board.png"),
                                                 "ground_origin": [0.1, 0.0, 0.25]}}}}
    (workflow.root / "config/experiments/tinyreal.yaml").write_text(yaml.safe_dump(exp))
    run = workflow.run("results/tinyreal/calibration/cameras.json")
    assert run.returncode == 0, run.stderr[-3000:]
    cam = json.loads((workflow.root / "results/tinyreal/calibration/cameras.json").read_text())["cameras"]["cam00"]
    truth = json.loads((workflow.root / "results/tiny/truth.json").read_text())["cameras"]["cam00"]
    assert cam["silhouette_iou_after"] >= cam["silhouette_iou_before"] > 0.9
    # a silhouette pins the distance only as well as matte and proxy outlines agree (1 px is about 1.4 % here):
    # from the floor board's accurate pose it may drift by a few per cent of the 2 m distance
    moved = np.linalg.norm(np.array(cam["c2w"])[:3, 3] - np.array(truth["c2w"])[:3, 3])
    assert moved < 0.1
