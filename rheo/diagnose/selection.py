"""Which candidate effect the recording asks for: each effect added and refitted along its profile, compared by an
information criterion so that a free parameter does not win by default.

A fit's per-frame boundary distances over the fitted frames (of every setup) are taken as Gaussian residuals of one
unknown scale; its Bayesian information criterion is then N log(SSE / N) + k log N (N frames, k fitted parameters). An
effect is named when its refit lowers the criterion below the base model's by more than ``diagnose.evidence`` (by
default 6: strong evidence on Kass and Raftery's scale), and the lowest criterion wins unless it is a decoy's;
otherwise nothing is named. The winner must also beat the base model refitted from the winner's own law.
The frames held out of every fit judge the choice afterwards. (The residual of a base fit is not noise but the
simulation's own error, which any extra freedom absorbs in part: at 2, positive evidence, a concealed case with no
effect named wall adhesion at -2.1.)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from rheo.diagnose.candidates import CANDIDATES, Candidate
from rheo.fit.dam_break import from_stress_split, stress_split
from rheo.fit.search import line_search, simplex_search

T = TypeVar("T")


def information_criterion(distances: np.ndarray, parameters: int) -> float:
    """N log(SSE / N) + k log N of per-frame distances (px)."""
    count = len(distances)
    sse = max(float(np.sum(np.square(distances))), 1e-300)
    return count * math.log(sse / count) + parameters * math.log(count)


@dataclass
class Refit:
    """The best point a (re)fit found, its loss (px) on the fitted frames, on those held out between them and on the
    last ones held out as a prediction, the per-frame distances of the fitted frames, and how many parameters it
    fitted."""

    name: str
    x: np.ndarray
    loss: float
    held_out_loss: float
    distances: np.ndarray
    parameters: int
    profile: tuple[tuple[float, float], ...] = ()  # (effect's magnitude, lowest loss there) along a profile
    forecast_loss: float = math.nan

    @classmethod
    def of(cls, name: str, record: dict) -> Refit:
        """From an evaluation's stored record (its point, losses and distances)."""
        forecast = record.get("forecast_loss")
        return cls(name, np.asarray(record["x"]), record["loss"], record["held_out_loss"],
                   np.asarray(record["distances"]), len(record["x"]),
                   forecast_loss=math.nan if forecast is None else forecast)

    @property
    def criterion(self) -> float:
        return information_criterion(self.distances, self.parameters)


# evaluate(x, phase) -> loss; best(phase) -> the stored record of the lowest loss evaluated in ``phase``
Evaluate = Callable[[np.ndarray, str], float]
Best = Callable[[str], dict]


