"""The virtual lab's renderer: the material's particles as discs, shaded as the surface they sample, over a textured
floor with a cast shadow, a backdrop and sensor noise, through a distorted pinhole camera. It shares nothing with the
fit's renderer: slits between discs narrower than two particle spacings are closed, the discs' nearest depth in each
pixel, smoothed, gives the surface's normals for shading, and the floor is ray-cast.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage

from rheo.vision.cameras import Camera

KETCHUP = np.array([0.62, 0.07, 0.04])
BACKDROP_TOP = np.array([0.80, 0.82, 0.86])
BACKDROP_BOTTOM = np.array([0.55, 0.57, 0.62])


@dataclass(frozen=True)
class Scene:
    """Lighting and materials of the virtual lab."""

    light: tuple[float, float, float] = (0.45, 1.0, 0.25)  # towards the light
    ambient: float = 0.35
    albedo: tuple[float, float, float] = tuple(KETCHUP)
    noise: float = 2.0 / 255.0
    floor_extent: float = 3.0  # half-size of the floor (m); beyond it the backdrop
    splat_radius: float = 0.6  # disc radius in particle spacings


@dataclass(frozen=True)
class FloorBoard:
    """A checkerboard lying on the floor: inner corners (columns along x, rows along z), square side, first inner
    corner at ``origin`` (x, z)."""

    columns: int
    rows: int
    square: float
    origin: tuple[float, float] = (0.0, 0.0)


def _light(scene: Scene) -> np.ndarray:
    light = np.asarray(scene.light, float)
    return light / np.linalg.norm(light)


def _floor_texture(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A wooden-table-like texture: planks along x with grain and tile-to-tile variation."""
    plank = np.floor(z / 0.12)
    grain = 0.5 + 0.5 * np.sin(40.0 * x + 7.0 * np.sin(3.0 * z + plank) + 13.0 * plank)
    tone = 0.85 + 0.1 * np.sin(plank * 12.9898) + 0.06 * grain
    edge = np.abs((z / 0.12) - np.round(z / 0.12)) < 0.02
    tone = np.where(edge, tone * 0.7, tone)
    return tone[..., None] * np.array([0.74, 0.60, 0.45])


def board_texture(x: np.ndarray, z: np.ndarray, board: FloorBoard) -> tuple[np.ndarray, np.ndarray]:
    """The board's grey (one value per point, black or white) and where the board (with a one-square white margin)
    covers the floor."""
    u = (x - board.origin[0]) / board.square + 1.0  # squares from the board's outer corner
    v = (z - board.origin[1]) / board.square + 1.0
    nu, nv = board.columns + 1, board.rows + 1
    inside = (u >= -1) & (u < nu + 1) & (v >= -1) & (v < nv + 1)
    squares = (u >= 0) & (u < nu) & (v >= 0) & (v < nv)
    black = squares & ((np.floor(u) + np.floor(v)) % 2 == 0)
    return np.where(black, 0.05, 0.95), inside


