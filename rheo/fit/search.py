"""Fitting the material on whole-frame silhouettes, without gradients.

The loss is the mean symmetric boundary distance (pixels) between the simulated particles' silhouettes and the masks,
over every view and frame: deterministic (every pixel, no random rays) and informative even far from the optimum,
where overlap losses are flat. Its minimiser is searched in two steps: a quasi-random survey of a wide box of
log-parameters around the initial guess, then Nelder-Mead from the best point of the survey. Gradient descent on
the rendering loss stalled in the curved, nearly flat valley between soft-and-strong and stiff-and-weak materials;
the survey finds the right valley and the simplex needs no gradient of a loss that pixel edges make rough.

Every evaluation is stored (in a JSON file written atomically after each one), so an interrupted search replays the
stored values and goes on from where it stopped.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc

from rheo.fit.observations import Observations
from rheo.fit.uncertainty import Z95, Interval
from rheo.io import write_atomic
from rheo.render.silhouette import coverage

logger = logging.getLogger(__name__)


def _outside_distance(mask: np.ndarray) -> np.ndarray:
    """Distance (px) from every pixel to the nearest pixel of ``mask``."""
    return cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


class SilhouetteTarget:
    """The masks of frames 0 .. ``frames`` of every view, with their distance maps."""

    def __init__(self, obs: Observations, frames: int) -> None:
        self.obs = obs
        self.frames = frames
        self.masks = [[v.masks[k].reshape(v.camera.height, v.camera.width).astype(bool) for v in obs.views]
                      for k in range(frames + 1)]
        self.outside = [[_outside_distance(m) for m in row] for row in self.masks]

    def distances(self, positions: Sequence[np.ndarray], spacing: float) -> np.ndarray:
        """Symmetric mean boundary distance (px) of every frame 1 .. frames and view: (frames, views). Half the
        mean distance of the simulated silhouette's pixels to the mask plus half that of the mask's pixels to the
        silhouette."""
        out = np.empty((self.frames, len(self.obs.views)))
        for k in range(1, self.frames + 1):
            for i, view in enumerate(self.obs.views):
                simulated = coverage(view.camera, positions[k], spacing) >= 0.5
                mask, outside = self.masks[k][i], self.outside[k][i]
                to_mask = outside[simulated].mean() if simulated.any() else outside.max()
                to_simulated = _outside_distance(simulated)[mask].mean() if mask.any() else 0.0
                out[k - 1, i] = 0.5 * (to_mask + to_simulated)
        return out

    def residuals(self, positions: Sequence[np.ndarray], spacing: float) -> list[np.ndarray]:
        """Covered fraction minus mask on the focus pixels, one array per image (frame 1 .. frames, view)."""
        return [coverage(view.camera, positions[k], spacing).ravel()[view.focus] - view.masks[k][view.focus]
                for k in range(1, self.frames + 1) for view in self.obs.views]


class EvaluationLog:
    """Objective values stored by phase and point, in ``path`` under ``key`` (the fit's inputs and settings): a
    stored point is not evaluated again, so a resumed search replays the stored values up to where it stopped."""

    def __init__(self, path: str | Path, key: str) -> None:
        self.path, self.key = Path(path), key
        self.records: list[dict] = []
        if self.path.is_file():
            stored = json.loads(self.path.read_text())
            if stored.get("key") == key:
                self.records = stored["records"]
                logger.info("replaying %d stored evaluations from %s", len(self.records), self.path)
        self._index = {self._point_key(r["phase"], r["x"]): r for r in self.records}

    @staticmethod
    def _point_key(phase: str, x) -> str:
        return phase + ":" + ",".join(f"{v:.12g}" for v in x)

    def evaluate(self, objective: Callable[[np.ndarray], float], x: np.ndarray, phase: str) -> float:
        record = self._index.get(self._point_key(phase, x))
        if record is None:
            record = {"phase": phase, "x": [float(v) for v in x], "loss": float(objective(x))}
            self.records.append(record)
            self._index[self._point_key(phase, x)] = record
            write_atomic(self.path, lambda p: p.write_text(json.dumps({"key": self.key, "records": self.records})))
        return record["loss"]


def survey(evaluate: Callable[[np.ndarray, str], float], centre: np.ndarray, half_width: float, samples: int,
           seed: int = 0, progress: Callable[[], None] | None = None) -> tuple[np.ndarray, float]:
    """The best of ``samples`` scrambled-Sobol points in the box centre +- half_width (log units); the centre is the
    first point."""
    count = max(samples - 1, 0)
    unit = qmc.Sobol(len(centre), seed=seed).random_base2(max(int(np.ceil(np.log2(max(count, 1)))), 0))[:count]
    points = np.r_[centre[None, :], centre + (2.0 * unit - 1.0) * half_width]
    values = []
    for x in points:
        values.append(evaluate(x, "survey"))
        if progress:
            progress()
    best = int(np.argmin(values))
    return points[best], values[best]


def simplex_search(evaluate: Callable[[np.ndarray, str], float], start: np.ndarray, step: float, evaluations: int,
                   phase: str, tolerance: float = 0.01) -> tuple[np.ndarray, float]:
    """Nelder-Mead from ``start`` with an initial simplex of ``step`` (log units) along each axis, for at most
    ``evaluations`` evaluations or until the simplex is within ``tolerance`` (log units)."""
    simplex = start + np.r_[np.zeros((1, len(start))), step * np.eye(len(start))]
    result = minimize(lambda x: evaluate(x, phase), start, method="Nelder-Mead",
                      options={"initial_simplex": simplex, "maxfev": evaluations, "xatol": tolerance,
                               "fatol": 1e-9})
    return result.x, float(result.fun)


def parabola_region(offsets: np.ndarray, values: np.ndarray, threshold: float) -> tuple[float, float] | None:
    """The range of offsets where the parabola fitted to (offsets, values) stays below ``threshold``; None where it
    does not curve upwards (the loss does not bound the parameter)."""
    a, b, c = np.polynomial.polynomial.polyfit(offsets, values, 2)
    if c <= 0:
        return None
    vertex = -b / (2 * c)
    half = np.sqrt(max(threshold - (a + b * vertex + c * vertex**2), 0.0) / c)
    return vertex - half, vertex + half


Evaluate = Callable[[np.ndarray, str], float]


@dataclass
class Estimate:
    """A fit's result: log-parameters, loss, 95 % intervals, the parameters held at their initial guess because the
    recording does not determine them, and the evidence behind the intervals."""

    log_values: np.ndarray
    loss: float
    intervals: dict[str, Interval]
    held: list[str] = field(default_factory=list)
    evidence: dict = field(default_factory=dict)


def identify(evaluate: Evaluate, centre: np.ndarray, free: Sequence[int], names: Sequence[str], step: float,
             tolerance: float, box: tuple[np.ndarray, np.ndarray], phase: str = "profile"
             ) -> tuple[np.ndarray, float, dict[str, Interval], dict]:
    """Intervals of the ``free`` parameters from profiles of the loss along each of them (the others at
    ``centre``; offsets -2, -1, 1, 2 times ``step`` in log units): the range where a parabola through the profile
    stays within ``tolerance`` (relative) of the lowest loss seen, clipped to ``box`` (the whole box where the
    profile does not curve upwards). A parabola over a wide step smooths the roughness pixel edges give the loss,
    which would make a local Hessian meaningless. Returns the best point seen, its loss, the intervals and the
    evidence."""
    offsets = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) * step
    centre_loss = evaluate(centre, phase)
    profiles = {}
    for i in free:
        values = []
        for d in offsets:
            point = centre.copy()
            point[i] += d
            values.append(centre_loss if d == 0 else evaluate(point, phase))
        profiles[i] = np.array(values)
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
        if span is None:
            unbounded.append(names[i])
        low, high = (box[0][i], box[1][i]) if span is None else (centre[i] + span[0], centre[i] + span[1])
        low, high = min(max(low, box[0][i]), x[i]), max(min(high, box[1][i]), x[i])
        intervals[names[i]] = Interval(float(np.exp(x[i])), float(np.exp(low)), float(np.exp(high)),
                                       float((high - low) / (2 * Z95)))
    evidence = {"loss": loss, "threshold": threshold, "profile_offsets_log": offsets.tolist(),
                "profiles": {names[i]: v.tolist() for i, v in profiles.items()}, "unbounded": unbounded}
    return x, loss, intervals, evidence


def estimate(evaluate: Evaluate, start: np.ndarray, guess: np.ndarray, names: Sequence[str], *, evaluations: int,
             step: float, profile_step: float, tolerance: float, box: tuple[np.ndarray, np.ndarray]) -> Estimate:
    """Nelder-Mead from ``start`` on every frame, then intervals from profiles of the loss. Parameters the recording
    does not determine (interval wider than a factor 4) and whose initial guess lies inside their interval are held
    at the guess, the others fitted again with them held: a flat direction would otherwise leave them wherever the
    search's noise took them. (A stiff material's moduli, say, are undetermined above some value but matter below
    it: a guess below stays unused.)"""
    everything = list(range(len(start)))
    x, _ = simplex_search(evaluate, start, step, evaluations, "full")
    x, loss, intervals, evidence = identify(evaluate, x, everything, names, profile_step, tolerance, box)
    # an undetermined parameter goes back to its guess where the guess is as good as any value (inside the interval)
    held = [i for i in everything if not intervals[names[i]].determined
            and intervals[names[i]].low <= np.exp(guess[i]) <= intervals[names[i]].high]
    result = Estimate(x, loss, intervals, [names[i] for i in held], {"all_free": evidence})
    free = [i for i in everything if i not in held]
    if not held or not free:
        return result
    fixed = x.copy()
    fixed[held] = guess[held]

    def partial(y: np.ndarray, phase: str) -> float:
        z = fixed.copy()
        z[free] = y
        return evaluate(z, phase)

    y, _ = simplex_search(partial, fixed[free], step, max(evaluations // 2, 1), "held")
    fixed[free] = y
    x, loss, free_intervals, evidence = identify(evaluate, fixed, free, names, profile_step, tolerance, box,
                                                 phase="profile, held")
    for i in held:
        joint = intervals[names[i]]
        value = float(np.exp(guess[i]))
        intervals[names[i]] = Interval(value, min(joint.low, value), max(joint.high, value), joint.sigma_log)
    intervals.update(free_intervals)
    result.log_values, result.loss, result.intervals = x, loss, intervals
    result.evidence["held_at_guess"] = evidence
    return result
