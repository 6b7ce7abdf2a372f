"""Calibration of a virtual-lab camera from the lab's own renderings, against the camera that rendered them."""

import cv2
import numpy as np
import pytest

from rheo.experiments.virtual_lab import LabBoard, board_poses, render_board_view
from rheo.render.lab import FloorBoard, render
from rheo.vision.calibration import Board, calibrate_intrinsics, camera_record, ground_pose, pose_errors
from rheo.vision.cameras import hemisphere


@pytest.mark.parametrize("distortion", [(0.0, 0.0, 0.0, 0.0, 0.0), (0.12, -0.25, 0.0, 0.0, 0.1)],
                         ids=["pinhole", "phone-like distortion"])
def test_lab_camera_is_recovered(tmp_path, distortion):
    camera = hemisphere(1, 2.0, [30.0, 30.0], [0.5, 0.1, 0.5], 480, 360, 40.0, distortion)[0]
    board = LabBoard(9, 6, 0.08, ground_origin=(0.18, 0.3))
    rng = np.random.default_rng(1)
    paths = []
    for i, pose in enumerate(board_poses(camera, board, rng)):
        path = tmp_path / f"{i:02d}.png"
        cv2.imwrite(str(path), render_board_view(camera, board, pose, rng))
        paths.append(path)
    spec = Board(board.columns, board.rows, board.square)
    intr = calibrate_intrinsics(paths, spec, fix_aspect_ratio=True)
    ground, _ = render(camera, board=FloorBoard(9, 6, 0.08, (0.18, 0.3)), rng=rng)
    gray = (ground.astype(float) @ [0.299, 0.587, 0.114]).astype(np.uint8)
    c2w, rms, sigma = ground_pose(gray, spec, intr.K, intr.dist, origin=(0.18, 0.0, 0.3))
    errors = pose_errors(camera_record(intr, c2w, rms, sigma), camera.record(), look_at=[0.5, 0.1, 0.5])
    assert 0 < sigma["rotation_deg"] < 0.2 and 0 < sigma["center_m"] < 0.01
    for key in ("fx", "fy", "cx", "cy"):
        assert abs(errors[key]) < 0.005, errors
    assert errors["rotation_deg"] < 0.2 and errors["translation_rel"] < 0.005, errors
