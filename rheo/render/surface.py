"""The material drawn as a shaded surface, for people to look at: the particles' density smoothed on a grid, its
level set as a triangle mesh (marching cubes), and the mesh filled far to near with diffuse light."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.special import ndtri
from skimage.measure import marching_cubes

from rheo.vision.cameras import Camera

MATERIAL_COLOUR = (0.72, 0.22, 0.14)  # a ketchup red, where the recording gives no colour
SUBPIXEL_BITS = 4


def particle_surface(positions: np.ndarray, spacing: float, smoothing: float = 1.5,
                     level: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) of the surface around particles ``spacing`` apart: their count per
    voxel of side ``spacing``, smoothed by a Gaussian of ``smoothing`` voxels, where it is ``level`` times the
    interior's (low enough that a sheet two particles thick stays whole), moved back onto the boundary."""
    margin = 3 * (smoothing + 1) * spacing
    low = positions.min(axis=0) - margin
    shape = np.ceil((positions.max(axis=0) + margin - low) / spacing).astype(int) + 1
    counts = np.zeros(shape, dtype=np.float32)
    index = np.clip(np.round((positions - low) / spacing).astype(int), 0, shape - 1)
    np.add.at(counts, tuple(index.T), 1.0)
    density = gaussian_filter(counts, smoothing)
    if density.max() <= level:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=int)
    vertices, faces, normals, _ = marching_cubes(density, level=level, spacing=(spacing,) * 3)
    # below half density the level set of a smoothed flat boundary lies this far outside it: moved back
    outside = smoothing * spacing * float(ndtri(1.0 - level))
    return vertices + low - outside * normals, faces


def shade(vertices: np.ndarray, faces: np.ndarray, camera: Camera, colour=MATERIAL_COLOUR,
          background: float = 1.0, supersample: int = 2) -> np.ndarray:
    """The mesh seen by ``camera``: RGB in [0, 1] on a plain background, lit from the camera and from above,
    drawn at ``supersample`` times the resolution and averaged down."""
    height, width = camera.height * supersample, camera.width * supersample
    image = np.full((height, width, 3), background, dtype=np.float32)
    if len(faces):
        uv, depth = camera.project(vertices)
        uv = uv * supersample + (supersample - 1) / 2  # pixel centres at integers, as in OpenCV
        corners = vertices[faces]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        to_camera = camera.c2w[:3, 3] - corners.mean(axis=1)
        to_camera /= np.linalg.norm(to_camera, axis=1, keepdims=True)
        above = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
        light = 0.3 + 0.45 * np.abs((normals * to_camera).sum(axis=1)) + 0.25 * np.abs(normals @ above)
        shades = np.clip(light[:, None] * np.asarray(colour, dtype=np.float32), 0.0, 1.0)
        face_depth = depth[faces].mean(axis=1)
        visible = (depth[faces] > 0).all(axis=1) & np.isfinite(uv[faces]).all(axis=(1, 2))
        points = np.round(uv[faces] * 2**SUBPIXEL_BITS).astype(np.int32)
        for f in np.flatnonzero(visible)[np.argsort(-face_depth[visible])]:  # far to near
            cv2.fillConvexPoly(image, points[f], shades[f].tolist(), lineType=cv2.LINE_8, shift=SUBPIXEL_BITS)
    return cv2.resize(image, (camera.width, camera.height), interpolation=cv2.INTER_AREA)


def surface_image(positions: np.ndarray, spacing: float, camera: Camera, colour=MATERIAL_COLOUR) -> np.ndarray:
    """Particles drawn as their shaded surface by ``camera`` (RGB in [0, 1] on white)."""
    return shade(*particle_surface(positions, spacing), camera, colour)


def framing(images: list[np.ndarray], background: float = 1.0, margin: int = 12) -> tuple[slice, slice]:
    """The region (rows, columns, even sizes) holding everything but the background over ``images``."""
    ink = np.zeros(images[0].shape[:2], dtype=bool)
    for image in images:
        ink |= np.abs(image - background).max(axis=-1) > 1e-3
    if not ink.any():
        return slice(None), slice(None)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    height, width = ink.shape

    def span(first: int, last: int, size: int) -> slice:
        start, stop = max(first - margin, 0), min(last + margin + 1, size)
        if (stop - start) % 2:
            stop = stop + 1 if stop < size else stop
            start = start - 1 if (stop - start) % 2 and start > 0 else start
        return slice(start, stop)

    return span(rows[0], rows[-1], height), span(cols[0], cols[-1], width)
