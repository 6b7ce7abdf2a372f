"""Particle sets filling simple solids on a regular lattice (a fixed number of particles per grid cell)."""

from __future__ import annotations

from collections.abc import Callable

import torch


def lattice_fill(inside: Callable[[torch.Tensor], torch.Tensor], lower, upper, spacing: float,
                 dtype: torch.dtype = torch.float64) -> tuple[torch.Tensor, float]:
    """Lattice points (cell centres of a grid of ``spacing``) inside the box [lower, upper] for which ``inside``
    is true; returns the positions (N, 3) and the volume each one represents (spacing^3)."""
    axes = [torch.arange(lo + spacing / 2, hi, spacing, dtype=dtype) for lo, hi in zip(lower, upper, strict=True)]
    points = torch.cartesian_prod(*axes).reshape(-1, 3)
    return points[inside(points)], spacing**3


def cylinder(center_xz, base_y: float, radius: float, height: float, spacing: float,
             dtype: torch.dtype = torch.float64) -> tuple[torch.Tensor, float]:
    """A vertical (y is up) solid cylinder with its axis at (x, z) = ``center_xz``, standing on y = ``base_y``."""
    cx, cz = center_xz

    def inside(p: torch.Tensor) -> torch.Tensor:
        return (p[:, 0] - cx) ** 2 + (p[:, 2] - cz) ** 2 <= radius**2

    return lattice_fill(inside, (cx - radius, base_y, cz - radius), (cx + radius, base_y + height, cz + radius),
                        spacing, dtype)


def box(lower, upper, spacing: float, dtype: torch.dtype = torch.float64) -> tuple[torch.Tensor, float]:
    """A solid axis-aligned box."""
    return lattice_fill(lambda p: torch.ones(len(p), dtype=torch.bool), lower, upper, spacing, dtype)
