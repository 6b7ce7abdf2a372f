"""Which candidate effect the recording asks for: short refits with each effect added, compared by an information
criterion so that a free parameter does not win by default.

A fit's per-frame boundary distances over the fitted frames (of every setup) are taken as Gaussian residuals of one
unknown scale; its Bayesian information criterion is then N log(SSE / N) + k log N (N frames, k fitted parameters).
An effect is named when its refit lowers the criterion below the base model's by more than ``EVIDENCE`` (6: strong
evidence on Kass and Raftery's scale), and the lowest criterion wins; otherwise nothing is missing. The frames held
out of every fit judge the choice afterwards. (The residual of a base fit is not noise but the simulation's own
error, which any extra freedom absorbs in part: at 2, positive evidence, a concealed case with no effect named wall
adhesion at -2.1.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from rheo.diagnose.candidates import Candidate
from rheo.fit.search import simplex_search

EVIDENCE = 6.0  # least drop of the information criterion that names an effect


def information_criterion(distances: np.ndarray, parameters: int) -> float:
    """N log(SSE / N) + k log N of per-frame distances (px)."""
    count = len(distances)
    sse = max(float(np.sum(np.square(distances))), 1e-300)
    return count * math.log(sse / count) + parameters * math.log(count)


@dataclass
class Refit:
    """The best point a (re)fit found, its loss (px) on the fitted frames and the held-out ones, the per-frame
    distances of the fitted frames, and how many parameters it fitted."""

    name: str
    x: np.ndarray
    loss: float
    held_out_loss: float
    distances: np.ndarray
    parameters: int

    @property
    def criterion(self) -> float:
        return information_criterion(self.distances, self.parameters)


# evaluate(x, phase) -> loss; details(phase, x) -> the stored record of a point evaluated in ``phase``
Evaluate = Callable[[np.ndarray, str], float]
Details = Callable[[str, np.ndarray], dict]


def refit_with(candidate: Candidate, evaluate: Evaluate, details: Details, base_x: np.ndarray,
               law_box: tuple[np.ndarray, np.ndarray], law_step: float, evaluations: int) -> Refit:
    """A short Nelder-Mead refit of the law with ``candidate`` added, from the base fit's law and the candidate's
    start, inside the law's box and the candidate's."""
    start = np.r_[base_x, candidate.coordinate(candidate.start)]
    low, high = candidate.bounds
    box = (np.r_[law_box[0], low], np.r_[law_box[1], high])
    steps = np.r_[np.full(len(base_x), law_step), candidate.step]
    phase = f"refit {candidate.name}"
    x, loss = simplex_search(evaluate, start, steps, evaluations, phase, box=box)
    record = details(phase, x)
    return Refit(candidate.name, x, loss, record["held_out_loss"], np.asarray(record["distances"]), len(start))


def refits(candidates: Sequence[Candidate], search: Callable[[Candidate], Refit], side_by_side: int) -> list[Refit]:
    """Every candidate's refit, ``side_by_side`` at a time (their evaluations hand work to other processes)."""
    with ThreadPoolExecutor(max(side_by_side, 1)) as threads:
        return list(threads.map(search, candidates))


def choose(base: Refit, found: Sequence[Refit], evidence: float = EVIDENCE) -> Refit | None:
    """The refit with the lowest criterion, if it undercuts the base model's by more than ``evidence``."""
    if not found:
        return None
    best = min(found, key=lambda r: r.criterion)
    return best if best.criterion < base.criterion - evidence else None
