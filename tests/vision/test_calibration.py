"""Calibration on OpenCV's real sample images (against OpenCV's published result) and on synthetic views of a board
lying on the floor with a known camera."""

import logging
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from rheo.vision.calibration import (
    _WORLD_FROM_BOARD,
    Board,
    CalibrationError,
    GroundView,
    adjust_ground_views,
    calibrate_intrinsics,
    ground_pose,
    pose_sigma,
    reprojection_rms,
    world_pose,
)
from rheo.vision.cameras import hemisphere, look_at

OPENCV_LEFT = Path(__file__).resolve().parents[3] / "shared" / "data" / "calibration" / "opencv_left"
BOARD = Board(columns=9, rows=6, square=0.025)


def test_real_images_match_opencv_reference():
    images = sorted(OPENCV_LEFT.glob("left*.jpg"))
    intr = calibrate_intrinsics(images, BOARD, fix_aspect_ratio=True)
    assert intr.K[0, 0] == pytest.approx(535.92, rel=0.005)
    assert intr.K[0, 0] == intr.K[1, 1]
    assert intr.rms_px <= 0.45
    assert max(intr.per_view_rms_px, key=intr.per_view_rms_px.get) == "left02.jpg"  # the reference's outlier view
    assert (intr.width, intr.height) == (640, 480)


def test_images_without_a_board_are_named_and_too_few_is_an_error(tmp_path, caplog):
    images = sorted(OPENCV_LEFT.glob("left*.jpg"))[:4]
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 127, np.uint8))
    with caplog.at_level(logging.WARNING):
        intr = calibrate_intrinsics([*images, blank], BOARD)
    assert "this camera: no 9x6 board found in 1 of 5 images: blank.png" in caplog.text
    assert intr.skipped == ["blank.png"]
    with pytest.raises(CalibrationError, match=r"camera left: only 1 of 2 images \(in .*\) show the 9x6 board "
                                               r"\(inner corners\); at least 3 are needed"):
        calibrate_intrinsics([images[0], blank], BOARD, camera="camera left")
    with pytest.raises(CalibrationError, match="camera left: no checkerboard images given"):
        calibrate_intrinsics([], BOARD, camera="camera left")
    unreadable = tmp_path / "broken.jpg"
    unreadable.write_bytes(b"not an image")
    with pytest.raises(CalibrationError, match=r"broken\.jpg: not a readable image"):
        calibrate_intrinsics([unreadable], BOARD)


def _render_floor_board(c2w: np.ndarray, K: np.ndarray, board: Board, size=(640, 480)) -> np.ndarray:
    """The board lying on the floor (its first inner corner at the world origin, columns along x, rows along z)."""
    px = 60  # texture pixels per square
    squares = (board.columns + 1, board.rows + 1)
    texture = np.full(((squares[1] + 2) * px, (squares[0] + 2) * px), 255, np.uint8)
    for i in range(squares[0]):
        for j in range(squares[1]):
            if (i + j) % 2 == 0:
                texture[(j + 1) * px:(j + 2) * px, (i + 1) * px:(i + 2) * px] = 0
    # texture pixel -> floor point (x, z) in m: the first inner corner is at texture pixel (2 px, 2 px)
    A = np.array([[board.square / px, 0, -2 * board.square], [0, board.square / px, -2 * board.square], [0, 0, 1]])
    w2c = np.linalg.inv(c2w)
    # floor point (x, 0, z) -> camera: columns for x and z, plus the translation
    H_floor = K @ np.stack([w2c[:3, 0], w2c[:3, 2], w2c[:3, 3]], axis=1)
    return cv2.warpPerspective(texture, H_floor @ A, size, flags=cv2.INTER_AREA, borderValue=200)


