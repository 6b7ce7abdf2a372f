"""Differentiable volume rendering of particle fields (PyTorch): particles carry a density and a colour, are spread
to a voxel grid with trilinear weights (the thesis' eq. 3.7), and rays are marched through the grid with a background
colour (eq. 3.3). Gradients reach the particles' positions, densities and colours.

The density grid is the weighted sum of the particles' densities (a filled region with one particle per voxel has
weights summing to about one, so the field falls off over one voxel at the free surface); the colour grid is the
density-weighted mean of the particles' colours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

WHITE = torch.ones(3)  # the matted frames' background
COUNT_FLOOR = 0.3  # particles per cell below which the density field is empty (docs/settings.md)


@dataclass(frozen=True)
class VoxelGrid:
    """An axis-aligned grid of ``shape`` nodes, node (0, 0, 0) at ``origin``, ``spacing`` apart (world units)."""

    origin: tuple[float, float, float]
    spacing: float
    shape: tuple[int, int, int]

    @classmethod
    def around(cls, points: np.ndarray, spacing: float, pad: int = 2, anchor: np.ndarray | None = None) -> VoxelGrid:
        """The grid of ``spacing`` that holds ``points`` with ``pad`` nodes to spare on every side: its nodes on
        multiples of ``spacing``, or, with ``anchor``, half a spacing off it (a particle lattice through ``anchor``
        then lies at cell centres, where the trilinear weights have no kink and their gradient is two-sided)."""
        shift = np.zeros(3) if anchor is None else np.asarray(anchor, float) + 0.5 * spacing
        lo = np.floor((points.min(axis=0) - shift) / spacing) - pad
        hi = np.ceil((points.max(axis=0) - shift) / spacing) + pad
        return cls(tuple((shift + lo * spacing).tolist()), float(spacing), tuple((hi - lo + 1).astype(int).tolist()))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.asarray(self.origin)
        return lo, lo + self.spacing * (np.asarray(self.shape) - 1)

    def centres(self) -> np.ndarray:
        """World positions of every node, (nx, ny, nz, 3)."""
        axes = [self.origin[a] + self.spacing * np.arange(self.shape[a]) for a in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def particles_to_grid(positions: torch.Tensor, values: torch.Tensor, grid: VoxelGrid) -> torch.Tensor:
    """Trilinear splat of per-particle ``values`` (N, C) to the grid's nodes: (C, nx, ny, nz), the weighted sums."""
    local = (positions - torch.as_tensor(grid.origin, dtype=positions.dtype)) / grid.spacing
    base = torch.floor(local).detach()
    frac = local - base
    base = base.long()
    shape = torch.as_tensor(grid.shape)
    out = torch.zeros((values.shape[1], int(np.prod(grid.shape))), dtype=values.dtype)
    for offset in np.ndindex(2, 2, 2):
        o = torch.as_tensor(offset)
        node = base + o
        weight = torch.prod(torch.where(o.bool(), frac, 1.0 - frac), dim=1)
        inside = ((node >= 0) & (node < shape)).all(dim=1)
        flat = (node[:, 0] * shape[1] + node[:, 1]) * shape[2] + node[:, 2]
        out.index_add_(1, flat[inside], (values[inside] * weight[inside, None]).T)
    return out.reshape(values.shape[1], *grid.shape)