def profile_refit(candidate: Candidate, evaluate: Evaluate, best: Best, base_x: np.ndarray,
                  law_box: tuple[np.ndarray, np.ndarray], split_step: tuple[float, float], rung_evaluations: int,
                  band: tuple[float, float] | None = None, flow_index: float | None = 1.0) -> Refit:
    """The candidate's best fit along its profile: from the base fit with the effect at its null (or the nearest the box
    allows, so that the refit, a model holding the base one, ends no worse), the effect climbs every rung of its
    ladder and the law is refitted at each in the law's stress at the middle of the shear-rate ``band`` and the yield
    stress' share of it (``stress_split``), then the coordinates after the law (the shear modulus, where fitted):
    a line search along each (``line_search``; first steps ``split_step``, the stress' for the rest, log units), then
    a short Nelder-Mead search (``rung_evaluations``). The silhouettes fix that stress tightly and the share loosely,
    so an effect shifts the stress a little either way and moves the law along that valley, often far (walls
    adhering with 20 Pa, which the base fit answered with tau_y 14.3 and K 4.5 Pa s, ask for 20 and 1.5); where it
    lets the material slide, the law that fits is an order of magnitude stronger and stiffer. ``flow_index``: the
    law's n, or None where ``base_x`` holds log n (after log K; shear thinning's rung gives its own). Each rung
    starts from the law extrapolated from the two before (continuation along the valley), unless the previous rung's
    law or the base fit's does better there (where the valley turns: a sliding floor first lowers the yield stress
    that held the material back, then, once the material slides, needs it back). An effect that changes what the
    law's parameters mean also starts from the laws ``Candidate.rung_starts`` gives (shear thinning: the last rung's
    flow curve over the base flow's shear-rate ``band``; thixotropy: the base fit's yield stress with its breakdown
    restored). Rungs that fit worse do not stop the climb: a sliding floor's loss rises while the floor barely holds
    and falls again once the material slides as recorded. Then a rung halfway (on the search coordinate) between the
    branch's best and the next one out is refitted too, started from both their laws."""
    phase = f"refit {candidate.name}"
    rate = 1.0 if band is None else math.sqrt(band[0] * band[1])

    def refit_at(rung: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
        """The lowest loss and its law with the effect at ``rung``: the best of ``starts``, then a short search."""
        found: list[tuple[float, np.ndarray]] = []

        def at_rung(y: np.ndarray, _: str) -> float:
            loss = evaluate(np.r_[y, rung], phase)
            found.append((loss, np.asarray(y)))
            return loss

        def n_of(y: np.ndarray) -> float:  # a law's flow index: its own log n, the rung's, or the fixed one
            return math.exp(y[2]) if flow_index is None else candidate.flow_index(candidate.value(rung), flow_index)

        def from_split(z: np.ndarray) -> np.ndarray:
            return np.clip(np.r_[from_stress_split(z[:2], n_of(z), rate)[:2], z[2:]], *law_box)

        start = min((np.clip(x, *law_box) for x in starts), key=lambda x: at_rung(x, phase))
        z = np.r_[stress_split(np.r_[start[:2], math.log(n_of(start))], rate), start[2:]]
        step = np.r_[split_step, np.full(len(start) - 2, split_step[0])]
        # the stress is fixed tightly and an effect shifts it either way, far where the material slides
        for axis in range(len(z)):
            z = line_search(lambda point: at_rung(from_split(point), phase), z, axis, step[axis])
        simplex_search(lambda z, ph: at_rung(from_split(z), ph), z, step, rung_evaluations, phase)
        return min(found, key=lambda f: f[0])

    def effect_starts(fitted: tuple[float, np.ndarray, float], rung: float) -> list[np.ndarray]:
        """The laws ``Candidate.rung_starts`` gives at ``rung`` from a fitted rung (coordinate, law, loss)."""
        return candidate.rung_starts(fitted[1], candidate.value(fitted[0]), candidate.value(rung), band, base_x)

    null = candidate.nearest_null
    null_loss = evaluate(np.r_[base_x, null], phase)
    profile = [(candidate.value(null), null_loss)]
    for branch in candidate.rungs:
        path = [(null, base_x, null_loss)]
        for value in branch:
            rung = candidate.coordinate(value)
            starts = [path[-1][1]]
            if len(path) > 1:
                (c0, x0, _), (c1, x1, _) = path[-2:]
                starts = [x1 + (x1 - x0) * (rung - c1) / (c1 - c0), x1, base_x]
            loss, law = refit_at(rung, starts + effect_starts(path[-1], rung))
            path.append((rung, law, loss))
            profile.append((value, loss))
        # the rungs are a factor 3 apart: between the branch's best and the next one out, which lost more
        k = min(range(len(path)), key=lambda i: path[i][2])
        if k + 1 < len(path):
            (c0, x0, _), (c1, x1, _) = path[k:k + 2]
            middle = 0.5 * (c0 + c1)
            loss, _ = refit_at(middle, [x0, x1, *effect_starts(path[k], middle)])
            profile.append((candidate.value(middle), loss))
    return dataclasses.replace(Refit.of(candidate.name, best(phase)), profile=tuple(sorted(profile)))


def refits(items: Sequence[T], search: Callable[[T], Refit], side_by_side: int) -> list[Refit]:
    """Every item's (candidate's, refit's) refit, ``side_by_side`` at a time (their evaluations hand work to other
    processes)."""
    with ThreadPoolExecutor(max(side_by_side, 1)) as threads:
        return list(threads.map(search, items))


def finalists_refitted(found: Sequence[Refit], refit: Callable[[Refit], Refit], count: int,
                       side_by_side: int) -> list[Refit]:
    """The ``count`` refits of lowest criterion refitted again (``refit``: a longer search from each one's best point,
    every parameter free), the others as they were, so that the luck of a profile's short searches does not decide
    between close candidates (docs/settings.md, `finalists`)."""
    ranked = sorted(found, key=lambda r: r.criterion)
    return refits(ranked[:count], refit, side_by_side) + list(ranked[count:])


def pays(refit: Refit, base: Refit, evidence: float) -> bool:
    """Whether ``refit`` lowers the base model's criterion by more than ``evidence``."""
    return refit.criterion < base.criterion - evidence


def winner(base: Refit, found: Sequence[Refit], evidence: float) -> Refit | None:
    """The refit with the lowest criterion, if it pays for its parameters (a decoy's included)."""
    best = min(found, key=lambda r: r.criterion, default=None)
    return best if best is not None and pays(best, base, evidence) else None


def choose(base: Refit, found: Sequence[Refit], evidence: float) -> Refit | None:
    """The winner, unless it is a decoy: where a change that is no physics of the material wins, an effect's gain says
    nothing of that effect."""
    best = winner(base, found, evidence)
    return None if best is None or CANDIDATES[best.name].decoy else best


def confirmed(base: Refit, found: Sequence[Refit], evidence: float,
              base_from: Callable[[Refit], Refit]) -> tuple[Refit | None, Refit | None]:
    """The choice and, where it names an effect, the base model refitted from the named refit's law
    (``base_from``). The effect stays named only if it also pays against that refit: a refit whose law moved to a
    valley the base fit missed gains what the law alone gives there, which is no effect's."""
    chosen = choose(base, found, evidence)
    if chosen is None:
        return None, None
    recheck = base_from(chosen)
    return choose(best_base(base, recheck), found, evidence), recheck


def best_base(base: Refit, recheck: Refit | None) -> Refit:
    """The base model's best refit: the base fit, or its recheck from a winner's law where that fits better."""
    return recheck if recheck is not None and recheck.criterion < base.criterion else base


def named_below(evidence: float, recheck_delta: float | None) -> float:
    """The change of the criterion from the base fit's below which an effect is named (``pays`` against
    ``best_base``), from a diagnosis' record: ``evidence`` below the base model's best refit, the base fit or its
    recheck (``recheck_delta`` from the base fit; None: not rechecked)."""
    return min(0.0, 0.0 if recheck_delta is None else recheck_delta) - evidence
