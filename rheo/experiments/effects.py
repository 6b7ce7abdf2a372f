"""What the base dam break leaves out, each at its null value by default: the effects a scene can switch on (a gate
lifted at a finite speed, a floor the material slides on, ...), without loading the simulator."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rheo.physics.optional import OptionalPhysics


class DamBreakError(ValueError):
    """A dam break that cannot be simulated as asked."""


@dataclass(frozen=True)
class Effects:
    """What the base dam break leaves out, each at its null value by default (the base model, bit for bit).

    ``floor_friction``: the Coulomb coefficient of a floor the material slides on (None: the floor as the setup
    gives it). ``wall_slip`` (Pa s/m): the floor and walls that the setup makes sticky hold the material with a
    Navier traction, this coefficient times its slip velocity, and walls that slip freely stay so (None: the setup's
    contact laws; a floor friction, when given, prevails on the floor). ``gate_lift_time`` (s): a gate at the
    cuboid's front slides up at a constant speed and clears the material's height after this time (0: released at
    once). ``gravity_tilt`` (rad): gravity leans towards +x, down the channel (a table or camera not level).
    ``density_factor``: the material's density times this (a wrong density). ``physics``: the engine's optional
    physics (air drag, thixotropy, wall adhesion, surface tension, the open drag); the scene sets the open drag's
    floor layer to a quarter of the material's height and its span to the rollout's duration."""

    floor_friction: float | None = None
    wall_slip: float | None = None
    gate_lift_time: float = 0.0
    gravity_tilt: float = 0.0
    density_factor: float = 1.0
    physics: OptionalPhysics = field(default_factory=OptionalPhysics)

    def __post_init__(self) -> None:
        if self.floor_friction is not None and not (math.isfinite(self.floor_friction) and self.floor_friction >= 0):
            raise DamBreakError(f"floor friction coefficient {self.floor_friction!r} must be finite and >= 0")
        if self.wall_slip is not None and not (math.isfinite(self.wall_slip) and self.wall_slip >= 0):
            raise DamBreakError(f"wall slip coefficient {self.wall_slip!r} Pa s/m must be finite and >= 0")
        if not (math.isfinite(self.gate_lift_time) and self.gate_lift_time >= 0):
            raise DamBreakError(f"gate lift time {self.gate_lift_time!r} s must be finite and >= 0")
        if not (math.isfinite(self.gravity_tilt) and abs(self.gravity_tilt) < 0.5 * math.pi):
            raise DamBreakError(f"gravity tilt {self.gravity_tilt!r} rad must lie within (-pi/2, pi/2)")
        if not (math.isfinite(self.density_factor) and self.density_factor > 0):
            raise DamBreakError(f"density factor {self.density_factor!r} must be finite and > 0")
