"""Fitting the material on whole-frame silhouettes, without gradients.

The loss is the mean symmetric boundary distance (pixels) between the simulated particles' silhouettes and the masks,
over every view and frame: deterministic (every pixel, no random rays) and informative even far from the optimum,
where overlap losses are flat. Its minimiser is searched in two steps: a quasi-random survey of a wide box of
log-parameters around the initial guess, then short Nelder-Mead searches from the survey's best few points (two
materials may fit nearly equally well in different basins, and the survey's best need not lie in the better one),
continued from the best of them. Gradient descent on
the rendering loss stalled in the curved, nearly flat valley between soft-and-strong and stiff-and-weak materials;
the survey finds the right valley and the simplex needs no gradient of a loss that pixel edges make rough.

Every evaluation is stored (in a JSON file written atomically after each one), so an interrupted search replays the
stored values and goes on from where it stopped.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc

from rheo.fit.observations import Observations
from rheo.fit.uncertainty import Evaluate, Interval, profile_intervals
from rheo.io import write_atomic
from rheo.render.silhouette import boundary_distance, distance_to, silhouette

logger = logging.getLogger(__name__)


class SilhouetteTarget:
    """The masks of frames 0 .. ``frames`` of every view, with their distance maps."""

    def __init__(self, obs: Observations, frames: int) -> None:
        self.obs = obs
        self.frames = frames
        self.masks = [[v.masks[k].reshape(v.camera.height, v.camera.width).astype(bool) for v in obs.views]
                      for k in range(frames + 1)]
        self.outside = [[distance_to(m) for m in row] for row in self.masks]

    def distances(self, positions: Sequence[np.ndarray], spacing: float) -> np.ndarray:
        """Symmetric mean boundary distance (px, ``boundary_distance``) of every frame 1 .. frames and view:
        (frames, views)."""
        out = np.empty((self.frames, len(self.obs.views)))
        for k in range(1, self.frames + 1):
            for i, view in enumerate(self.obs.views):
                out[k - 1, i] = boundary_distance(silhouette(view.camera, positions[k], spacing), self.masks[k][i],
                                                  self.outside[k][i])
        return out


class EvaluationLog:
    """Objective values stored by phase and point, in ``path`` under ``key`` (the fit's inputs and settings): a
    stored point is not evaluated again, so a resumed search replays the stored values up to where it stopped.
    With ``one_objective`` every phase evaluates the same objective, and a point stored by one phase serves the
    others (a search starting from a survey's point, a profile through the search's best)."""

    def __init__(self, path: str | Path, key: str, one_objective: bool = False) -> None:
        self.path, self.key, self.one_objective = Path(path), key, one_objective
        self.records: list[dict] = []
        self.earlier_seconds = 0.0  # the time the interrupted runs spent up to their last stored evaluation
        self._started = time.monotonic()
        if self.path.is_file():
            stored = json.loads(self.path.read_text())
            if stored.get("key") == key:
                self.records = stored["records"]
                self.earlier_seconds = stored.get("seconds", 0.0)
                logger.info("replaying %d stored evaluations from %s", len(self.records), self.path)
        self._index: dict[str, dict] = {}
        for record in self.records:
            self._index.setdefault(self._point_key(record["phase"], record["x"]), record)
        # the records this run has asked for, stored or new: what a resumed search has seen at the same step
        self.requested: list[dict] = []
        self._requested_ids: set[int] = set()
        self._lock = threading.Lock()  # searches running side by side share the log

    def _point_key(self, phase: str, x) -> str:
        return ("" if self.one_objective else phase) + ":" + ",".join(f"{v:.12g}" for v in x)

    def evaluate(self, objective: Callable[[np.ndarray], float], x: np.ndarray, phase: str) -> float:
        return self.evaluate_many(lambda points: [objective(p) for p in points], [x], phase)[0]

    def evaluate_many(self, objective: Callable[[list[np.ndarray]], list[float | dict]],
                      points: Sequence[np.ndarray], phase: str) -> list[float]:
        """Losses of ``points``, those not stored evaluated together by ``objective`` (on several processes, say).
        An objective may return a dict of JSON-ready details with the loss under "loss"; they are stored with it."""
        with self._lock:
            todo = [x for x in points if self._point_key(phase, x) not in self._index]
        if todo:
            values = objective(todo)
            with self._lock:
                for x, value in zip(todo, values, strict=True):
                    details = value if isinstance(value, dict) else {"loss": value}
                    record = {"phase": phase, "x": [float(v) for v in x], **details,
                              "loss": float(details["loss"])}
                    self.records.append(record)
                    self._index[self._point_key(phase, x)] = record
                self._write()
        with self._lock:
            found = [self._index[self._point_key(phase, x)] for x in points]
            for record in found:
                if id(record) not in self._requested_ids:
                    self._requested_ids.add(id(record))
                    self.requested.append(record)
            return [record["loss"] for record in found]

    def seen(self) -> tuple[np.ndarray, np.ndarray]:
        """The points this run has asked for so far (a resumed run: those replayed up to here) and their losses: what
        a search that goes on from them may use, the same in the interrupted run and the resumed one."""
        with self._lock:
            return (np.array([r["x"] for r in self.requested]), np.array([r["loss"] for r in self.requested]))

    def record(self, phase: str, x) -> dict:
        """The stored record of a point evaluated in ``phase``."""
        with self._lock:
            return self._index[self._point_key(phase, x)]

    def best(self, phase: str) -> dict:
        """The stored record of the lowest loss evaluated in ``phase`` (a search stopped by its budget may have
        evaluated a better point than the simplex it returns)."""
        with self._lock:
            return min((r for r in self.records if r["phase"] == phase), key=lambda r: r["loss"])

    def _write(self) -> None:
        seconds = self.earlier_seconds + time.monotonic() - self._started
        write_atomic(self.path, lambda p: p.write_text(json.dumps({"key": self.key, "records": self.records,
                                                                  "seconds": seconds})))


def survey_points(centre: np.ndarray, half_width: float | np.ndarray, samples: int, seed: int = 0) -> np.ndarray:
    """``samples`` scrambled-Sobol points in the box centre +- half_width (log units), the centre first."""
    count = max(samples - 1, 0)
    unit = qmc.Sobol(len(centre), seed=seed).random_base2(max(int(np.ceil(np.log2(max(count, 1)))), 0))[:count]
    return np.r_[centre[None, :], centre + (2.0 * unit - 1.0) * half_width]


def start_step(width: float, samples: int, dimensions: int) -> float:
    """A quarter of the spacing of ``samples`` survey points along each axis of a box ``width`` wide: the initial
    simplex of a search from one of them."""
    return 0.25 * width / samples ** (1.0 / dimensions)


def survey(evaluate: Evaluate, centre: np.ndarray, half_width: float | np.ndarray, samples: int,
           seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The ``survey_points`` and their losses, both ordered from the lowest loss."""
    points = survey_points(centre, half_width, samples, seed)
    values = np.array([evaluate(x, "survey") for x in points])
    order = np.argsort(values, kind="stable")
    return points[order], values[order]


def simplex_search(evaluate: Evaluate, start: np.ndarray, step: float | np.ndarray, evaluations: int,
                   phase: str, tolerance: float = 0.01,
                   box: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, float]:
    """Nelder-Mead from ``start`` with an initial simplex of ``step`` (log units) along each axis, for at most
    ``evaluations`` evaluations or until the simplex is within ``tolerance`` (log units), inside ``box`` if given."""
    simplex = start + np.r_[np.zeros((1, len(start))), step * np.eye(len(start))]
    bounds = None if box is None else list(zip(box[0], box[1], strict=True))
    if bounds is not None:
        simplex = np.clip(simplex, box[0], box[1])
    result = minimize(lambda x: evaluate(x, phase), start, method="Nelder-Mead", bounds=bounds,
                      options={"initial_simplex": simplex, "maxfev": evaluations, "xatol": tolerance,
                               "fatol": 1e-9})
    return result.x, float(result.fun)


def start_searches(evaluate: Evaluate, starts: Sequence[np.ndarray], step: float, evaluations: int,
                   box: tuple[np.ndarray, np.ndarray] | None = None,
                   side_by_side: bool = False) -> tuple[np.ndarray, float]:
    """Nelder-Mead from each of ``starts`` (initial simplex ``step``, ``evaluations`` each, phases "start 1",
    "start 2", ...); the best point found and its loss. ``side_by_side``: the searches run in threads at the same
    time (for an ``evaluate`` that hands its work to other processes and is thread-safe); the result is that of
    running them one after another."""

    def search(k: int) -> tuple[np.ndarray, float]:
        return simplex_search(evaluate, starts[k], step, evaluations, f"start {k + 1}", box=box)

    if side_by_side:
        with ThreadPoolExecutor(len(starts)) as threads:
            found = list(threads.map(search, range(len(starts))))
    else:
        found = [search(k) for k in range(len(starts))]
    best = min(range(len(found)), key=lambda k: found[k][1])
    logger.info("best of %d starts: start %d, loss %.5g", len(starts), best + 1, found[best][1])
    return found[best]


def multistart_search(evaluate: Evaluate, starts: Sequence[np.ndarray], start_step: float, step: float,
                      evaluations: int, box: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, float]:
    """Nelder-Mead from each of ``starts`` (initial simplex ``start_step``) with half of ``evaluations`` shared among
    them, then from the best point found with a fresh simplex of ``step`` and the remaining evaluations."""
    if len(starts) == 1:
        return simplex_search(evaluate, starts[0], step, evaluations, "full", box=box)
    each = evaluations // (2 * len(starts))
    x, _ = start_searches(evaluate, starts, start_step, each, box)
    return simplex_search(evaluate, x, step, evaluations - each * len(starts), "full", box=box)


@dataclass
class Estimate:
    """A fit's result: log-parameters, loss, 95 % intervals, the parameters held at their initial guess because the
    recording does not determine them, and the evidence behind the intervals."""

    log_values: np.ndarray
    loss: float
    intervals: dict[str, Interval]
    held: list[str] = field(default_factory=list)
    evidence: dict = field(default_factory=dict)


def estimate(evaluate: Evaluate, starts: Sequence[np.ndarray], guess: np.ndarray, names: Sequence[str], *,
             evaluations: int, start_step: float, step: float, profile_step: float, tolerance: float,
             box: tuple[np.ndarray, np.ndarray]) -> Estimate:
    """Nelder-Mead from ``starts`` (``multistart_search``, inside the survey's ``box``), then intervals from profiles
    of the loss. Parameters the recording
    does not determine (interval wider than a factor 4) and whose initial guess lies inside their interval are held
    at the guess, the others fitted again with them held: a flat direction would otherwise leave them wherever the
    search's noise took them. (A stiff material's moduli, say, are undetermined above some value but matter below
    it: a guess below stays unused.)"""
    everything = list(range(len(guess)))
    x, _ = multistart_search(evaluate, starts, start_step, step, evaluations, box)
    x, loss, intervals, evidence = profile_intervals(evaluate, x, everything, names, profile_step, tolerance, box)
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

    y, _ = simplex_search(partial, fixed[free], step, max(evaluations // 2, 1), "held",
                          box=(box[0][free], box[1][free]))
    fixed[free] = y
    x, loss, free_intervals, evidence = profile_intervals(evaluate, fixed, free, names, profile_step, tolerance, box,
                                                 phase="profile, held")
    for i in held:
        joint = intervals[names[i]]
        value = float(np.exp(guess[i]))
        intervals[names[i]] = Interval(value, min(joint.low, value), max(joint.high, value))
    intervals.update(free_intervals)
    result.log_values, result.loss, result.intervals = x, loss, intervals
    result.evidence["held_at_guess"] = evidence
    return result
