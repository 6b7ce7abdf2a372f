"""Pinhole cameras with OpenCV distortion, in the world frame (y up); camera axes x right, y down, z forward."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass
class Camera:
    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    c2w: np.ndarray

    @property
    def w2c(self) -> np.ndarray:
        return np.linalg.inv(self.c2w)

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (N, 2) and depths (N,) of world points (distortion applied)."""
        w2c = self.w2c
        cam = points @ w2c[:3, :3].T + w2c[:3, 3]
        if not self.dist.any():  # a pinhole: the perspective division alone, several times faster than OpenCV's
            with np.errstate(divide="ignore", invalid="ignore"):
                return (cam / cam[:, 2:]) @ self.K[:2].T, cam[:, 2]
        rvec, _ = cv2.Rodrigues(w2c[:3, :3])
        uv, _ = cv2.projectPoints(points.astype(np.float64), rvec, w2c[:3, 3], self.K, self.dist)
        return uv.reshape(-1, 2), cam[:, 2]

    def pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pixel (column, row) each world point falls in, (N, 2) int, and whether it is in front of the camera
        and inside the image."""
        uv, depth = self.project(points)
        pixel = np.round(uv).astype(int)
        inside = (depth > 0) & (pixel[:, 0] >= 0) & (pixel[:, 0] < self.width) & (pixel[:, 1] >= 0) & (
            pixel[:, 1] < self.height)
        return pixel, inside

    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space origin (3,) and unit directions (H, W, 3) through every pixel centre (distortion undone), both
        read-only (the last two cameras' rays are kept). As in OpenCV, pixel (i, j) has its centre at (u, v) = (j, i).
        """
        return _pixel_rays(self.width, self.height, *(np.asarray(a, np.float64).tobytes()
                                                      for a in (self.K, np.ravel(self.dist), self.c2w)))

    def record(self) -> dict:
        return {"width": self.width, "height": self.height, "K": self.K.tolist(), "dist": self.dist.tolist(),
                "c2w": self.c2w.tolist(), "axes": "opencv"}

    @classmethod
    def from_record(cls, rec: dict) -> Camera:
        return cls(rec["width"], rec["height"], np.asarray(rec["K"], float), np.asarray(rec["dist"], float),
                   np.asarray(rec["c2w"], float))


@functools.lru_cache(maxsize=2)
def _pixel_rays(width: int, height: int, K: bytes, dist: bytes, c2w: bytes) -> tuple[np.ndarray, np.ndarray]:
    K_, dist_, c2w_ = np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), np.frombuffer(c2w).reshape(4, 4)
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1)[:, None, :]
    normalized = cv2.undistortPointsIter(pixels, K_, dist_, None, None,
                                         (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10))
    dirs = np.c_[normalized.reshape(-1, 2), np.ones(len(pixels))] @ c2w_[:3, :3].T
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origin, dirs = c2w_[:3, 3].copy(), dirs.reshape(height, width, 3)
    origin.flags.writeable = dirs.flags.writeable = False
    return origin, dirs


def look_at(eye, target) -> np.ndarray:
    """Camera-to-world (4x4) of a camera at ``eye`` looking at ``target``, image up towards world +y."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    if np.linalg.norm(right) < 1e-9:  # looking straight down or up
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    c2w = np.eye(4)
    c2w[:3, :3] = np.stack([right, down, forward], axis=1)
    c2w[:3, 3] = eye
    return c2w


def intrinsics(width: int, height: int, fov_deg: float) -> np.ndarray:
    """Square pixels, principal point at the image centre, horizontal field of view ``fov_deg``."""
    f = 0.5 * width / math.tan(math.radians(fov_deg) / 2)
    return np.array([[f, 0.0, width / 2], [0.0, f, height / 2], [0.0, 0.0, 1.0]])


def hemisphere(count: int, distance: float, elevation_deg, look_at_point, width: int, height: int, fov_deg: float,
               dist=(0.0, 0.0, 0.0, 0.0, 0.0)) -> list[Camera]:
    """``count`` cameras around ``look_at_point`` at ``distance``, azimuths evenly spread, elevations alternating
    across ``elevation_deg`` = [min, max] (as in PAC-NeRF's data)."""
    lo, hi = elevation_deg
    target = np.asarray(look_at_point, float)
    cameras = []
    for i in range(count):
        azimuth = 2 * math.pi * i / count
        elevation = math.radians(lo if count == 1 or lo == hi else lo + (hi - lo) * ((i * 0.618034) % 1.0))
        offset = distance * np.array([math.cos(elevation) * math.cos(azimuth), math.sin(elevation),
                                      math.cos(elevation) * math.sin(azimuth)])
        cameras.append(Camera(width, height, intrinsics(width, height, fov_deg), np.asarray(dist, float),
                              look_at(target + offset, target)))
    return cameras