def _shadow(points: np.ndarray, radius: float, light: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Fraction of light reaching floor points (x, z): the particles projected along the light onto the floor."""
    shadow_xz = points[:, [0, 2]] - points[:, [1]] / light[1] * light[[0, 2]]
    cell = radius
    lo = shadow_xz.min(axis=0) - 4 * cell
    shape = np.ceil((shadow_xz.max(axis=0) + 4 * cell - lo) / cell).astype(int) + 1
    raster = np.zeros(shape)
    idx = np.floor((shadow_xz - lo) / cell).astype(int)
    np.add.at(raster, (idx[:, 0], idx[:, 1]), 1.0)
    occluded = ndimage.gaussian_filter((raster > 0).astype(float), 1.2)
    i = np.clip(((x - lo[0]) / cell).astype(int), 0, shape[0] - 1)
    k = np.clip(((z - lo[1]) / cell).astype(int), 0, shape[1] - 1)
    outside = (x < lo[0]) | (z < lo[1]) | (i >= shape[0] - 1) | (k >= shape[1] - 1)
    return np.where(outside, 1.0, 1.0 - 0.55 * np.clip(occluded[i, k] * 1.5, 0.0, 1.0))


def surface_normals(origin: np.ndarray, dirs: np.ndarray, forward: np.ndarray, depth: np.ndarray, covered: np.ndarray,
                    smoothing: float) -> tuple[np.ndarray, np.ndarray]:
    """World points and unit normals (towards the camera) of the surface seen in each pixel, from the splats' depth
    buffer smoothed over ``smoothing`` pixels (a Gaussian, normalised over the ``covered`` pixels)."""
    weight = ndimage.gaussian_filter(covered.astype(float), smoothing)
    smoothed = ndimage.gaussian_filter(np.where(covered, depth, 0.0), smoothing)
    nearest = np.where(covered, depth, np.inf).min()
    z = np.where(weight > 1e-6, smoothed / np.maximum(weight, 1e-6), nearest)
    points = origin + dirs * (z / (dirs @ forward))[..., None]
    normals = np.cross(np.gradient(points, axis=1), np.gradient(points, axis=0))
    normals *= np.sign(np.sum(normals * (origin - points), axis=-1, keepdims=True))
    return points, normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)


def splats(camera: Camera, points: np.ndarray, spacing: float, scene: Scene = Scene()
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """The particles ``points`` of lattice ``spacing`` splatted as discs: the depth buffer (inf where no disc
    reaches), the true mask of the material (slits narrower than two particle spacings closed) and the spacing in
    pixels."""
    uv, depth = camera.project(points)
    radius_px = scene.splat_radius * spacing * camera.K[0, 0] / np.maximum(depth, 1e-6)
    order = np.argsort(-depth)  # far to near: of the splats reaching a pixel in one pass, the nearest is last
    uv, radius_px, depth = uv[order], radius_px[order], depth[order]
    zbuffer = np.full((camera.height, camera.width), np.inf)
    reach = int(np.ceil(radius_px.max()))
    for du in range(-reach, reach + 1):
        for dv in range(-reach, reach + 1):
            px = np.floor(uv[:, 0]).astype(int) + du
            py = np.floor(uv[:, 1]).astype(int) + dv
            d2 = (px + 0.5 - uv[:, 0]) ** 2 + (py + 0.5 - uv[:, 1]) ** 2
            keep = (d2 <= radius_px**2) & (px >= 0) & (py >= 0) & (px < camera.width) & (py < camera.height)
            px, py, near = px[keep], py[keep], depth[keep]
            closer = near < zbuffer[py, px]
            zbuffer[py[closer], px[closer]] = near[closer]
    covered = np.isfinite(zbuffer)
    spacing_px = float(np.median(radius_px)) / scene.splat_radius
    gap = int(np.ceil(spacing_px))
    disk = (np.hypot(*np.mgrid[-gap:gap + 1, -gap:gap + 1]) <= gap).astype(np.uint8)
    closed = cv2.morphologyEx(np.pad(covered, gap + 1).astype(np.uint8), cv2.MORPH_CLOSE, disk)
    return zbuffer, closed[gap + 1:-gap - 1, gap + 1:-gap - 1].astype(bool) | covered, spacing_px


def render(camera: Camera, points: np.ndarray | None = None, spacing: float | None = None, *,
           scene: Scene = Scene(), board: FloorBoard | None = None,
           rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """An 8-bit RGB image and the true mask of the material (particles ``points`` of lattice ``spacing``)."""
    light = _light(scene)
    origin, dirs = camera.pixel_rays()
    down = dirs[..., 1] < -1e-9
    t = np.where(down, -origin[1] / np.where(down, dirs[..., 1], -1.0), np.inf)
    hit = origin + t[..., None] * dirs
    extent = scene.floor_extent + 0.5
    on_floor = down & (np.abs(hit[..., 0]) < extent) & (np.abs(hit[..., 2]) < extent)
    x, z = np.where(on_floor, hit[..., 0], 0.0), np.where(on_floor, hit[..., 2], 0.0)
    floor = _floor_texture(x, z)
    if board is not None:
        board_grey, on_board = board_texture(x, z, board)
        floor = np.where(on_board[..., None], board_grey[..., None], floor)
    shade = np.full(x.shape, 0.55 + 0.45 * light[1])
    if points is not None and len(points):
        shade = shade * _shadow(points, spacing, light, x, z)
    backdrop = BACKDROP_BOTTOM + (BACKDROP_TOP - BACKDROP_BOTTOM) * np.clip(dirs[..., 1:2] * 2 + 0.5, 0, 1)
    image = np.where(on_floor[..., None], floor * shade[..., None], backdrop)
    mask = np.zeros(x.shape, dtype=bool)
    if points is not None and len(points):
        zbuffer, mask, spacing_px = splats(camera, points, spacing, scene)
        covered = np.isfinite(zbuffer)
        # shaded per pixel from the smoothed surface, so that the particles' lattice does not show
        surface, normals = surface_normals(origin, dirs, camera.c2w[:3, 2], zbuffer, covered, smoothing=spacing_px)
        diffuse = np.clip(normals @ light, 0.0, 1.0)
        view = origin - surface
        view /= np.linalg.norm(view, axis=-1, keepdims=True)
        half = (view + light) / np.linalg.norm(view + light, axis=-1, keepdims=True)
        specular = 0.25 * np.clip(np.sum(normals * half, axis=-1), 0.0, 1.0) ** 30
        albedo = np.asarray(scene.albedo)
        colors = albedo * (scene.ambient + (1 - scene.ambient) * diffuse[..., None]) + specular[..., None]
        image = np.where(mask[..., None], colors, image)
    if rng is not None and scene.noise > 0:
        image = image + rng.normal(0.0, scene.noise, image.shape)
    return (np.clip(image, 0.0, 1.0) * 255 + 0.5).astype(np.uint8), mask
