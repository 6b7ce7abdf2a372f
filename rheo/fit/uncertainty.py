"""Tolerance intervals of fitted parameters (their coverage is not calibrated).

The fit's model is never exact (particles instead of a continuum, disc silhouettes instead of the camera's), so
the loss has a floor well above any noise; materials whose loss lies within a tolerance of the best (the model's
own error, measured on virtual experiments where the truth is known) cannot be told apart. The interval of a
parameter is its range over the region where the loss stays within that tolerance: the region of the surface fitted
to the loss (``rheo.fit.surface``), grown to the evaluated materials within it (``Tolerated.widen``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from rheo.experiments.rheometer import herschel_bulkley

Z95 = 1.959964
# A parameter is determined when its tolerance interval spans less than this factor (low to high) and is closed.
DETERMINED_SPAN = 4.0
# ... a flow index ("n"), whose real materials' values span far less (0.2 to 1.5), when its interval tells n 0.5 from 1
SPANS = {"n": 1.5}


@dataclass
class Interval:
    """A parameter's value and tolerance interval; an open end (``open``: low, high) is a lower bound on the interval's
    reach there (the region within the tolerance goes on past what the fit evaluated)."""

    value: float
    low: float
    high: float
    open: tuple[bool, bool] = (False, False)
    span: float = DETERMINED_SPAN  # the widest (high / low) a determined interval may be

    @property
    def determined(self) -> bool:
        return self.high / self.low < self.span and not any(self.open)

    @property
    def sigma_log(self) -> float:
        """The standard deviation of the normal log-parameter whose central 95 % is this interval."""
        return float(np.log(self.high / self.low) / (2 * Z95))


def parameter_interval(name: str, value: float, low: float, high: float,
                       open_ends: tuple[bool, bool] = (False, False)) -> Interval:
    """The interval of the parameter ``name``, judged determined by that parameter's span."""
    return Interval(value, low, high, open_ends, SPANS.get(name, DETERMINED_SPAN))


def grown_to_profile(interval: Interval, values: Sequence[float], losses: Sequence[float],
                     level: float) -> Interval:
    """``interval`` grown to hold where the parameter's profile (the lowest loss found at each of ``values``, the
    other parameters free) lies within ``level``, the profile taken linear in the parameter's logarithm between
    values; an end is open where the profile is still within the level at the first or last value."""
    order = np.argsort(values)
    x, y = np.log(np.asarray(values, dtype=float)[order]), np.asarray(losses, dtype=float)[order]
    within = np.flatnonzero(y <= level)
    if len(x) < 2 or not len(within):
        return interval

    def crossing(inside: int, outside: int) -> float:
        return float(np.exp(x[inside] + (level - y[inside]) / (y[outside] - y[inside]) * (x[outside] - x[inside])))

    first, last = int(within[0]), int(within[-1])
    low = float(np.exp(x[0])) if first == 0 else crossing(first, first - 1)
    high = float(np.exp(x[-1])) if last == len(x) - 1 else crossing(last, last + 1)
    return dataclasses.replace(
        interval, low=min(interval.low, low), high=max(interval.high, high),
        open=(interval.open[0] if interval.low < low else interval.open[0] or first == 0,
              interval.open[1] if interval.high > high else interval.open[1] or last == len(x) - 1))


def log_draws(intervals: Sequence[Interval], count: int = 400, seed: int = 0, clip: float = 4.0) -> np.ndarray:
    """(count, parameters) draws of the log-parameters, independent normals whose central 95 % are the
    ``intervals``, clipped to ``clip`` log units (a factor e^4, about 55) of each value: an undetermined parameter's
    spread is otherwise huge."""
    mean = np.log([i.value for i in intervals])
    sigma = np.array([i.sigma_log for i in intervals])
    draws = mean + sigma * np.random.default_rng(seed).standard_normal((count, len(intervals)))
    return np.clip(draws, mean - clip, mean + clip)


Evaluate = Callable[[np.ndarray, str], float]  # loss at a point of log-parameters, in a named phase


