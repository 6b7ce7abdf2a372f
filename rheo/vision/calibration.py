"""Checkerboard calibration: intrinsics and distortion (OpenCV's model and order), and camera poses in the
simulator's world frame (y up, floor at y = 0) from a board lying on the ground.

Camera axes follow OpenCV (x right, y down, z forward); ``c2w`` maps camera coordinates to world coordinates.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import least_squares

logger = logging.getLogger(__name__)

# world_from_board for a board lying on the floor: board x -> world x, board y -> world z, board -z -> world y (up)
_WORLD_FROM_BOARD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


class CalibrationError(ValueError):
    """Calibration images that cannot give a calibration."""


@dataclass(frozen=True)
class Board:
    """A checkerboard: inner corners per row (``columns``) and per column (``rows``), square side in m."""

    columns: int = 9
    rows: int = 6
    square: float = 0.025

    def object_points(self) -> np.ndarray:
        """Corner positions in the board frame (z = 0), in OpenCV's detection order."""
        grid = np.mgrid[0:self.columns, 0:self.rows].T.reshape(-1, 2)
        return np.hstack([grid * self.square, np.zeros((len(grid), 1))]).astype(np.float32)


@dataclass
class Intrinsics:
    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    rms_px: float
    per_view_rms_px: dict[str, float] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


