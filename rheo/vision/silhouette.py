"""Refine a camera pose by aligning the proxy's silhouette with the material's mask in the first frame (for real
recordings, where the camera pose rarely comes with ground truth; replaces aligning overlays by hand).

A silhouette does not fix every pose direction (an axially symmetric cup looks the same from anywhere on a circle
around it), so a weak prior keeps the pose near its start along the directions the silhouette leaves free."""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from rheo.render.silhouette import DISC, silhouette
from rheo.vision.cameras import Camera


def _pose_to_c2w(params: np.ndarray) -> np.ndarray:
    R, _ = cv2.Rodrigues(params[:3])
    w2c = np.eye(4)
    w2c[:3, :3], w2c[:3, 3] = R, params[3:]
    return np.linalg.inv(w2c)


def _c2w_to_pose(c2w: np.ndarray) -> np.ndarray:
    w2c = np.linalg.inv(c2w)
    rvec, _ = cv2.Rodrigues(w2c[:3, :3])
    return np.r_[rvec.ravel(), w2c[:3, 3]]


def silhouette_residuals(camera: Camera, points: np.ndarray, spacing: float, outside: np.ndarray,
                         edge_pixels: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Two-sided silhouette distance (px): projected points outside the mask, and mask edge pixels farther from the
    projected points than the particles' own extent (``spacing``)."""
    cam = Camera(camera.width, camera.height, camera.K, camera.dist, _pose_to_c2w(params))
    uv, depth = cam.project(points)
    # bilinear samples of the distance to the mask: smooth in the pose
    r_points = ndimage.map_coordinates(outside, [uv[:, 1], uv[:, 0]], order=1, mode="nearest")
    r_points = r_points + 10.0 * (depth <= 0)
    nearest, index = cKDTree(uv).query(edge_pixels[:, ::-1])
    reach = DISC * spacing * cam.K[0, 0] / np.maximum(depth[index], 1e-6) + 0.5  # disc radius, pixel rounding
    r_edges = np.maximum(nearest - reach, 0.0)
    return np.r_[r_points / np.sqrt(len(r_points)), r_edges / np.sqrt(len(r_edges))]


def refine_pose(camera: Camera, points: np.ndarray, spacing: float, mask: np.ndarray,
                prior: float = 0.05) -> tuple[np.ndarray, dict]:
    """The camera-to-world pose whose view of ``points`` (the proxy at frame 0, particle ``spacing``) best matches
    ``mask``; ``prior`` weighs the distance from the starting pose (units: 0.01 rad, 1 % of the camera distance)."""
    if not mask.any():
        raise ValueError("the first frame's mask is empty: nothing to align the proxy with")
    outside = ndimage.distance_transform_edt(~mask)
    edge_pixels = np.argwhere(mask & ~ndimage.binary_erosion(mask))
    start = _c2w_to_pose(camera.c2w)

    scale = np.r_[np.full(3, 0.01), np.full(3, 0.01 * np.linalg.norm(start[3:]))]

    def residuals(delta):  # the pose as start + scale * delta
        p = start + scale * delta
        return np.r_[silhouette_residuals(camera, points, spacing, outside, edge_pixels, p), prior * delta]

    before = float(np.sum(residuals(np.zeros(6)) ** 2))
    fit = least_squares(residuals, np.zeros(6), diff_step=0.1, max_nfev=400)
    c2w = _pose_to_c2w(start + scale * fit.x)
    return c2w, {"cost_before": before, "cost_after": float(np.sum(fit.fun**2)), "evaluations": int(fit.nfev)}


def silhouette_mask(camera: Camera, points: np.ndarray, spacing: float) -> np.ndarray:
    """The proxy's silhouette: its particles splatted as discs, holes closed."""
    return ndimage.binary_fill_holes(silhouette(camera, points, spacing))
