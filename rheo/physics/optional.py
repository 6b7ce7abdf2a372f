"""Physics beyond the base model that the simulator can switch on, each off at its null value (the default), which
gives back the base model bit for bit.

Some effects are already parameters of the base model's parts: floor friction and slip (a collider's contact law
and Coulomb coefficient), a finite cup or gate lift speed (a moving collider), shear thinning (the flow index n),
the density and the gravity vector. The rest live here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

OPEN_DRAG_TERMS = ("floor early", "floor late", "bulk early", "bulk late")
OPEN_LAYER = 0.25  # the open drag's floor layer in a dam break, a share of the material's height


@dataclass(frozen=True)
class OptionalPhysics:
    """``air_drag`` (1/m): quadratic drag, an acceleration -air_drag |v| v on the material (a body of size L and
    density rho in air of density rho_air: about rho_air C_d / (2 rho L), 1e-2 1/m for a few cm of sauce).
    ``thixotropy``: the yield stress falls to tau_y (floor + (1 - floor) exp(-thixotropy xi)) as the material
    accumulates xi, the integral over time of its plastic shear rate to the power ``thixotropy_exponent`` (1: the
    plastic shear strain; 0: the time spent yielding, thixotropy then in 1/s); its structure breaks down, with no
    rebuilding over the seconds simulated. ``thixotropy_floor`` (in [0, 1)): the share a broken-down structure
    keeps.
    ``wall_adhesion`` (Pa): a traction with which every non-sticky collider holds the material touching it, against
    sliding and separating alike and whatever the pressure (unlike Coulomb friction).
    ``surface_tension`` (N/m): the free surface's tension, as the continuum surface stress of the material's volume
    fraction on the grid (Lafaurie et al. 1994); the walls are neutral (a contact angle left free).
    ``open_drag`` (1/s, signed): a generic discrepancy, a linear drag -rate v on the material whose rate blends four
    values, (floor early, floor late, bulk early, bulk late): near the floor y = 0 (weight exp(-height /
    ``open_layer``, m)) or above it, and from the release to ``open_span`` (s), linearly; a negative rate drives
    the flow instead of holding it."""

    air_drag: float = 0.0
    thixotropy: float = 0.0
    thixotropy_floor: float = 0.0
    thixotropy_exponent: float = 1.0
    wall_adhesion: float = 0.0
    surface_tension: float = 0.0
    open_drag: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    open_layer: float = 1.0
    open_span: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "open_drag":
                if len(value) != len(OPEN_DRAG_TERMS) or not all(math.isfinite(v) for v in value):
                    raise ValueError(f"optional physics open_drag = {value!r} must be {len(OPEN_DRAG_TERMS)} finite "
                                     f"rates (1/s: {', '.join(OPEN_DRAG_TERMS)})")
            elif not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"optional physics {f.name} = {value!r} must be finite and >= 0")
        if not (self.open_layer > 0.0 and self.open_span > 0.0):
            raise ValueError(f"optional physics open_layer {self.open_layer!r} m and open_span {self.open_span!r} s "
                             "must be > 0")
        if self.thixotropy_floor >= 1.0:
            raise ValueError(f"optional physics thixotropy_floor = {self.thixotropy_floor!r} must be below 1")


def open_drag_rate(rates: Sequence[float], height: np.ndarray, time: np.ndarray, layer: float,
                   span: float) -> np.ndarray:
    """The open drag's rate (1/s) at ``height`` (m) above the floor and ``time`` (s) after the release, blended from
    its four ``rates`` as the simulator blends them (``OptionalPhysics``)."""
    floor_early, floor_late, bulk_early, bulk_late = rates
    late = np.minimum(np.asarray(time) / span, 1.0)
    floor = np.exp(-np.maximum(np.asarray(height), 0.0) / layer)
    return (floor * ((1 - late) * floor_early + late * floor_late)
            + (1 - floor) * ((1 - late) * bulk_early + late * bulk_late))