def read_gray(path: str | Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise CalibrationError(f"{path}: not a readable image")
    return image


def _grid_residual(corners: np.ndarray, board: Board) -> float:
    """RMS distance (px) of the corners from the best plane-to-image homography of the board grid."""
    grid = board.object_points()[:, :2]
    H, _ = cv2.findHomography(grid, corners.reshape(-1, 2), 0)
    fitted = cv2.perspectiveTransform(grid[None], H)[0]
    return float(np.sqrt(np.mean(np.sum((fitted - corners.reshape(-1, 2)) ** 2, axis=1))))


def find_corners(gray: np.ndarray, board: Board, max_grid_residual: float = 2.5) -> np.ndarray | None:
    """Sub-pixel inner corners (N, 1, 2) of ``board`` in ``gray``, or None where the board is not found.

    OpenCV's classic detector with corner refinement (the one behind OpenCV's reference calibrations). Under strong
    foreshortening it can return a grid that is not a plane board's (homography residual above
    ``max_grid_residual`` px; lens distortion alone stays well below); then OpenCV's sector-based detector decides.
    """
    size = (board.columns, board.rows)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH + cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(gray, size, flags=flags)
    if found:
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
        # the refinement window must stay inside the squares around each corner
        c = corners.reshape(board.rows, board.columns, 2)
        side = min(np.linalg.norm(np.diff(c, axis=0), axis=-1).min(), np.linalg.norm(np.diff(c, axis=1), axis=-1).min())
        half = int(np.clip(0.5 * side, 2, 11))
        corners = cv2.cornerSubPix(gray, corners, (half, half), (-1, -1), criteria)
        if _grid_residual(corners, board) <= max_grid_residual:
            return corners
    found_sb, corners_sb = cv2.findChessboardCornersSB(gray, size,
                                                       flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
    if found_sb and (not found or _grid_residual(corners_sb, board) < _grid_residual(corners, board)):
        return corners_sb.astype(np.float32)
    return corners if found else None


def canonical_order(gray: np.ndarray, corners: np.ndarray, board: Board) -> np.ndarray:
    """Corners ordered so that the square diagonally inside the first corner is dark: the same board then gives
    the same world frame from any side (OpenCV may return the order rotated by 180 degrees)."""
    c = corners.reshape(-1, 2)
    probe = c[0] + 0.5 * ((c[1] - c[0]) + (c[board.columns] - c[0]))
    far = c[-1] + 0.5 * ((c[-2] - c[-1]) + (c[-1 - board.columns] - c[-1]))
    x0, y0 = np.clip(np.round(probe).astype(int), 0, np.array(gray.shape[::-1]) - 1)
    x1, y1 = np.clip(np.round(far).astype(int), 0, np.array(gray.shape[::-1]) - 1)
    if int(gray[y0, x0]) > int(gray[y1, x1]):
        return corners[::-1].copy()
    return corners


def calibrate_intrinsics(images: Sequence[str | Path], board: Board, *, fix_aspect_ratio: bool = False,
                         min_views: int = 3, camera: str = "this camera") -> Intrinsics:
    """Intrinsics and distortion (k1, k2, p1, p2, k3) from checkerboard photos of one camera (named ``camera`` in
    messages).

    Images where the board is not found are skipped with a warning naming them; fewer than ``min_views`` usable
    images is a CalibrationError.
    """
    if not images:
        raise CalibrationError(f"{camera}: no checkerboard images given")
    object_points, image_points, names, skipped = [], [], [], []
    size = None
    for path in images:
        gray = read_gray(path)
        if size is None:
            size = gray.shape[::-1]
        elif gray.shape[::-1] != size:
            raise CalibrationError(f"{path}: image size {gray.shape[::-1]} differs from the first image's {size}")
        corners = find_corners(gray, board)
        if corners is None:
            skipped.append(Path(path).name)
            continue
        object_points.append(board.object_points())
        image_points.append(corners)
        names.append(Path(path).name)
    if skipped:
        logger.warning("%s: no %dx%d board found in %d of %d images: %s", camera, board.columns, board.rows,
                       len(skipped), len(images), ", ".join(skipped))
    if len(names) < min_views:
        raise CalibrationError(f"{camera}: only {len(names)} of {len(images)} images (in {Path(images[0]).parent}) "
                               f"show the {board.columns}x{board.rows} board (inner corners); at least {min_views} "
                               "are needed")
    flags = cv2.CALIB_FIX_ASPECT_RATIO if fix_aspect_ratio else 0
    K0 = np.eye(3)
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(object_points, image_points, size, K0, None, flags=flags)
    per_view = {}
    for name, obj, img, rvec, tvec in zip(names, object_points, image_points, rvecs, tvecs, strict=True):
        projected, _ = cv2.projectPoints(obj, rvec, tvec, K, dist)
        per_view[name] = float(np.sqrt(np.mean(np.sum((projected - img) ** 2, axis=-1))))
    return Intrinsics(width=size[0], height=size[1], K=K, dist=dist.ravel()[:5], rms_px=float(rms),
                      per_view_rms_px=per_view, skipped=skipped)


@dataclass
class GroundView:
    """One camera's view of the board lying on the floor: its corners (N, 2, canonical order), the camera's
    intrinsics, and the board-to-camera pose (Rodrigues ``rvec``, ``tvec``)."""

    corners: np.ndarray
    K: np.ndarray
    dist: np.ndarray
    rvec: np.ndarray
    tvec: np.ndarray
    source: str = "image"


def locate_ground_board(gray: np.ndarray, board: Board, K: np.ndarray, dist: np.ndarray,
                        source: str = "image") -> GroundView:
    """The board lying on the floor in one camera's image, and that camera's pose relative to it (PnP, then
    Levenberg-Marquardt)."""
    corners = find_corners(gray, board)
    if corners is None:
        raise CalibrationError(f"{source}: no {board.columns}x{board.rows} board found for the world frame")
    corners = canonical_order(gray, corners, board)
    obj = board.object_points()
    ok, rvec, tvec = cv2.solvePnP(obj, corners, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise CalibrationError(f"{source}: the board pose could not be solved")
    rvec, tvec = cv2.solvePnPRefineLM(obj, corners, K, dist, rvec, tvec)
    return GroundView(corners.reshape(-1, 2).astype(float), np.asarray(K, float), np.asarray(dist, float).ravel(),
                      rvec.ravel(), tvec.ravel(), source)


def world_pose(view: GroundView, origin: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Camera-to-world transform (4x4) of a ground view. The world frame: the board's first corner at ``origin``
    (x, z on the floor), y up out of the floor."""
    R, _ = cv2.Rodrigues(view.rvec)
    center_board = -R.T @ view.tvec
    world_from_board = _WORLD_FROM_BOARD
    if (world_from_board @ center_board)[1] < 0:  # the camera must be above the floor: flip the board's y and z
        world_from_board = world_from_board @ np.diag([1.0, -1.0, -1.0])
    c2w = np.eye(4)
    c2w[:3, :3] = world_from_board @ R.T
    c2w[:3, 3] = world_from_board @ center_board + np.asarray(origin, dtype=float)
    return c2w


def reprojection_rms(view: GroundView, points: np.ndarray) -> float:
    """RMS distance (px) between the view's corners and ``points`` (board frame) projected into it."""
    projected, _ = cv2.projectPoints(np.asarray(points, float), view.rvec, view.tvec, view.K, view.dist)
    return float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - view.corners) ** 2, axis=-1))))


