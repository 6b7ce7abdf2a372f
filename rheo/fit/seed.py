"""The particles a fit starts from.

Several views: a static voxel radiance field (density, colour) fitted to every camera's first frame, coarse to fine,
with the thesis' surface regulariser (eq. 3.8), started from the visual hull of the masks; particles then fill the
voxels the field makes opaque and take its density and colour, carved node by node to the masks on the lattice
placement that draws them best, and the top layers no outline needs (a cap over a flat top) are trimmed. One view: the
proxy's geometry, coloured from the view.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from scipy import ndimage
from tqdm.auto import tqdm

from rheo.fit.observations import Observations, sample_rays
from rheo.render.field import WHITE, VoxelGrid, march
from rheo.render.silhouette import SUPERSAMPLE, disc_kernel, disc_radius, iou, silhouette, subpixels
from rheo.vision.cameras import Camera

logger = logging.getLogger(__name__)

OPAQUE = 4.0  # optical depth per particle spacing (with rheo.render.field.COUNT_FLOOR: surfaces where volumes end)
# top layers are trimmed while the silhouettes' outlines move by less than this on average (px; docs/settings.md)
OUTLINE_SHIFT = 0.05


@dataclass
class Seed:
    """Particles on a lattice of ``spacing``: positions (N, 3), densities (N,) in 1/m, colours (N, 3) in [0, 1]."""

    positions: np.ndarray
    density: np.ndarray
    colour: np.ndarray
    spacing: float

    @property
    def particle_volume(self) -> float:
        return self.spacing**3

    @property
    def volume(self) -> float:
        return len(self.positions) * self.particle_volume


def _inside_views(obs: Observations, points: np.ndarray, frame: int) -> np.ndarray:
    """For each point, whether every view that sees it (in front of the camera, inside the image) sees it inside
    the mask; points no view sees are outside."""
    inside = np.ones(len(points), bool)
    seen = np.zeros(len(points), bool)
    for view in obs.views:
        cam = view.camera
        pixel, visible = cam.pixels(points)
        mask = view.masks[frame].reshape(cam.height, cam.width)
        hit = np.zeros(len(points), bool)
        hit[visible] = mask[pixel[visible, 1], pixel[visible, 0]]
        inside &= hit | ~visible
        seen |= visible
    return inside & seen


def visual_hull(obs: Observations, grid: VoxelGrid, frame: int = 0) -> np.ndarray:
    """Nodes of ``grid`` (above the floor) inside the masks of every view that sees them: (nx, ny, nz) bool."""
    centres = grid.centres().reshape(-1, 3)
    return (_inside_views(obs, centres, frame) & (centres[:, 1] >= 0)).reshape(grid.shape)


def hull_grid(obs: Observations, bounds: tuple[np.ndarray, np.ndarray], spacing: float,
              frame: int = 0) -> VoxelGrid:
    """The grid of ``spacing`` around the visual hull within ``bounds`` (the box particles may start in; the hull
    computed on a grid twice as coarse), its nodes half a spacing off the multiples of ``spacing``."""
    lo, hi = np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float)
    coarse = VoxelGrid(tuple(lo), 2 * spacing, tuple(int(n) for n in np.ceil((hi - lo) / (2 * spacing)) + 1))
    hull = visual_hull(obs, coarse, frame)
    centres = coarse.centres()
    hull &= (centres <= hi).all(axis=-1)
    if not hull.any():
        raise ValueError("the masks of the first frame have no common region inside the simulation domain: check "
                         "the cameras and masks")
    # nodes at cell centres of the lattice through the origin: the lowest layer of particles then starts at the floor
    return VoxelGrid.around(centres[hull], spacing, pad=3, anchor=np.zeros(3))


def _resample(field: torch.Tensor, source: VoxelGrid, target: VoxelGrid) -> torch.Tensor:
    """A (C, nx, ny, nz) field on ``source`` interpolated at the nodes of ``target``."""
    lo, hi = source.bounds()
    centres = torch.as_tensor(target.centres(), dtype=field.dtype)
    normalized = 2.0 * (centres - torch.as_tensor(lo, dtype=field.dtype)) / torch.as_tensor(hi - lo,
                                                                                             dtype=field.dtype) - 1
    return F.grid_sample(field[None], normalized.flip(-1)[None], mode="bilinear", padding_mode="border",
                         align_corners=True)[0]


def fit_radiance_field(obs: Observations, grid: VoxelGrid, occupancy: np.ndarray, *, levels: int = 3,
                       iterations: int = 150, rays_per_view: int = 1024, surface_weight: float = 0.01,
                       mask_weight: float = 1.0,
                       learning_rate: float = 0.1, seed: int = 0,
                       progress: bool = True) -> tuple[torch.Tensor, torch.Tensor, list[float]]:
    """Density (nx, ny, nz) and colour (3, nx, ny, nz) on ``grid`` fitted to the first frame of every view, from a
    grid 2**(levels-1) times coarser up to ``grid``; starts opaque inside ``occupancy`` (the visual hull). The loss:
    colours against the matted frames, opacity against the masks (``mask_weight``) and the surface regulariser
    (``surface_weight``). Returns the fields and the loss per iteration."""
    rng = np.random.default_rng(seed)
    opaque = 4.0 / grid.spacing  # about 98 % opacity per voxel
    current = grid
    raw = None
    losses = []
    for level in reversed(range(levels)):
        factor = 2**level
        shape = tuple(int(np.ceil((n - 1) / factor)) + 1 for n in grid.shape)
        level_grid = VoxelGrid(grid.origin, grid.spacing * factor, shape)
        if raw is None:
            hull = torch.as_tensor(occupancy[None].astype(np.float32))
            start = _resample(hull, grid, level_grid)[0]
            raw = torch.cat([torch.log(torch.expm1(torch.full_like(start, 1.0))) + 6.0 * (start - 0.5)[None],
                             torch.zeros((3, *shape))], dim=0)
        else:
            raw = _resample(raw.detach(), current, level_grid)
        current = level_grid
        raw.requires_grad_(True)
        optimizer = torch.optim.Adam([raw], lr=learning_rate)
        for _ in tqdm(range(iterations), desc=f"radiance field {shape}", disable=not progress):
            batch = sample_rays(obs, 0, rays_per_view, rng)
            density = F.softplus(raw[0]) * (opaque / 1.0)
            rgb, opacity = march(density, torch.sigmoid(raw[1:]), level_grid, batch.origins, batch.dirs, WHITE)
            alpha = 1.0 - torch.exp(-density * level_grid.spacing)
            surface = torch.clamp(alpha, 1e-4, 1e-1).mean()  # eq. 3.8, per voxel
            # the masks tell empty space from white material, which the matted colours alone cannot
            loss = (F.mse_loss(rgb, batch.colours) + mask_weight * F.mse_loss(opacity, batch.masks)
                    + surface_weight * surface)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
    with torch.no_grad():
        return F.softplus(raw[0]) * opaque, torch.sigmoid(raw[1:]), losses


def opaque_density(spacing: float) -> float:
    """The density (1/m) every particle carries: the material is opaque, and a surface rendered from particles of
    ``spacing`` then lies about where their volumes end."""
    return OPAQUE / spacing


def field_occupancy(density: torch.Tensor, grid: VoxelGrid, threshold: float = 0.5,
                    min_piece: float = 0.05) -> np.ndarray:
    """The nodes (above the floor) whose voxel the field makes more opaque than ``threshold``, or that such voxels
    enclose (``solid``)."""
    alpha = (1.0 - torch.exp(-density * grid.spacing)).numpy()
    return solid(alpha > threshold, grid, min_piece)


def solid(occupied: np.ndarray, grid: VoxelGrid, min_piece: float = 0.05) -> np.ndarray:
    """``occupied`` nodes of ``grid`` with what they enclose: images constrain the surface, not the inside, so
    cavities are filled (the floor closes the material from below), in 3-D and in every horizontal slice. Pieces
    smaller than ``min_piece`` of the largest are dropped, and nodes below the floor."""
    above = grid.centres()[..., 1] > 0
    closed = occupied & above
    closed[:, :np.argmax(above, axis=1).min()] = True
    keep = ndimage.binary_fill_holes(closed)
    # a cavity open to the outside somewhere escapes the 3-D filling; horizontal slices of a heap rarely have holes
    keep |= np.stack([ndimage.binary_fill_holes(keep[:, j, :]) for j in range(keep.shape[1])], axis=1)
    keep &= above
    labels, count = ndimage.label(keep)
    if count > 1:  # drop specks of opacity floating apart from the material
        sizes = ndimage.sum(keep, labels, index=np.arange(1, count + 1))
        keep = np.isin(labels, 1 + np.flatnonzero(sizes >= min_piece * sizes.max()))
    return keep


def grid_seed(occupied: np.ndarray, colour: torch.Tensor, grid: VoxelGrid) -> Seed:
    """One particle at every ``occupied`` node, with the field's colour there."""
    return Seed(grid.centres()[occupied], np.full(int(occupied.sum()), opaque_density(grid.spacing)),
                colour.numpy().transpose(1, 2, 3, 0)[occupied], grid.spacing)


