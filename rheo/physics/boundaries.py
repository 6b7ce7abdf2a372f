"""Colliders: the floor, static boxes (container walls) and moving ones (a lifted cup, a dam-break gate).

Each collider is a solid region given by a signed distance function, a contact law applied at the grid nodes inside
it (sticky, slip, Coulomb friction with a coefficient, or Navier partial slip: a wall traction beta times the slip
velocity, beta in Pa s/m, on the nodes of the collider's face) and a rigid motion: constant velocity between
``start`` and ``stop`` seconds. The friction coefficient (Coulomb's, or Navier's beta) and the velocity are
differentiable boundary parameters; geometry enters through which nodes lie inside and is not differentiated.
Lengths in m, speeds in m/s, times in s, y is up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import torch

from rheo.physics import kernels as k

CONTACT_LAWS = {"sticky": k.CONTACT_STICKY, "slip": k.CONTACT_SLIP, "friction": k.CONTACT_FRICTION,
                "navier": k.CONTACT_NAVIER}


class BoundaryError(ValueError):
    """A collider description the simulator cannot use."""


def _finite(name: str, *values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        raise BoundaryError(f"collider {name} = {values!r} must be finite")


@dataclass(frozen=True)
class Collider:
    """Common part: contact law, friction coefficient and motion."""

    contact: str = "sticky"
    friction: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start: float = 0.0
    stop: float = math.inf

    shape: ClassVar[int]

    def __post_init__(self) -> None:
        if self.contact not in CONTACT_LAWS:
            raise BoundaryError(f"unknown contact law {self.contact!r}; known: {sorted(CONTACT_LAWS)}")
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise BoundaryError(f"friction coefficient {self.friction!r} must be finite and >= 0")
        _finite("velocity", *self.velocity)
        if not (math.isfinite(self.start) and self.stop >= self.start):
            raise BoundaryError(f"collider motion needs finite start <= stop, got start={self.start}, stop={self.stop}")

    def geometry(self, origin) -> list[float]:
        """Shape parameters relative to the simulation domain's corner ``origin``."""
        raise NotImplementedError

    def parameters(self) -> list[float]:
        """Differentiable parameters: friction coefficient, then velocity (vx, vy, vz)."""
        return [self.friction, *self.velocity]


@dataclass(frozen=True)
class Floor(Collider):
    """The half-space below ``height``."""

    height: float = 0.0
    shape: ClassVar[int] = k.SHAPE_FLOOR

    def __post_init__(self) -> None:
        super().__post_init__()
        _finite("height", self.height)

    def geometry(self, origin) -> list[float]:
        return [self.height - origin[1]]


@dataclass(frozen=True)
class Box(Collider):
    """An axis-aligned solid box (a container wall, or with a velocity a dam-break gate)."""

    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    half_extents: tuple[float, float, float] = (0.1, 0.1, 0.1)
    shape: ClassVar[int] = k.SHAPE_BOX

    def __post_init__(self) -> None:
        super().__post_init__()
        _finite("center", *self.center)
        if not all(math.isfinite(h) and h > 0 for h in self.half_extents):
            raise BoundaryError(f"box half extents {self.half_extents!r} must be finite and > 0")

    def geometry(self, origin) -> list[float]:
        return [*(c - o for c, o in zip(self.center, origin, strict=True)), *self.half_extents]


@dataclass(frozen=True)
class Cup(Collider):
    """An upturned cup: a truncated-cone shell with a vertical axis at (x, z) = ``axis``, open at its rim
    (y = ``rim_height``), closed at the top.

    The material fills the cavity; lifting the cup (a velocity along +y from ``start``) releases it.
    """

    axis: tuple[float, float] = (0.5, 0.5)
    rim_height: float = 0.0
    height: float = 0.1
    rim_radius: float = 0.05
    top_radius: float = 0.05
    thickness: float = 0.02
    shape: ClassVar[int] = k.SHAPE_CUP

    def __post_init__(self) -> None:
        super().__post_init__()
        _finite("axis", *self.axis)
        _finite("rim_height", self.rim_height)
        for name in ("height", "rim_radius", "top_radius", "thickness"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise BoundaryError(f"cup {name} = {value!r} must be finite and > 0")

    def geometry(self, origin) -> list[float]:
        return [self.axis[0] - origin[0], self.axis[1] - origin[2], self.rim_height - origin[1], self.height,
                self.rim_radius, self.top_radius, self.thickness]


def lifted_cup(speed: float, start: float = 0.0, **geometry: float) -> Cup:
    """A cup lifted vertically at ``speed`` (m/s) from time ``start``."""
    return Cup(velocity=(0.0, speed, 0.0), start=start, contact=geometry.pop("contact", "slip"), **geometry)


def dam_break_gate(speed: float, start: float = 0.0, **geometry) -> Box:
    """A gate plate that slides up at ``speed`` (m/s) from time ``start``."""
    return Box(velocity=(0.0, speed, 0.0), start=start, contact=geometry.pop("contact", "slip"), **geometry)


@dataclass(frozen=True)
class ColliderArrays:
    """Colliders packed for the kernels."""

    shapes: list[int]
    laws: list[int]
    geometry: list[list[float]]
    timing: list[list[float]]
    parameters: torch.Tensor  # (n, 4), differentiable


def pack(colliders: tuple[Collider, ...] | list[Collider], origin=(0.0, 0.0, 0.0)) -> ColliderArrays:
    """Colliders as kernel arrays, their geometry relative to the domain corner ``origin``."""
    if len(colliders) > k.MAX_COLLIDERS:
        raise BoundaryError(f"{len(colliders)} colliders given; at most {k.MAX_COLLIDERS} are supported")
    geometry = []
    for c in colliders:
        g = c.geometry(origin)
        geometry.append(g + [0.0] * (k.N_GEOM - len(g)))
    return ColliderArrays(
        shapes=[c.shape for c in colliders],
        laws=[CONTACT_LAWS[c.contact] for c in colliders],
        geometry=geometry,
        timing=[[c.start, min(c.stop, 1e30)] for c in colliders],
        parameters=torch.tensor([c.parameters() for c in colliders], dtype=torch.float64).reshape(-1, 4),
    )