def pose_sigma(view: GroundView, covariance: np.ndarray) -> dict:
    """1-sigma rotation (degrees) and camera-centre (m) uncertainty from the 6x6 covariance of (rvec, tvec)."""

    def center(params: np.ndarray) -> np.ndarray:
        R, _ = cv2.Rodrigues(params[:3])
        return -R.T @ params[3:]

    params = np.r_[view.rvec, view.tvec]
    dC = np.stack([(center(params + h) - center(params - h)) / 2e-7 for h in np.eye(6) * 1e-7], axis=1)
    return {"rotation_deg": float(np.degrees(np.sqrt(np.trace(covariance[:3, :3])))),
            "center_m": float(np.sqrt(np.trace(dC @ covariance @ dC.T)))}


@dataclass
class GroundAdjustment:
    """Cameras adjusted together on one ground board: their views (updated poses), each pose's 6x6 covariance of
    (rvec, tvec), the board's adjusted corners (board frame), each view's reprojection RMS (px), and the pixel noise
    (px, 1 sigma per coordinate) the adjustment assumed."""

    views: list[GroundView]
    covariances: list[np.ndarray]
    board_points: np.ndarray
    rms_px: list[float]
    pixel_sigma: float


def adjust_ground_views(views: Sequence[GroundView], board: Board, tolerance: float = 5e-4) -> GroundAdjustment:
    """Bundle adjustment of the cameras that see the same board lying on the floor.

    Unknowns: every camera's pose and every corner of the board (a printed board lying on a floor is neither exactly
    flat nor exactly to scale); residuals: the corners' reprojection errors in all views, whitened by the pixel noise
    of the single-camera fits, and each corner's offset from the nominal board, whitened by ``tolerance`` (m,
    1 sigma), which also fixes the world frame. Covariances come from the Gauss-Newton normal matrix at the optimum,
    so each pose's uncertainty includes what the board's own uncertainty contributes.
    """
    nominal = board.object_points().astype(float)
    n, m = len(nominal), len(views)
    squared = sum(reprojection_rms(view, nominal) ** 2 * n for view in views)
    pixel_sigma = max(float(np.sqrt(squared / max(2 * n * m - 6 * m, 1))), 0.02)
    corners = np.concatenate([view.corners.ravel() for view in views])
    j = np.arange(n)[:, None, None]
    point_rows = 2 * j + np.arange(2)[None, :, None]
    point_cols = 6 * m + 3 * j + np.arange(3)[None, None, :]

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x[:6 * m].reshape(m, 6), x[6 * m:].reshape(n, 3)

    def residuals(x: np.ndarray) -> np.ndarray:
        poses, points = unpack(x)
        projected = [cv2.projectPoints(points, p[:3], p[3:], v.K, v.dist)[0].ravel()
                     for p, v in zip(poses, views, strict=True)]
        return np.r_[(np.concatenate(projected) - corners) / pixel_sigma, ((points - nominal) / tolerance).ravel()]

    def jacobian(x: np.ndarray) -> np.ndarray:
        poses, points = unpack(x)
        J = np.zeros((2 * n * m + 3 * n, 6 * m + 3 * n))
        for i, (p, v) in enumerate(zip(poses, views, strict=True)):
            _, d = cv2.projectPoints(points, p[:3], p[3:], v.K, v.dist)
            R, _ = cv2.Rodrigues(p[:3])
            J[2 * n * i:2 * n * (i + 1), 6 * i:6 * i + 6] = d[:, :6] / pixel_sigma
            # a corner moves in the camera as the translation does, rotated: d(pixel)/d(point) = d(pixel)/d(t) R
            J[2 * n * i + point_rows, point_cols] = d[:, 3:6].reshape(n, 2, 3) @ R / pixel_sigma
        J[2 * n * m:, 6 * m:] = np.eye(3 * n) / tolerance
        return J

    x0 = np.r_[np.concatenate([np.r_[v.rvec, v.tvec] for v in views]), nominal.ravel()]
    solution = least_squares(residuals, x0, jac=jacobian, method="lm", xtol=1e-12, ftol=1e-12)
    covariance = np.linalg.pinv(solution.jac.T @ solution.jac)
    poses, points = unpack(solution.x)
    adjusted = [GroundView(v.corners, v.K, v.dist, p[:3].copy(), p[3:].copy(), v.source)
                for p, v in zip(poses, views, strict=True)]
    return GroundAdjustment(adjusted, [covariance[6 * i:6 * i + 6, 6 * i:6 * i + 6] for i in range(m)], points,
                            [reprojection_rms(v, points) for v in adjusted], pixel_sigma)


