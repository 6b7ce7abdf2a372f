"""Silhouettes of particle sets: every particle a disc of the lab's splat radius, rasterised with supersampling.

Fast (a few milliseconds per image, no Python loop over particles) and deterministic, for comparisons of whole
frames with masks, where the differentiable renderer's random ray batches would be both slow and noisy."""

from __future__ import annotations

import cv2
import numpy as np

from rheo.vision.cameras import Camera

DISC = 0.5  # disc radius in particle spacings: the circle inscribed in a particle's cell (docs/settings.md)
SUPERSAMPLE = 2  # sub-pixels per pixel along each axis


def disc_kernel(radius: float) -> np.ndarray:
    """The pixels (2r + 1, 2r + 1) of a disc of ``radius`` about the centre one."""
    r = max(int(np.ceil(radius - 0.5)), 0)
    y, x = np.mgrid[-r:r + 1, -r:r + 1]
    return (x * x + y * y <= radius * radius + 0.25).astype(np.uint8)


def subpixels(camera: Camera, uv: np.ndarray, depth: np.ndarray, supersample: int = SUPERSAMPLE
              ) -> tuple[np.ndarray, np.ndarray]:
    """The sub-pixel (column, row) each projected point falls in, on a raster ``supersample`` times finer, and
    whether it is in front of the camera and inside the image."""
    # pixel centres at integers (OpenCV): sub-pixel (i, j) of pixel (u, v) has centre u + (j + 0.5) / s - 0.5
    sub = np.floor((uv + 0.5) * supersample).astype(int)
    inside = (depth > 0) & (sub[:, 0] >= 0) & (sub[:, 0] < camera.width * supersample) & (sub[:, 1] >= 0) & (
        sub[:, 1] < camera.height * supersample)
    return sub, inside


def disc_radius(camera: Camera, spacing: float, depths: np.ndarray, supersample: int = SUPERSAMPLE) -> float:
    """The discs' radius in sub-pixels: ``DISC`` spacings at the median of ``depths``."""
    return DISC * spacing * camera.K[0, 0] * supersample / float(np.median(depths))


def coverage(camera: Camera, points: np.ndarray, spacing: float, supersample: int = SUPERSAMPLE,
             projection: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The fraction (H, W) of every pixel covered by the particles' discs (radius from the median depth);
    ``projection``: the points' ``camera.project``, where the caller has it."""
    uv, depth = projection or camera.project(np.asarray(points, dtype=np.float64))
    sub, keep = subpixels(camera, uv, depth, supersample)
    hits = np.zeros((camera.height * supersample, camera.width * supersample), np.uint8)
    hits[sub[keep, 1], sub[keep, 0]] = 1
    if keep.any():
        hits = cv2.dilate(hits, disc_kernel(disc_radius(camera, spacing, depth[keep], supersample)))
    return cv2.resize(hits.astype(np.float32), (camera.width, camera.height), interpolation=cv2.INTER_AREA)


def silhouette(camera: Camera, points: np.ndarray, spacing: float,
               projection: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The particles' silhouette (H, W) bool: pixels at least half covered."""
    return coverage(camera, points, spacing, projection=projection) >= 0.5


def distance_to(mask: np.ndarray) -> np.ndarray:
    """Distance (px) from every pixel to the nearest pixel of ``mask``."""
    return cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def boundary_distance(simulated: np.ndarray, mask: np.ndarray, to_mask: np.ndarray) -> float:
    """Symmetric mean boundary distance (px): half the mean distance of the simulated silhouette's pixels to the
    mask (``to_mask``: its ``distance_to`` map) plus half that of the mask's pixels to the simulated silhouette."""
    to_mask_mean = to_mask[simulated].mean() if simulated.any() else to_mask.max()
    to_simulated_mean = distance_to(simulated)[mask].mean() if mask.any() else 0.0
    return 0.5 * (float(to_mask_mean) + float(to_simulated_mean))


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean images (0 where both are empty)."""
    return float((a & b).sum()) / max(float((a | b).sum()), 1.0)