def particle_fields(positions: torch.Tensor, density: torch.Tensor, colour: torch.Tensor | None,
                    grid: VoxelGrid) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Density (nx, ny, nz) and colour (3, nx, ny, nz) grids of a particle field whose particles sit on a lattice
    of the grid's spacing: the splatted particle count is about 1 inside the material and falls to 1/2 where the
    particles' volumes end and to 0 half a particle further out. The density is the particles' mean density times
    the count above COUNT_FLOOR (rescaled to 1 inside), which puts the rendered surface (half opacity) of opaque
    particles (density OPAQUE / spacing, see rheo.fit.seed) where their volumes end."""
    values = [torch.ones_like(density)[:, None], density[:, None]]
    if colour is not None:
        values.append(density[:, None] * colour)
    sums = particles_to_grid(positions, torch.cat(values, dim=1), grid)
    count, weighted = sums[0], sums[1]
    mean_density = weighted / count.clamp_min(1e-8)
    field = mean_density * torch.clamp((count - COUNT_FLOOR) / (1.0 - COUNT_FLOOR), min=0.0)
    return field, None if colour is None else sums[2:] / weighted.clamp_min(1e-8)


def _ray_box(origins: torch.Tensor, dirs: torch.Tensor, lo: np.ndarray, hi: np.ndarray):
    """Entry and exit distances of rays through an axis-aligned box (exit < entry where a ray misses it)."""
    safe = torch.where(dirs.abs() < 1e-12, torch.full_like(dirs, 1e-12), dirs)
    t0 = (torch.as_tensor(lo, dtype=dirs.dtype) - origins) / safe
    t1 = (torch.as_tensor(hi, dtype=dirs.dtype) - origins) / safe
    near = torch.minimum(t0, t1).amax(dim=1).clamp_min(0.0)
    far = torch.maximum(t0, t1).amin(dim=1)
    return near, far


def march(density: torch.Tensor, colour: torch.Tensor | None, grid: VoxelGrid, origins: torch.Tensor,
          dirs: torch.Tensor, background: torch.Tensor | None = None,
          step: float | None = None) -> tuple[torch.Tensor | None, torch.Tensor]:
    """Volume rendering of the grids along rays (origins (R, 3), unit directions (R, 3)).

    Returns the ray colours (R, 3) over ``background`` (or None without a colour grid: silhouette mode) and the
    opacities (R,), 1 - transmittance. Samples every ``step`` (half a voxel by default) inside the grid.
    """
    step = 0.5 * grid.spacing if step is None else step
    lo, hi = grid.bounds()
    near, far = _ray_box(origins, dirs, lo, hi)
    count = int(np.ceil(np.linalg.norm(hi - lo) / step)) + 1
    t = near[:, None] + step * (torch.arange(count, dtype=dirs.dtype) + 0.5)[None, :]
    valid = t < far[:, None]
    points = origins[:, None, :] + t[..., None] * dirs[:, None, :]
    # grid_sample wants (x, y, z) -> (W, H, D) in [-1, 1]: our (nx, ny, nz) layout is (D, H, W)
    normalized = 2.0 * (points - torch.as_tensor(lo, dtype=dirs.dtype)) / torch.as_tensor(hi - lo, dtype=dirs.dtype)
    sample_at = normalized.flip(-1)[None, :, :, None, :] - 1.0  # (1, R, S, 1, 3)
    channels = density[None] if colour is None else torch.cat([density[None], colour], dim=0)
    sampled = F.grid_sample(channels[None], sample_at, mode="bilinear", padding_mode="zeros",
                            align_corners=True)[0, :, :, :, 0]  # (C, R, S)
    alpha = (1.0 - torch.exp(-sampled[0].clamp_min(0.0) * step)) * valid
    transmittance = torch.cumprod(torch.cat([torch.ones_like(alpha[:, :1]), 1.0 - alpha[:, :-1]], dim=1), dim=1)
    weights = alpha * transmittance
    opacity = weights.sum(dim=1)
    if colour is None:
        return None, opacity
    rgb = torch.einsum("rs,crs->rc", weights, sampled[1:])
    if background is not None:
        rgb = rgb + (1.0 - opacity)[:, None] * background
    return rgb, opacity


def render_particles(positions: torch.Tensor, density: torch.Tensor, colour: torch.Tensor | None, spacing: float,
                     origins: torch.Tensor, dirs: torch.Tensor, background: torch.Tensor | None = None,
                     anchor: np.ndarray | None = None) -> tuple[torch.Tensor | None, torch.Tensor]:
    """Rays through a particle field splatted to a grid of ``spacing`` around the particles (colour None:
    silhouette mode; ``anchor``: see ``VoxelGrid.around``). See ``march``."""
    grid = VoxelGrid.around(positions.detach().cpu().numpy(), spacing, anchor=anchor)
    return march(*particle_fields(positions, density, colour, grid), grid, origins, dirs, background)


def render_view(positions: np.ndarray, density: np.ndarray, colour: np.ndarray, spacing: float, origin: np.ndarray,
                dirs: np.ndarray, chunk: int = 32768) -> tuple[np.ndarray, np.ndarray]:
    """Colours (R, 3) on white and opacities (R,) of a particle field along many rays (no gradients), in chunks."""
    p, d, c = (torch.as_tensor(a, dtype=torch.float32) for a in (positions, density, colour))
    grid = VoxelGrid.around(positions, spacing, anchor=positions[0])
    rgb, opacity = [], []
    with torch.no_grad():
        density_grid, colour_grid = particle_fields(p, d, c, grid)
        for start in range(0, len(dirs), chunk):
            ray_dirs = torch.as_tensor(dirs[start:start + chunk], dtype=torch.float32)
            origins = torch.as_tensor(origin, dtype=torch.float32).expand(len(ray_dirs), 3)
            r, o = march(density_grid, colour_grid, grid, origins, ray_dirs, torch.ones(3))
            rgb.append(r.numpy())
            opacity.append(o.numpy())
    return np.concatenate(rgb), np.concatenate(opacity)