def ground_pose(gray: np.ndarray, board: Board, K: np.ndarray, dist: np.ndarray, *,
                origin: Sequence[float] = (0.0, 0.0, 0.0), source: str = "image") -> tuple[np.ndarray, float, dict]:
    """One camera's camera-to-world transform (4x4) from a photo of the board lying on the floor, the reprojection
    RMS (px), and the pose's 1-sigma uncertainty (see ``pose_sigma``); ``world_pose`` gives the world frame."""
    adjusted = adjust_ground_views([locate_ground_board(gray, board, K, dist, source)], board)
    view = adjusted.views[0]
    return world_pose(view, origin), adjusted.rms_px[0], pose_sigma(view, adjusted.covariances[0])


def camera_record(intr: Intrinsics, c2w: np.ndarray, pose_rms_px: float, sigma: dict | None = None) -> dict:
    """One camera as written to cameras.json."""
    return {"width": intr.width, "height": intr.height, "K": intr.K.tolist(), "dist": intr.dist.tolist(),
            "c2w": c2w.tolist(), "rms_px": intr.rms_px, "pose_rms_px": pose_rms_px, "pose_sigma": sigma,
            "per_view_rms_px": intr.per_view_rms_px, "skipped_images": intr.skipped, "axes": "opencv"}


def pose_errors(estimated: dict, truth: dict, look_at=None) -> dict:
    """Errors of one calibrated camera against the truth (both camera records): relative focal lengths and
    principal point, rotation angle (degrees) and camera-centre distance relative to the camera's distance from
    ``look_at`` (or from the world origin)."""
    K, Kt = np.asarray(estimated["K"]), np.asarray(truth["K"])
    c2w, c2w_t = np.asarray(estimated["c2w"]), np.asarray(truth["c2w"])
    cos = np.clip((np.trace(c2w[:3, :3].T @ c2w_t[:3, :3]) - 1) / 2, -1.0, 1.0)
    target = np.zeros(3) if look_at is None else np.asarray(look_at, float)
    distance = np.linalg.norm(c2w_t[:3, 3] - target)
    return {"fx": K[0, 0] / Kt[0, 0] - 1, "fy": K[1, 1] / Kt[1, 1] - 1, "cx": K[0, 2] / Kt[0, 2] - 1,
            "cy": K[1, 2] / Kt[1, 2] - 1, "rotation_deg": float(np.degrees(np.arccos(cos))),
            "translation_rel": float(np.linalg.norm(c2w[:3, 3] - c2w_t[:3, 3]) / distance)}
