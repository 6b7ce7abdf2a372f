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
    mask = imageio.imread(workflow.root / "results/clip/matte/phone/masks/000.png") > 127
    assert abs(mask.sum() - 20 * 15) < 60  # the blob of source frame 2
    cols = np.flatnonzero(mask.any(axis=0))
    assert abs(cols.min() - 15) <= 2


def test_real_experiment_without_recording_is_refused(workflow):
    run = workflow.run("-n", "results/opencv_left/matte.json")
    assert run.returncode != 0
    assert "a real experiment needs a recording section to ingest" in run.stdout + run.stderr
