"""Approximate 95 % intervals of fitted parameters, from profiles of the loss.

The fit's model is never exact (particles instead of a continuum, disc silhouettes instead of the camera's), so
the loss has a floor well above any noise; materials whose loss lies within a tolerance of the best (the model's
own error, measured on virtual experiments where the truth is known) cannot be told apart. The interval of a
parameter is the range along it where the loss stays within that tolerance: from a parabola fitted through the
loss at -2, -1, 0, 1, 2 steps, which smooths the roughness pixel edges give the loss (a local Hessian would be
meaningless there). The other parameters stay at the optimum (a conditional profile: correlations are not
included); ``Tolerated.widen`` grows the intervals to the evaluated materials within the tolerance, which do see them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

Z95 = 1.959964
# A parameter is determined when its 95 % interval spans less than this factor (low to high) and is closed.
DETERMINED_SPAN = 4.0


@dataclass
class Interval:
    """A parameter's value and 95 % interval; an open end (``open``: low, high) is a lower bound on the interval's
    reach there (the region within the tolerance goes on past what the fit evaluated)."""

    value: float
    low: float
    high: float
    open: tuple[bool, bool] = (False, False)

    @property
    def determined(self) -> bool:
        return self.high / self.low < DETERMINED_SPAN and not any(self.open)

    @property
    def sigma_log(self) -> float:
        """The standard deviation of the normal log-parameter whose 95 % interval this is."""
        return float(np.log(self.high / self.low) / (2 * Z95))


def parabola_region(offsets: np.ndarray, values: np.ndarray, threshold: float) -> tuple[float, float]:
    """The range of offsets where the parabola fitted to (offsets, values) stays below ``threshold``. Where it does
    not curve upwards, the range of the sampled offsets below the threshold, unbounded (infinite) on each side where
    the outermost sample is still below it."""
    a, b, c = np.polynomial.polynomial.polyfit(offsets, values, 2)
    if c > 0:
        vertex = -b / (2 * c)
        half = np.sqrt(max(threshold - (a + b * vertex + c * vertex**2), 0.0) / c)
        return vertex - half, vertex + half
    below = offsets[values <= threshold]
    if not len(below):
        best = offsets[int(np.argmin(values))]
        return best, best
    return (-np.inf if values[0] <= threshold else below.min(), np.inf if values[-1] <= threshold else below.max())


def log_draws(intervals: Sequence[Interval], count: int = 400, seed: int = 0, clip: float = 4.0) -> np.ndarray:
    """(count, parameters) draws of the log-parameters, independent normals whose 95 % intervals are
    ``intervals``, clipped to ``clip`` log units (a factor e^4, about 55) of each value: an undetermined parameter's
    spread is otherwise huge."""
    mean = np.log([i.value for i in intervals])
    sigma = np.array([i.sigma_log for i in intervals])
    draws = mean + sigma * np.random.default_rng(seed).standard_normal((count, len(intervals)))
    return np.clip(draws, mean - clip, mean + clip)


Evaluate = Callable[[np.ndarray, str], float]  # loss at a point of log-parameters, in a named phase
PROFILE_OFFSETS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])  # the profile points, in steps


def profile_points(centre: np.ndarray, free: Sequence[int], step: float) -> list[np.ndarray]:
    """Every point ``profile_intervals`` evaluates, to evaluate them together beforehand."""
    points = [centre]
    for i in free:
        for d in PROFILE_OFFSETS[PROFILE_OFFSETS != 0] * step:
            point = centre.copy()
            point[i] += d
            points.append(point)
    return points


def profile_intervals(evaluate: Evaluate, centre: np.ndarray, free: Sequence[int], names: Sequence[str], step: float,
                      tolerance: float, box: tuple[np.ndarray, np.ndarray], phase: str = "profile"
                      ) -> tuple[np.ndarray, float, dict[str, Interval], dict]:
    """Intervals of the ``free`` parameters from profiles of the loss along each of them (the others at
    ``centre``; offsets -2, -1, 1, 2 times ``step`` in log units): the range where a parabola through the profile
    stays within ``tolerance`` (relative) of the lowest loss seen, clipped to ``box`` (up to the box's edge on a
    side where the profile stays low). A parabola over a wide step smooths the roughness pixel edges give the loss,
    which would make a local Hessian meaningless. Returns the best point seen, its loss, the intervals and the
    evidence."""
    offsets = PROFILE_OFFSETS * step
    centre_loss, *around = [evaluate(point, phase) for point in profile_points(centre, free, step)]
    side = len(offsets) - 1  # points per parameter besides the centre
    profiles = {i: np.insert(around[k * side:(k + 1) * side], side // 2, centre_loss) for k, i in enumerate(free)}
    lowest = min(centre_loss, *(p.min() for p in profiles.values()))
    threshold = (1.0 + tolerance) * lowest
    x, loss = centre.copy(), centre_loss
    for i, values in profiles.items():
        if values.min() < loss:
            x, loss = centre.copy(), float(values.min())
            x[i] += offsets[int(np.argmin(values))]
    intervals, unbounded = {}, []
    for i, values in profiles.items():
        span = parabola_region(offsets, values, threshold)
        if not np.isfinite(span).all():
            unbounded.append(names[i])
        low, high = centre[i] + span[0], centre[i] + span[1]
        low, high = min(max(low, box[0][i]), x[i]), max(min(high, box[1][i]), x[i])
        intervals[names[i]] = Interval(float(np.exp(x[i])), float(np.exp(low)), float(np.exp(high)))
    evidence = {"loss": loss, "threshold": threshold, "profile_offsets_log": offsets.tolist(),
                "profiles": {names[i]: v.tolist() for i, v in profiles.items()}, "unbounded": unbounded}
    return x, loss, intervals, evidence


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

    def widen(self, intervals: dict[str, Interval], names: Sequence[str]) -> dict[str, Interval]:
        """Each interval (of the parameters ``names``, in order) grown to hold these materials' range along its
        parameter: a conditional profile misses where the parameters trade against each other."""
        return {name: dataclasses.replace(intervals[name], low=min(intervals[name].low, float(np.exp(low))),
                                          high=max(intervals[name].high, float(np.exp(high))))
                for name, (low, high) in zip(names, self.ranges, strict=True)}


def tolerated(points: np.ndarray, losses: np.ndarray, tolerance: float) -> Tolerated:
    """The evaluated ``points`` (log-parameters) whose ``losses`` lie within ``tolerance`` (relative) of the lowest,
    each once (a point evaluated in two phases is one material)."""
    points, losses = np.asarray(points, dtype=float), np.asarray(losses, dtype=float)
    return Tolerated(np.unique(points[losses <= (1.0 + tolerance) * losses.min()], axis=0))
