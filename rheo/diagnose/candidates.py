"""The effects a diagnosis can name: each one parameter that the base dam-break model holds at its null value.

Eight are physics a recording may show (floor friction, wall slip, wall adhesion, a gate lifted at a finite speed,
shear thinning, thixotropy, surface tension, air drag); two are decoys, not physics of the material (gravity
tilted, a wrong density): a diagnosis that names them has found a free parameter that fits, not an effect. Each is
searched on a coordinate (its logarithm, or the value itself for the tilt) within a box, climbing rungs of
magnitude outward from the null (both ways for the two-sided decoys).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from rheo.experiments.effects import Effects
from rheo.physics.optional import OPEN_DRAG_TERMS

BAND_POINTS = 9  # shear rates, log-spaced over the band, at which a rung's law matches the last rung's stresses
BREAKDOWN_STRAINS = (1.0, 3.0, 10.0)  # plastic strains whose breakdown a thixotropy rung's starts restore


@dataclass(frozen=True)
class Candidate:
    """An effect: ``name`` (key), ``title`` (plain words), its parameter (``parameter``, ``unit``), the ``null`` value
    that gives back the base model, the box [``low``, ``high``] searched (on the logarithm when ``log``) and the
    ``rungs`` of magnitude a profile climbs, outward from the null (one branch per side)."""

    name: str
    title: str
    parameter: str
    unit: str
    null: float
    low: float
    high: float
    rungs: tuple[tuple[float, ...], ...]
    log: bool = True
    decoy: bool = False
    step: float = 0.7  # initial simplex step on the search coordinate

    def coordinate(self, value: float) -> float:
        return math.log(value) if self.log else value

    def value(self, coordinate: float) -> float:
        return math.exp(coordinate) if self.log else coordinate

    @property
    def bounds(self) -> tuple[float, float]:
        return self.coordinate(self.low), self.coordinate(self.high)

    @property
    def nearest_null(self) -> float:
        """The coordinate in the box nearest the null value: the null itself where the box holds it, else the end
        towards it (the weakest effect searched; an infinite friction coefficient or a zero on a logarithm lies
        outside every box)."""
        null = -math.inf if self.log and self.null == 0 else self.coordinate(self.null)
        low, high = self.bounds
        return min(max(null, low), high)

    def apply(self, value: float, law: dict[str, float], effects: Effects) -> tuple[dict[str, float], Effects]:
        """The law (tau_y, K, n) and effects with this effect at ``value``."""
        physics = effects.physics
        match self.name:
            case "floor_friction":
                return law, dataclasses.replace(effects, floor_friction=value)
            case "wall_slip":
                return law, dataclasses.replace(effects, wall_slip=value)
            case "wall_adhesion":
                return law, dataclasses.replace(effects, physics=dataclasses.replace(physics, wall_adhesion=value))
            case "gate_lift":
                return law, dataclasses.replace(effects, gate_lift_time=value)
            case "shear_thinning":
                return {**law, "n": value}, effects
            case "thixotropy":
                return law, dataclasses.replace(effects, physics=dataclasses.replace(physics, thixotropy=value))
            case "surface_tension":
                return law, dataclasses.replace(effects, physics=dataclasses.replace(physics, surface_tension=value))
            case "air_drag":
                return law, dataclasses.replace(effects, physics=dataclasses.replace(physics, air_drag=value))
            case "gravity_tilt":
                return law, dataclasses.replace(effects, gravity_tilt=math.radians(value))
            case "density":
                return law, dataclasses.replace(effects, density_factor=value)
        raise ValueError(f"unknown effect {self.name!r}")

    def flow_index(self, value: float, base: float) -> float:
        """The law's flow index with the effect at ``value``: shear thinning sets it, the others leave ``base``."""
        return value if self.name == "shear_thinning" else base

    def rung_starts(self, law: np.ndarray, value: float, next_value: float, band: tuple[float, float] | None,
                    base_law: np.ndarray) -> list[np.ndarray]:
        """Where the material (log tau_y, log K, the rest kept) refitted at ``next_value`` may start besides the laws
        along the path, given the law fitted at ``value`` and the base fit's ``base_law``: none unless the effect
        changes what the law's parameters mean. Shear thinning changes what K means: at another flow index the same
        K is another stress at the flow's shear rates, so the law starts where its flow curve matches the last one
        over the shear-rate ``band`` (1/s) that the base fit's flow reaches. Thixotropy changes what tau_y means:
        the base fit's is what the broken-down material showed, the intact material's is larger by what a plastic
        strain of a few units takes away (``BREAKDOWN_STRAINS``), which no short search from the base law reaches:
        on the way the loss rises (docs/settings.md, "Constants in the code")."""
        if self.name == "shear_thinning" and band is not None:
            return [np.r_[matched_law(law, value, next_value, band), law[2:]]]
        if self.name == "thixotropy":
            return [np.r_[base_law[0] + next_value * strain, base_law[1:]] for strain in BREAKDOWN_STRAINS]
        return []


CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    # each profile starts at its box's weak end: the base model, or as near it as the effect's law comes
    # null: a sticky floor (an infinite coefficient); the box reaches from a floor that barely holds to nearly sticky
    Candidate("floor_friction", "floor friction (the material slides on the floor)", "Coulomb coefficient", "",
              math.inf, 0.05, 5.0, ((2.0, 1.0, 0.5, 0.3, 0.18, 0.1),)),
    # null: the setup's sticky floor and walls (an infinite coefficient); across the box a wall stress of 10 Pa
    # makes the material slip at 0.1 mm/s to 1 m/s
    Candidate("wall_slip", "wall slip (the material slides on a sticky floor and walls, Navier's law)",
              "slip coefficient", "Pa s/m", math.inf, 10.0, 1.0e5, ((1.0e4, 3.0e3, 1.0e3, 300.0, 100.0),)),
    Candidate("wall_adhesion", "wall adhesion (smooth walls hold the material)", "adhesion", "Pa", 0.0, 0.1, 1000.0,
              ((5.0, 15.0, 45.0, 135.0),)),
    Candidate("gate_lift", "a gate lifted at a finite speed", "lift time", "s", 0.0, 0.005, 0.3,
              ((0.03, 0.06, 0.12, 0.24),)),
    Candidate("shear_thinning", "shear thinning (flow index n != 1)", "flow index n", "", 1.0, 0.15, 2.0,
              ((0.85, 0.7, 0.55, 0.4),), step=0.3),
    Candidate("thixotropy", "thixotropy (the yield stress falls as the material is sheared)", "breakdown per unit "
              "plastic shear strain", "", 0.0, 0.01, 10.0, ((0.1, 0.3, 1.0, 3.0),)),
    # water's tension is 0.072 N/m, a surfactant's solutions' 0.025-0.04
    Candidate("surface_tension", "surface tension (the free surface pulls the material together)", "tension",
              "N/m", 0.0, 0.003, 0.3, ((0.01, 0.03, 0.09),)),
    Candidate("air_drag", "air drag", "quadratic drag coefficient", "1/m", 0.0, 0.01, 100.0,
              ((2.0, 6.0, 20.0, 60.0),)),
    Candidate("gravity_tilt", "gravity tilted along the channel (decoy)", "tilt", "deg", 0.0, -15.0, 15.0,
              ((2.0, 5.0, 10.0), (-2.0, -5.0, -10.0)), log=False, decoy=True, step=3.0),
    Candidate("density", "a wrong density (decoy)", "density factor", "", 1.0, 0.5, 2.0,
              ((1.25, 1.6), (0.8, 0.63)), decoy=True, step=0.2),
)}


def matched_law(law: np.ndarray, n: float, next_n: float, band: tuple[float, float]) -> np.ndarray:
    """(log tau_y, log K) at flow index ``next_n`` whose Herschel-Bulkley flow curve matches that of ``law`` at
    ``n`` over the shear-rate ``band`` (1/s) most closely in relative stress (non-negative least squares), the
    yield stress kept above a thousandth of its old value (its logarithm must stay finite)."""
    rates = np.geomspace(*band, BAND_POINTS)
    tau_y, K = np.exp(law[:2])
    stress = tau_y + K * rates**n
    (new_tau_y, new_K), _ = nnls(np.stack([np.ones_like(rates), rates**next_n], axis=1) / stress[:, None],
                                 np.ones_like(rates))
    return np.log([max(new_tau_y, 1e-3 * tau_y), max(new_K, 1e-3 * K)])


# The open candidate: a generic discrepancy fitted where no named effect explains the mismatch, the four rates (1/s)
# of OptionalPhysics.open_drag, searched as they are within a box (negative: the flow driven rather than held back)
OPEN_DRAG = tuple(f"drag_{term.replace(' ', '_')}" for term in OPEN_DRAG_TERMS)
OPEN_BOX = (-5.0, 20.0)
OPEN_STEP = 1.0  # initial simplex step of each rate, 1/s


def open_rates(x) -> tuple[float, ...]:
    """The open drag's rates (1/s): the last entries of a search vector."""
    return tuple(float(r) for r in x[-len(OPEN_DRAG):])


@dataclass(frozen=True)
class Law:
    """How a search vector maps to a material and effects: log tau_y, log K, then log n unless the flow index is
    fixed at ``n``, then log mu where the shear modulus is fitted (``fitted_modulus``; else the simulation's), then
    the ``candidate`` effect's coordinate, if any, or the open drag's four rates (``open``)."""

    n: float | None = None
    candidate: Candidate | None = None
    open: bool = False
    fitted_modulus: bool = False

    @property
    def material_names(self) -> tuple[str, ...]:
        """The material's coordinates: the law's, and the shear modulus where fitted."""
        return ("tau_y", "K") + (("n",) if self.n is None else ()) + (("mu",) if self.fitted_modulus else ())

    @property
    def names(self) -> tuple[str, ...]:
        effect = ((self.candidate.name,) if self.candidate else ()) + (OPEN_DRAG if self.open else ())
        return self.material_names + effect

    def unpack(self, x, effects: Effects | None = None) -> tuple[dict[str, float], Effects]:
        """The law (with ``mu`` where the shear modulus is fitted) and the effects (``effects``, none by default, with
        the candidate's added) of a search vector."""
        names = self.material_names
        values = dict(zip(names, np.exp(np.asarray(x[:len(names)], dtype=float)), strict=True))
        law = {"tau_y": values["tau_y"], "K": values["K"], "n": values.get("n", self.n)}
        if self.fitted_modulus:
            law["mu"] = values["mu"]
        effects = effects or Effects()
        if self.candidate is not None:
            law, effects = self.candidate.apply(self.candidate.value(float(x[-1])), law, effects)
        if self.open:
            physics = dataclasses.replace(effects.physics, open_drag=open_rates(x))
            effects = dataclasses.replace(effects, physics=physics)
        return law, effects