@dataclass
class Tolerated:
    """The evaluated materials whose loss lies within the tolerance of the lowest, as log-parameters (count,
    parameters). Unlike the conditional profiles, their ranges see parameters that trade against each other, but
    only where the search evaluated."""

    points: np.ndarray

    @property
    def count(self) -> int:
        return len(self.points)

    @property
    def ranges(self) -> np.ndarray:
        """Each log-parameter's range over the materials (parameters, 2)."""
        return np.column_stack([self.points.min(axis=0), self.points.max(axis=0)])

    @property
    def direction(self) -> np.ndarray | None:
        """The unit vector (log-parameters) along which the materials spread most; None below three."""
        if self.count < 3:
            return None
        direction = np.linalg.eigh(np.cov(self.points.T))[1][:, -1]
        return direction * np.sign(direction[np.argmax(np.abs(direction))])

    @property
    def span(self) -> float:
        """The largest factor (high / low) of any parameter over the materials."""
        return float(np.exp(np.max(self.ranges[:, 1] - self.ranges[:, 0])))

    @property
    def ridge(self) -> bool:
        """Whether the materials spread along a ridge: some parameter over at least DETERMINED_SPAN."""
        return self.span >= DETERMINED_SPAN

    def widen(self, intervals: dict[str, Interval], names: Sequence[str],
              box: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, Interval]:
        """Each interval (of the parameters ``names``, in order) grown to hold these materials' range along its
        parameter: a conditional profile misses where the parameters trade against each other. An end where one of
        them lies at the search ``box`` (log-parameters, low and high) is open: the region goes on past the fit's
        reach."""
        widened = {}
        for i, (name, (low, high)) in enumerate(zip(names, self.ranges, strict=True)):
            interval = intervals[name]
            at_box = (False, False) if box is None else (bool(np.isclose(low, box[0][i])),
                                                          bool(np.isclose(high, box[1][i])))
            widened[name] = dataclasses.replace(
                interval, low=min(interval.low, float(np.exp(low))), high=max(interval.high, float(np.exp(high))),
                open=(interval.open[0] or at_box[0], interval.open[1] or at_box[1]))
        return widened


@dataclass(frozen=True)
class DeterminedStress:
    """Where the flow curves of several laws agree best: the shear rate (1/s) and their lowest and highest stress
    there (Pa)."""

    rate: float
    low: float
    high: float


def best_determined_stress(laws: np.ndarray, band: Sequence[float], samples: int = 200) -> DeterminedStress | None:
    """The shear rate within ``band`` (1/s) at which the Herschel-Bulkley ``laws`` (rows tau_y, K, n) spread least in
    stress (highest over lowest), and their stresses there; None where the laws have fewer than three flow indices
    (two flow curves cross somewhere whatever they are, so where they agree says nothing)."""
    laws = np.atleast_2d(np.asarray(laws, dtype=float))
    if len(np.unique(laws[:, 2].round(6))) < 3:
        return None
    rates = np.geomspace(band[0], band[1], samples)
    stress = herschel_bulkley(rates, laws[:, :1], laws[:, 1:2], laws[:, 2:3])  # (laws, rates)
    best = int(np.argmin(stress.max(axis=0) / stress.min(axis=0)))
    return DeterminedStress(float(rates[best]), float(stress[:, best].min()), float(stress[:, best].max()))


def tolerance_level(loss: float, tolerance: float) -> float:
    """The highest loss within ``tolerance`` (relative) of ``loss``."""
    return (1.0 + tolerance) * loss


def tolerated(points: np.ndarray, losses: np.ndarray, tolerance: float) -> Tolerated:
    """The evaluated ``points`` (log-parameters) whose ``losses`` lie within ``tolerance`` (relative) of the lowest,
    each once (a point evaluated in two phases is one material)."""
    points, losses = np.asarray(points, dtype=float), np.asarray(losses, dtype=float)
    return Tolerated(np.unique(points[losses <= tolerance_level(losses.min(), tolerance)], axis=0))