class _Coverage:
    """The views' silhouettes of particles at a grid's nodes as ``rheo.render.silhouette.silhouette`` draws them
    (discs on a raster ``SUPERSAMPLE`` times finer, a pixel set where at least half its sub-pixels are covered), every
    view's raster laid end to end in one, kept up to date as single nodes are added or removed: how many discs cover
    each sub-pixel and how many covered sub-pixels each pixel has."""

    def __init__(self, views: list[tuple[Camera, np.ndarray]], centres: np.ndarray, occupied: np.ndarray,
                 spacing: float) -> None:
        s = SUPERSAMPLE
        footprints, pixels, rasters = [], [], []
        first_sub = first_pixel = 0
        for camera, _ in views:
            width = camera.width * s
            uv, depth = camera.project(centres)
            sub, seen = subpixels(camera, uv, depth)
            kernel = disc_kernel(disc_radius(camera, spacing, depth[occupied & seen]))
            dy, dx = np.nonzero(kernel)
            rows = sub[:, 1, None] + dy - kernel.shape[0] // 2
            columns = sub[:, 0, None] + dx - kernel.shape[1] // 2
            inside = seen[:, None] & (rows >= 0) & (rows < camera.height * s) & (columns >= 0) & (columns < width)
            footprints.append(np.where(inside, first_sub + rows * width + columns, -1).astype(np.int32))
            pixels.append(np.where(inside, first_pixel + (rows // s) * camera.width + columns // s, -1)
                          .astype(np.int32))
            rasters.append((first_sub, camera.height, camera.width))
            first_sub += camera.height * s * width
            first_pixel += camera.height * camera.width
        # per node, the sub-pixels its discs cover (-1 where off the image) and their pixels, in the pixels' order
        pixel = np.concatenate(pixels, axis=1)
        order = np.argsort(pixel, axis=1, kind="stable")
        self.footprint = np.take_along_axis(np.concatenate(footprints, axis=1), order, axis=1)
        self.pixel = np.take_along_axis(pixel, order, axis=1)
        self.mask = np.concatenate([mask.reshape(-1) for _, mask in views])
        covers = self.footprint[occupied]
        self.discs = np.bincount(covers[covers >= 0], minlength=first_sub).astype(np.int32)
        self.covered = np.concatenate([
            (self.discs[start:start + height * s * width * s] > 0).reshape(height, s, width, s).sum(axis=(1, 3)).ravel()
            for start, height, width in rasters])

    def change(self, node: int, add: bool) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """What adding (removing) ``node`` does: the change in the number of pixels where the silhouettes and the
        masks disagree, and the sub-pixels, pixels and per-pixel counts that change."""
        keep = self.footprint[node] >= 0
        footprint, pixel = self.footprint[node][keep], self.pixel[node][keep]
        flipped = pixel[self.discs[footprint] == (0 if add else 1)]  # sub-pixels covered (uncovered), in order
        starts = np.flatnonzero(np.concatenate(([True], flipped[1:] != flipped[:-1]))) if flipped.size else flipped
        pixels, counts = flipped[starts], np.diff(starts, append=flipped.size)
        before = 2 * self.covered[pixels] >= SUPERSAMPLE**2
        after = 2 * (self.covered[pixels] + (counts if add else -counts)) >= SUPERSAMPLE**2
        wrong = int((after != self.mask[pixels]).sum() - (before != self.mask[pixels]).sum())
        return wrong, footprint, pixels, counts

    def apply(self, add: bool, footprint: np.ndarray, pixels: np.ndarray, counts: np.ndarray) -> None:
        self.discs[footprint] += 1 if add else -1
        self.covered[pixels] += counts if add else -counts


def carve(obs: Observations, grid: VoxelGrid, occupied: np.ndarray, frame: int = 0, passes: int = 20) -> np.ndarray:
    """``occupied`` nodes of ``grid`` refined to the masks of ``frame``: nodes on the boundary are added or removed,
    one at a time, wherever that lowers the number of pixels at which the silhouettes (as the fit draws them) and the
    masks disagree, summed over the views; until a pass over the boundary changes nothing, or ``passes`` are done.
    A node whose change no view sees stays as it is, so the inside stays filled. The radiance field's opacity
    threshold leaves its surface a voxel too far out here and a voxel too far in there; the fit, which compares
    silhouettes of particles, is biased by every such voxel."""
    occupied = occupied.copy()
    flat = occupied.reshape(-1)  # a view of it
    centres = grid.centres().reshape(-1, 3)
    above = centres[:, 1] > 0
    coverage = _Coverage([(v.camera, v.masks[frame].astype(bool)) for v in obs.views], centres, flat, grid.spacing)
    for done in range(1, passes + 1):
        grown = ndimage.binary_dilation(occupied) & ~occupied
        boundary = occupied & ~ndimage.binary_erosion(occupied, border_value=0)
        changed = 0
        for node in np.flatnonzero((grown | boundary).reshape(-1) & above):
            add = not flat[node]
            wrong, *change = coverage.change(node, add)
            if wrong < 0:
                coverage.apply(add, *change)
                flat[node] = add
                changed += 1
        logger.debug("carving pass %d: %d nodes changed", done, changed)
        if not changed:
            break
    return occupied


def silhouette_iou(obs: Observations, seed: Seed, frame: int = 0) -> dict[str, float]:
    """Per view, the IoU of the particles' silhouette (as the fit draws it) with the mask."""
    scores = {}
    for view in obs.views:
        scores[view.name] = iou(silhouette(view.camera, seed.positions, seed.spacing).ravel(), view.masks[frame])
    return scores


def mismatched_pixels(obs: Observations, positions: np.ndarray, spacing: float, frame: int = 0) -> int:
    """The number of pixels, over the views, where the particles' silhouettes and the masks of ``frame`` differ."""
    return sum(int((silhouette(view.camera, positions, spacing).ravel() != view.masks[frame]).sum())
               for view in obs.views)


def seed_from_field(obs: Observations, density: torch.Tensor, colour: torch.Tensor, grid: VoxelGrid,
                    thresholds=(0.8, 0.6, 0.4, 0.3, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005), offsets: int = 3
                    ) -> tuple[Seed, float, dict[str, float]]:
    """The particles of the opacity threshold whose silhouettes best match the first frame's masks (mean IoU over
    the views), carved to the masks (``carve``) on the horizontal placement of the lattice (``offsets`` per axis and
    spacing) whose carved silhouettes differ from the masks on the fewest pixels; returns them, the threshold and the
    IoU per view."""
    best = None
    for threshold in thresholds:
        occupied = field_occupancy(density, grid, threshold)
        scores = silhouette_iou(obs, grid_seed(occupied, colour, grid))
        logger.info("opacity threshold %.2f: %d particles, mean silhouette IoU %.4f", threshold, occupied.sum(),
                    np.mean(list(scores.values())))
        if best is None or np.mean(list(scores.values())) > np.mean(list(best[2].values())):
            best = (occupied, threshold, scores)
    threshold = best[1]
    if threshold == min(thresholds):
        logger.warning("the lowest opacity threshold (%g) matches the masks best: the field may be too faint",
                       threshold)
    placements = []
    for dx, dz in itertools.product(np.arange(offsets) / offsets, repeat=2):
        shifted = VoxelGrid(tuple(np.asarray(grid.origin) + grid.spacing * np.array([dx, 0.0, dz])), grid.spacing,
                            grid.shape)
        occupied = solid(carve(obs, shifted, field_occupancy(_resample(density[None], grid, shifted)[0], shifted,
                                                                 threshold)), shifted)
        wrong = mismatched_pixels(obs, shifted.centres()[occupied], grid.spacing)
        logger.info("lattice shifted by (%.2f, %.2f) spacings: carved to %d particles, %d pixels off the masks", dx, dz,
                    occupied.sum(), wrong)
        placements.append((wrong, dx, dz, shifted, occupied))
    _, dx, dz, shifted, occupied = min(placements, key=lambda placement: placement[0])
    seed = grid_seed(occupied, _resample(colour, grid, shifted), shifted)
    scores = silhouette_iou(obs, seed)
    logger.info("seed on the lattice shifted by (%.2f, %.2f): %d particles, mean silhouette IoU %.4f", dx, dz,
                len(seed.positions), np.mean(list(scores.values())))
    return seed, threshold, scores


def outline_length(mask: np.ndarray) -> int:
    """The number of pixels on the outline of a (H, W) mask (its pixels with a 4-neighbour outside)."""
    return int((mask & ~ndimage.binary_erosion(mask, border_value=0)).sum())


def trim_top(obs: Observations, seed: Seed, frame: int = 0, shift: float = OUTLINE_SHIFT) -> tuple[Seed, int]:
    """The seed without its highest layers as long as the silhouettes' outlines move by less than ``shift`` px on
    average; returns it and the number of layers removed.

    Views from above the horizon cannot carve the visual hull over a flat top (every one of them sees a point above
    it inside the top face), and a field coloured like the top face fills that cone at no cost: a cap of material
    the recording never showed, which the fit would then have to explain away. The outlines tell the cap, which
    none of them needs, from a true layer, which moves the upper outline of every view by its projected height."""
    allowed = shift * sum(outline_length(view.masks[frame].reshape(view.camera.height, view.camera.width))
                          for view in obs.views)
    layer = np.round((seed.positions[:, 1] - seed.positions[:, 1].min()) / seed.spacing).astype(int)
    untrimmed = mismatched_pixels(obs, seed.positions, seed.spacing, frame)
    top = layer.max()
    while top > 0 and mismatched_pixels(obs, seed.positions[layer < top], seed.spacing, frame) - untrimmed <= allowed:
        top -= 1
    keep = layer <= top
    return Seed(seed.positions[keep], seed.density[keep], seed.colour[keep], seed.spacing), int(layer.max() - top)


def proxy_particles(occupancy: np.ndarray, origin: np.ndarray, proxy_spacing: float, spacing: float) -> np.ndarray:
    """The proxy's occupancy (voxel ``(i, j, k)`` centred at ``origin + proxy_spacing * (i, j, k)``) sampled at the
    centres of a lattice of ``spacing`` over the same box."""
    corner = origin - 0.5 * proxy_spacing
    extent = np.asarray(occupancy.shape) * proxy_spacing
    axes = [corner[a] + spacing / 2 + spacing * np.arange(int(np.floor(extent[a] / spacing))) for a in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    index = np.floor((points - corner) / proxy_spacing).astype(int)
    index = np.clip(index, 0, np.asarray(occupancy.shape) - 1)
    return points[occupancy[index[:, 0], index[:, 1], index[:, 2]]]


def colour_from_view(obs: Observations, points: np.ndarray, frame: int = 0) -> np.ndarray:
    """Colours (N, 3) of ``points`` from the first view's matted frame: the pixel each projects to where that is on
    the material, the material's mean colour elsewhere."""
    view = obs.views[0]
    cam = view.camera
    image = view.images[frame].reshape(cam.height, cam.width, 3) / 255.0
    mask = view.masks[frame].reshape(cam.height, cam.width)
    if not mask.any():
        raise ValueError(f"camera {view.name}: the first frame's mask is empty")
    pixel, inside = cam.pixels(points)
    on_material = np.zeros(len(points), bool)
    on_material[inside] = mask[pixel[inside, 1], pixel[inside, 0]]
    colours = np.broadcast_to(image[mask].mean(axis=0), (len(points), 3)).copy()
    colours[on_material] = image[pixel[on_material, 1], pixel[on_material, 0]]
    return colours