@pytest.mark.parametrize("eye", [(0.35, 0.45, -0.25), (-0.2, 0.3, 0.4), (0.1, 0.6, 0.06)])
def test_ground_board_gives_the_camera_pose_in_the_world_frame(eye):
    K = np.array([[800.0, 0, 320], [0, 800.0, 240], [0, 0, 1]])
    board = Board(9, 6, 0.03)
    center = np.array([4 * 0.03, 0.0, 2.5 * 0.03])
    truth = look_at(np.array(eye), center)
    gray = _render_floor_board(truth, K, board)
    c2w, rms, _ = ground_pose(gray, board, K, np.zeros(5))
    assert rms < 0.2
    cos = (np.trace(c2w[:3, :3].T @ truth[:3, :3]) - 1) / 2
    assert math.degrees(math.acos(min(1.0, cos))) < 0.2
    distance = np.linalg.norm(truth[:3, 3] - center)
    assert np.linalg.norm(c2w[:3, 3] - truth[:3, 3]) < 0.005 * distance



def _ground_views(board: Board, cameras, true_points: np.ndarray, noise_px: float, rng) -> list[GroundView]:
    """Noisy corners of ``true_points`` (board frame, board at the world origin) in every camera, and each camera's
    single-view pose against the nominal board."""
    nominal = board.object_points().astype(float)
    views = []
    for cam in cameras:
        w2c = np.linalg.inv(cam.c2w)
        rvec, _ = cv2.Rodrigues(w2c[:3, :3] @ _WORLD_FROM_BOARD)
        uv, _ = cv2.projectPoints(true_points, rvec, w2c[:3, 3], cam.K, cam.dist)
        uv = uv.reshape(-1, 2) + rng.normal(0.0, noise_px, uv.reshape(-1, 2).shape)
        _, rvec, tvec = cv2.solvePnP(nominal, uv, cam.K, cam.dist)
        views.append(GroundView(uv, cam.K, cam.dist, rvec.ravel(), tvec.ravel()))
    return views


def test_joint_adjustment_gives_calibrated_pose_uncertainties():
    board = Board(9, 6, 0.08)
    cameras = hemisphere(11, 2.0, [25.0, 45.0], [0.3, 0.1, 0.2], 400, 400, 40.0)
    rng = np.random.default_rng(0)
    z = []
    for _ in range(20):
        adjusted = adjust_ground_views(_ground_views(board, cameras, board.object_points(), 0.15, rng), board)
        assert adjusted.pixel_sigma == pytest.approx(0.15, rel=0.25)
        for view, covariance, cam in zip(adjusted.views, adjusted.covariances, cameras, strict=True):
            error = np.linalg.norm(world_pose(view)[:3, 3] - cam.c2w[:3, 3])
            z.append(error / pose_sigma(view, covariance)["center_m"])
    # a 3-D error over its 1-sigma norm: about 1 on average when the covariances are right
    assert 0.5 < np.sqrt(np.mean(np.square(z))) < 1.5


def test_joint_adjustment_recovers_the_shape_of_a_board_that_is_not_flat():
    board = Board(9, 6, 0.08)
    cameras = hemisphere(11, 2.0, [25.0, 45.0], [0.3, 0.1, 0.2], 400, 400, 40.0)
    nominal = board.object_points().astype(float)
    radius = np.linalg.norm(nominal[:, :2] - nominal[:, :2].mean(axis=0), axis=1)
    bulged = nominal - [0.0, 0.0, 1.0] * (0.005 * np.cos(0.5 * np.pi * radius / radius.max()))[:, None]  # 5 mm up
    views = _ground_views(board, cameras, bulged, 0.15, np.random.default_rng(1))
    adjusted = adjust_ground_views(views, board)
    # shape only: the world frame is the nominal board's, so compare after the best rigid alignment
    a, b = adjusted.board_points - adjusted.board_points.mean(axis=0), bulged - bulged.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    assert np.abs(a @ (u @ vt) - b).max() < 0.0015
    # the adjusted board explains the bulge: residuals at the noise level, below those against the nominal board
    assert np.mean(adjusted.rms_px) < 0.8 * np.mean([reprojection_rms(view, nominal) for view in views])
