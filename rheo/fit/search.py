"""Fitting the material on whole-frame silhouettes, without gradients.

The loss is the mean symmetric boundary distance (pixels) between the simulated particles' silhouettes and the masks,
over every view and frame: deterministic (every pixel, no random rays) and informative even far from the optimum,
where overlap losses are flat. Its minimiser is searched in three steps: a quasi-random survey of a wide box of
log-parameters, short Nelder-Mead searches from the survey's best few points (two materials may fit nearly equally
well in different basins, and the survey's best need not lie in the better one), then the surface of the loss around
the best point found (``rheo.fit.surface``), whose region within the tolerance gives the intervals. The estimate is
the lowest loss evaluated, the surface's lowest point included (docs/settings.md, "Constants in the code"). Gradient
descent on the rendering loss stalled in the curved, nearly flat valley between soft-and-strong and stiff-and-weak
materials; the survey finds the right valley, and neither the simplex nor the surface needs a gradient of a loss that
pixel edges make rough.

Every evaluation is stored (in a JSON file written atomically after each one), so an interrupted search replays the
stored values and goes on from where it stopped.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import logging
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from rheo.fit.observations import Observations
from rheo.fit.surface import describe_surface, refine
from rheo.fit.uncertainty import Evaluate, Interval, Tolerated, parameter_interval, tolerance_level, tolerated
from rheo.io import write_atomic
from rheo.render.silhouette import boundary_distance, distance_to, silhouette

logger = logging.getLogger(__name__)
# the surface stops moving where it promises a loss lower by less than this fraction of the tolerance: a valley flat
# at that scale cannot place the estimate along it, and walking on would follow the loss's roughness
FLAT = 0.25
# each interval end is walked outward along the surface's valley floor, a design half-width a step, at most this many
# steps
END_STEPS = 8
# then a closed end is placed to within 1 / 2**END_HALVINGS of a step by bisection
END_HALVINGS = 2
# a line search doubles its step at most this often
LINE_EXPANSIONS = 5


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
        self.runs: list[dict] = []  # each run's start (UTC), the evaluations it added and its seconds; this one last
        self._started = time.monotonic()
        if self.path.is_file():
            stored = json.loads(self.path.read_text())
            if stored.get("key") == key:
                self.records = stored["records"]
                self.earlier_seconds = stored.get("runtime_s", stored.get("seconds", 0.0))  # older stores: "seconds"
                self.runs = stored.get("runs", [])
                unlisted = len(self.records) - sum(r["evaluations"] for r in self.runs)
                if unlisted > 0:  # stored before the store kept its runs: one entry of unrecorded start
                    self.runs.insert(0, {"started": None, "evaluations": unlisted,
                                         "seconds": self.earlier_seconds - sum(r["seconds"] for r in self.runs)})
                logger.info("replaying %d stored evaluations from %s%s", len(self.records), self.path,
                            "".join(f"; run of {r['started'] or 'unrecorded start'}: {r['evaluations']} in "
                                    f"{r['seconds'] / 60:.0f} min" for r in self.runs))
        self.runs.append({"started": datetime.now(UTC).isoformat(timespec="seconds"), "evaluations": 0,
                          "seconds": 0.0})
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
                self.runs[-1]["evaluations"] += len(todo)
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

    def times(self) -> dict:
        """The seconds all runs spent (the interrupted ones up to their last stored evaluation) and each run's
        start, evaluations added and seconds, this one up to now."""
        self.runs[-1]["seconds"] = time.monotonic() - self._started
        return {"runtime_s": self.earlier_seconds + self.runs[-1]["seconds"], "runs": self.runs}

    def _write(self) -> None:
        stored = {"key": self.key, "records": self.records, **self.times()}
        write_atomic(self.path, lambda p: p.write_text(json.dumps(stored)))


def survey_points(centre: np.ndarray, half_width: float | np.ndarray, samples: int, seed: int = 0) -> np.ndarray:
    """``samples`` scrambled-Sobol points in the box centre +- half_width (log units), the centre first."""
    from scipy.stats import qmc  # here: slow to import, and most stages survey nothing

    count = max(samples - 1, 0)
    unit = qmc.Sobol(len(centre), seed=seed).random_base2(max(int(np.ceil(np.log2(max(count, 1)))), 0))[:count]
    return np.r_[centre[None, :], centre + (2.0 * unit - 1.0) * half_width]


def start_step(width: float, samples: int, dimensions: int) -> float:
    """A quarter of the spacing of ``samples`` survey points along each axis of a box ``width`` wide: the initial
    simplex of a search from one of them."""
    return 0.25 * width / samples ** (1.0 / dimensions)


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


def line_search(loss: Callable[[np.ndarray], float], z: np.ndarray, axis: int, step: float,
                expansions: int = LINE_EXPANSIONS) -> np.ndarray:
    """The lowest point found along coordinate ``axis`` from ``z``: a ``step`` either way, then, in the direction
    that fitted better, steps doubling while the ``loss`` falls (at most ``expansions`` of them), then the lowest
    point of the parabola through the best point and its neighbours either side."""
    along: dict[float, float] = {}

    def probe(t: float) -> float:
        along[t] = loss(np.r_[z[:axis], z[axis] + t, z[axis + 1:]])
        return along[t]

    best, move = 0.0, step
    probe(best)
    sign = -1.0 if probe(-step) < probe(step) else 1.0
    doublings = 0
    while along[best + sign * move] < along[best]:
        best += sign * move
        if doublings == expansions:
            return np.r_[z[:axis], z[axis] + best, z[axis + 1:]]
        move, doublings = 2.0 * move, doublings + 1
        probe(best + sign * move)
    left, right = max(t for t in along if t < best), min(t for t in along if t > best)
    rise_left, rise_right = along[left] - along[best], along[right] - along[best]
    curvature = (best - left) * rise_right + (right - best) * rise_left
    if curvature > 0.0:  # not flat where the loss ignores the coordinate
        vertex = best + 0.5 * ((right - best) ** 2 * rise_left - (best - left) ** 2 * rise_right) / curvature
        if probe(vertex) < along[best]:
            best = vertex
    return np.r_[z[:axis], z[axis] + best, z[axis + 1:]]


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


@dataclass
class Estimate:
    """A fit's result: log-parameters, loss, tolerance intervals, the parameters held at their initial guess because the
    recordings do not determine them, the evaluated materials within the tolerance of the best (of the search with
    every parameter free) and the evidence behind the intervals."""

    log_values: np.ndarray
    loss: float
    intervals: dict[str, Interval]
    within_tolerance: Tolerated
    held: list[str] = field(default_factory=list)
    evidence: dict = field(default_factory=dict)


EvaluateMany = Callable[[list[np.ndarray], str], list[float]]  # losses of points (log-parameters) in a named phase


def estimate(evaluate_many: EvaluateMany, starts: Sequence[np.ndarray], names: Sequence[str], *,
             seen: Callable[[], tuple[np.ndarray, np.ndarray]], evaluations: int, start_step: float,
             half_width: float, rounds: int, tolerance: float, box: tuple[np.ndarray, np.ndarray],
             guess: np.ndarray | None = None, side_by_side: bool = False,
             evaluate_estimate: Callable[[np.ndarray], float] | None = None) -> Estimate:
    """Nelder-Mead from each of ``starts`` (``evaluations`` shared among them, inside ``box``; none without
    evaluations: the first start is the best), then the surface of the loss around the best point found
    (``rheo.fit.surface.refine``): its lowest point, or the best evaluated where that is lower, is the estimate, and
    its region within the tolerance gives the intervals, grown to the evaluated materials within it. ``seen()`` gives
    every point evaluated so far and its loss (``EvaluationLog.seen``);
    ``evaluate_estimate`` evaluates the estimate (by default as phase "estimate").

    With a ``guess``, parameters the recordings do not determine and whose guess lies inside their interval (or
    beyond an open end) are held at the guess and the others searched again (a simplex, then their surface), unless
    that loses more than the tolerance: a flat direction would otherwise leave them wherever the roughness of the
    loss took them.
    (A stiff material's moduli, say, are undetermined above some value but matter below it: a guess below stays
    unused.)"""
    evaluate_estimate = evaluate_estimate or (lambda x: evaluate_many([x], "estimate")[0])
    if evaluations > 0:
        x, _ = start_searches(lambda x, phase: evaluate_many([x], phase)[0], starts, start_step,
                              evaluations // len(starts), box, side_by_side)
    else:
        x = np.asarray(starts[0], dtype=float)
    everything = list(range(len(x)))
    x, loss, intervals, evidence = surface_estimate(evaluate_many, x, everything, names, seen, half_width, rounds,
                                                    tolerance, box, evaluate_estimate, "surface")
    result = Estimate(x, loss, intervals, tolerated(*seen(), tolerance), evidence={"all_free": evidence})
    held = [] if guess is None else [i for i in everything if _inside(intervals[names[i]], float(np.exp(guess[i])))]
    free = [i for i in everything if i not in held]
    if not held or not free:
        return result
    fixed = x.copy()
    fixed[held] = guess[held]
    # the valley of the others moves with the held values: a simplex search finds its floor before the surface
    if evaluations > 0:
        fixed[free], _ = simplex_search(lambda y, phase: evaluate_many([_embed(fixed, free, y)], phase)[0],
                                        fixed[free], start_step, evaluations // len(starts), "start, held",
                                        box=(box[0][free], box[1][free]))
    y, held_loss, free_intervals, evidence = surface_estimate(evaluate_many, fixed, free, names, seen, half_width,
                                                              rounds, tolerance, box, evaluate_estimate,
                                                              "surface, held")
    result.evidence["held_at_guess"] = evidence
    if held_loss > tolerance_level(loss, tolerance):
        logger.warning("with %s at the initial guess the loss is %.5g, more than the tolerance above %.5g: nothing "
                       "is held", ", ".join(names[i] for i in held), held_loss, loss)
        return result
    x, loss = y, held_loss
    for i in held:
        joint = intervals[names[i]]
        value = float(np.exp(guess[i]))
        intervals[names[i]] = dataclasses.replace(joint, value=value, low=min(joint.low, value),
                                                  high=max(joint.high, value))
    intervals.update(free_intervals)
    result.log_values, result.loss, result.intervals = x, loss, intervals
    result.held = [names[i] for i in held]
    return result


def _embed(centre: np.ndarray, free: Sequence[int], y: np.ndarray) -> np.ndarray:
    """``centre`` with its ``free`` coordinates set to ``y``."""
    z = centre.copy()
    z[list(free)] = y
    return z


def _inside(interval: Interval, value: float) -> bool:
    """Whether an undetermined parameter's ``value`` lies in its interval, or beyond an open end (the region within
    the tolerance goes on past it)."""
    return not interval.determined and ((interval.low <= value or interval.open[0])
                                        and (value <= interval.high or interval.open[1]))


def walk_ends(evaluate_many: Callable[[list[np.ndarray]], list[float]], estimate: np.ndarray, extents: np.ndarray,
              open_ends: np.ndarray, box: tuple[np.ndarray, np.ndarray], step: float, level: float,
              directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The intervals' ends (coordinates, 2) checked on the loss itself: from each, along its line through the
    ``estimate`` (row i of ``directions``, scaled to move coordinate i: the surface's valley floor, where the other
    parameters trade against it), a point ``step`` further out is evaluated, and the next while the loss stays
    within ``level`` (``END_STEPS`` at most, not past ``box``); an end moves to the farthest point within the
    level, open where the walk ran out of steps or reached the box. A closed end is then placed
    between its last point within the level (the estimate, where the end sat at the box and the box is beyond) and
    the first beyond by ``END_HALVINGS`` bisections. A quadratic surface
    misjudges a valley that flattens on one side (a viscosity too low to show): its ends fall short where the loss
    itself stays low. Along the axis, with the others held at the estimate, a walk would leave the valley of a
    trade-off (the cup's shear modulus against lambda) at once."""
    extents, open_ends = extents.copy(), open_ends.copy()
    beyond = np.full(extents.shape, np.nan)  # the first point out along each closed end's line past the level

    def probe_all(ends: list[tuple[int, int]], coordinates: list[float]) -> list[bool]:
        probes = [np.clip(estimate + (value - estimate[i]) * directions[i], *box)
                  for (i, _), value in zip(ends, coordinates, strict=True)]
        return [loss <= level for loss in (evaluate_many(probes) if probes else [])]

    walking = [(i, side) for i in range(len(estimate)) for side in (0, 1)]
    for done in range(END_STEPS):
        coordinates = [float(np.clip(extents[i, side] + (step if side else -step), box[0][i], box[1][i]))
                       for i, side in walking]
        still = []
        for (i, side), value, within in zip(walking, coordinates, probe_all(walking, coordinates), strict=True):
            open_ends[i, side] = within and (done == END_STEPS - 1 or value in (box[0][i], box[1][i]))
            if within:
                extents[i, side] = value
                if not open_ends[i, side]:
                    still.append((i, side))
            else:
                if value == extents[i, side]:  # the end was at the box and lies beyond: bisect from the estimate
                    extents[i, side] = estimate[i]
                beyond[i, side] = value
        walking = still
    closed = [(i, side) for i, side in zip(*np.nonzero(~np.isnan(beyond)), strict=True)]
    for _ in range(END_HALVINGS):
        middles = [0.5 * (extents[i, side] + beyond[i, side]) for i, side in closed]
        for (i, side), value, within in zip(closed, middles, probe_all(closed, middles), strict=True):
            if within:
                extents[i, side] = value
            else:
                beyond[i, side] = value
    return extents, open_ends


