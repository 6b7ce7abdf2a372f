"""Physics beyond the base model that the simulator can switch on, each off at its null value (the default), which
gives back the base model bit for bit.

Some effects are already parameters of the base model's parts: floor friction and slip (a collider's contact law
and Coulomb coefficient), a finite cup or gate lift speed (a moving collider), shear thinning (the flow index n),
the density and the gravity vector. The rest live here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields


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
    fraction on the grid (Lafaurie et al. 1994); the walls are neutral (a contact angle left free)."""

    air_drag: float = 0.0
    thixotropy: float = 0.0
    thixotropy_floor: float = 0.0
    thixotropy_exponent: float = 1.0
    wall_adhesion: float = 0.0
    surface_tension: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"optional physics {f.name} = {value!r} must be finite and >= 0")
        if self.thixotropy_floor >= 1.0:
            raise ValueError(f"optional physics thixotropy_floor = {self.thixotropy_floor!r} must be below 1")