def surface_estimate(evaluate_many: EvaluateMany, centre: np.ndarray, free: Sequence[int], names: Sequence[str],
                     seen: Callable[[], tuple[np.ndarray, np.ndarray]], half_width: float, rounds: int,
                     tolerance: float, box: tuple[np.ndarray, np.ndarray],
                     evaluate_estimate: Callable[[np.ndarray], float], phase: str
                     ) -> tuple[np.ndarray, float, dict[str, Interval], dict]:
    """The surface of the loss along the ``free`` coordinates (the others held at ``centre``'s), fitted to the points
    evaluated with the others held there: the estimate, its loss, the free parameters' intervals and the evidence
    (the surface, its rounds, open ends)."""
    free = list(free)
    held = [i for i in range(len(centre)) if i not in free]

    embed = functools.partial(_embed, centre, free)

    def seen_here() -> tuple[np.ndarray, np.ndarray]:
        points, losses = seen()
        if not len(points):
            return points, losses
        here = np.all(points[:, held] == centre[held], axis=1)
        return points[here][:, free], losses[here]

    inner = (box[0][free], box[1][free])
    refinement = refine(lambda points: evaluate_many([embed(y) for y in points], phase), centre[free], half_width,
                        inner, seen_here, rounds, flat=FLAT * tolerance)
    if refinement.flat:
        logger.info("the surface promises less than %.2g %% from a further move: the valley is flat there",
                    100 * FLAT * tolerance)
    elif not refinement.converged:
        logger.warning("the surface's lowest point still moved after %d rounds: the estimate is the lowest point "
                       "within the last design", refinement.rounds)

    def lowest(y: np.ndarray, loss: float, found_by: str) -> tuple[np.ndarray, float]:
        """``y`` and its ``loss``, or the material evaluated here that loses less (the loss is rough: the estimate is
        the material that reproduces the recording best)."""
        points, losses = seen_here()
        best = int(np.argmin(losses))
        if losses[best] >= loss:
            return y, loss
        logger.info("%s found a material losing %.5g, less than the estimate's %.5g: that is the estimate", found_by,
                    losses[best], loss)
        return points[best], float(losses[best])

    y, loss = lowest(refinement.x, evaluate_estimate(embed(refinement.x)), "the searches and designs")
    extents, open_ends = refinement.surface.extents(tolerance, refinement.reach, y)
    extents = np.column_stack([np.clip(extents[:, 0], inner[0], y), np.clip(extents[:, 1], y, inner[1])])
    extents, open_ends = walk_ends(lambda ys: evaluate_many([embed(v) for v in ys], phase), y, extents, open_ends,
                                   inner, refinement.half_width, tolerance_level(loss, tolerance),
                                   refinement.surface.valley_floor())
    # the walk may go on down the valley
    y, loss = lowest(y, loss, "walking the interval ends")
    points, losses = seen_here()
    free_names = [names[i] for i in free]
    if open_ends.any():
        logger.warning("the region within the tolerance goes on past the evaluations at %s: those ends of the "
                       "intervals are lower bounds", ", ".join(
                           f"{n}'s {side}" for n, ends in zip(free_names, open_ends, strict=True)
                           for side, end in zip(("low", "high"), ends, strict=True) if end))
    intervals = {n: parameter_interval(n, float(np.exp(v)), float(np.exp(lo)), float(np.exp(hi)), tuple(ends.tolist()))
                 for n, v, (lo, hi), ends in zip(free_names, y, extents, open_ends, strict=True)}
    intervals = tolerated(points, losses, tolerance).widen(intervals, free_names, inner)
    evidence = describe_surface(refinement.surface, free_names) | {
        "half_width_log": refinement.half_width, "rounds": refinement.rounds, "converged": refinement.converged,
        "flat": refinement.flat,
        "reach_log": refinement.reach, "open_ends": {n: list(ends) for n, ends in zip(free_names, open_ends.tolist(),
                                                                                      strict=True)}}
    return embed(y), loss, intervals, evidence
