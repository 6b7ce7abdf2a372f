"""The diagnosis of a dam-break fit: where the best fit still disagrees with the recordings, which candidate effect
explains it, the refit with that effect, and the gain on the frames held out of every fit.

Each candidate is refitted along its profile (the effect climbing rungs of magnitude, the law refitted at each); the
candidates are ranked by the information criterion (``rheo.diagnose.selection``), and the winner, if any, is
refitted with more evaluations. Every evaluation is stored, so an interrupted diagnosis resumes.
"""

from __future__ import annotations

import dataclasses
import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from rheo.diagnose.candidates import CANDIDATES, OPEN_BOX, OPEN_DRAG, OPEN_STEP, Candidate, Law, matched_law, open_rates
from rheo.diagnose.residuals import Location, locate
from rheo.diagnose.selection import (
    Best,
    Evaluate,
    Refit,
    best_base,
    choose,
    confirmed,
    finalists_refitted,
    pays,
    profile_refit,
    refits,
    winner,
)
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.experiments.virheometry import Setup
from rheo.fit.dam_break import Comparison, compare_law, shear_rate_band, targets
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, simplex_search
from rheo.io import json_number
from rheo.physics.optional import OPEN_DRAG_TERMS

logger = logging.getLogger(__name__)
MIN_LAW_STEP = 0.05  # log units: the smallest initial simplex of a refit's law


def applicable(candidate: Candidate, setups: list[Setup], law: Law) -> bool:
    """Whether the effect can act: walls adhere only where some wall lets the material slide; a fitted flow index
    leaves no shear thinning to add."""
    if candidate.name == "wall_adhesion":
        return any(w.contact != "sticky" for s in setups for w in s.walls)
    if candidate.name == "shear_thinning":
        return law.n is not None
    return True


def objectives(setups: dict[str, tuple[str, str]], simulation: dict, laws: dict[str, Law]) -> dict[str, Callable]:
    """Comparisons by "law|setup", every setup's target built once; for ``Evaluator``."""
    built = targets(setups, simulation)
    return {f"{law_name}|{name}": partial(compare_law, target, law)
            for law_name, law in laws.items() for name, target in built.items()}


def summary(results: list[Comparison]) -> dict:
    """One evaluation over the setups, JSON-ready: mean losses and the fitted frames' distances."""

    def mean(losses: list[float]) -> float | None:
        kept = [v for v in losses if not np.isnan(v)]
        return float(np.mean(kept)) if kept else None

    return {"loss": float(np.mean([r.loss for r in results])),
            "held_out_loss": mean([r.held_out_loss for r in results]),
            "forecast_loss": mean([r.forecast_loss for r in results]),
            "distances": [float(d) for r in results for d in r.fitted_distances]}


def stored_base(log: EvaluationLog, x_base: np.ndarray, before: list[Comparison]) -> tuple[dict, list[float] | None]:
    """The base fit's record in ``log`` (stored there from its comparisons ``before`` if new) and the shear-rate band
    of its flow, stored with it: the refits' points depend on that band, and a base fit simulated again on another
    machine (or a GPU, whose sums are not reproducible bit for bit) gives a slightly different one, which would send
    a resumed diagnosis through new points rather than its stored ones."""
    band = shear_rate_band(before)
    log.evaluate_many(lambda _: [{**summary(before), "shear_rate_band": band}], [x_base], "base")
    record = log.record("base", x_base)
    return record, record.get("shear_rate_band", band)


def open_drag_words(rates: Sequence[float]) -> str:
    """Where and when the open drag acts, in words: its terms of at least half the largest rate (1/s)."""
    largest = float(np.max(np.abs(rates)))
    parts = []
    for term, rate in zip(OPEN_DRAG_TERMS, rates, strict=True):
        if largest > 0 and abs(rate) >= 0.5 * largest:
            place, when = term.split()
            action = "holds the material back" if rate > 0 else "drives the flow"
            where = "near the floor" if place == "floor" else "above the floor"
            parts.append(f"{action} {where}, {when} in the recording ({rate:+.2g} 1/s)")
    return "; ".join(parts) or "nowhere"


@dataclass
class Diagnosis:
    """The base fit, every candidate's short refit, the chosen effect's longer refit (None: no candidate explains the
    mismatch), the comparisons before and after by setup, where the base fit's mismatch lies (and the chosen
    refit's, ``remains``), the open drag's refit where no candidate is chosen (None if not fitted), the shear
    rates the base fit's flow reaches, and the base model refitted from the law of the effect that won first
    (``recheck``; None where none won)."""

    law: Law
    base: Refit
    candidates: list[Refit]
    chosen: Refit | None
    before: dict[str, Comparison]
    after: dict[str, Comparison]
    location: dict[str, Location]
    evidence: float
    open: Refit | None = None
    remains: dict[str, Location] | None = None
    band: list[float] | None = None  # the shear rates (1/s) the base fit's flow reaches, as stored with it
    recheck: Refit | None = None

    def values(self, refit: Refit) -> dict[str, float]:
        """The law and the effect of a refit (a candidate's or the open drag's), in their units."""
        candidate = CANDIDATES.get(refit.name)
        law, _ = dataclasses.replace(self.law, candidate=candidate).unpack(refit.x)
        out = {PARAMETER_KEYS[name]: value for name, value in law.items()}
        if candidate is not None:
            out[candidate.name] = candidate.value(float(refit.x[-1]))
        if refit.name == "open":
            out |= dict(zip(OPEN_DRAG, open_rates(refit.x), strict=True))
        return out

    @property
    def open_explains(self) -> bool:
        """Whether the open drag lowers the criterion below the base model's by the evidence asked of an effect."""
        return self.open is not None and pays(self.open, best_base(self.base, self.recheck), self.evidence)

    @staticmethod
    def worst(location: dict[str, Location]) -> str:
        """The setup that shows the most mismatch and where and when it lies there."""
        name = max(location, key=lambda n: location[n].total.sum())
        return f"{name}: {location[name].words()}"

    def verdict(self) -> str:
        """The chosen effect and the mismatch that remains after it, or ``unexplained``."""
        if self.chosen is None:
            return self.unexplained()
        title = CANDIDATES[self.chosen.name].title
        if not self.remains or all(loc.total.sum() == 0 for loc in self.remains.values()):
            return title
        return f"{title}; the mismatch that remains after it ({self.worst(self.remains)})"

    def unexplained(self) -> str:
        """The verdict where no candidate is named: the mismatch that remains, where and when, in the setup that
        shows the most of it, whether a decoy wins or the recheck withdrew the winner, and what the open drag says of
        it where it explains it."""
        verdict = f"no candidate explains the mismatch that remains ({self.worst(self.location)})"
        first = winner(self.base, self.candidates, self.evidence)
        if first and CANDIDATES[first.name].decoy:
            verdict += (f"; {CANDIDATES[first.name].title} fits it better than every effect (criterion "
                        f"{first.criterion - self.base.criterion:+.1f}), so no effect's gain can be told from that of "
                        "a change that is no physics of the material")
        elif first and self.recheck is not None:
            verdict += (f"; {CANDIDATES[first.name].title} fitted better (criterion "
                        f"{first.criterion - self.base.criterion:+.1f}) with a law the base fit had missed, and the "
                        f"base model refitted from that law comes within the evidence of it (criterion "
                        f"{self.recheck.criterion - self.base.criterion:+.1f})")
        if self.open_explains:
            verdict += (f"; an open drag explains part of it ({self.base.loss:.3g} to {self.open.loss:.3g} px): it "
                        f"{open_drag_words(open_rates(self.open.x))}")
        return verdict

    def record(self) -> dict:
        """diagnosis.json's content."""

        def fit(refit: Refit) -> dict:
            return {"loss_px": refit.loss, "held_out_loss_px": refit.held_out_loss,
                    "forecast_loss_px": json_number(refit.forecast_loss), "criterion": refit.criterion,
                    "parameters": refit.parameters, "values": self.values(refit)}

        def mismatch(location: dict[str, Location]) -> dict:
            return {name: {"words": loc.words(), "by_region": loc.by_region(),
                           "pixels_by_frame": loc.by_frame().tolist()} for name, loc in location.items()}

        ranked = sorted(self.candidates, key=lambda r: r.criterion)
        chosen = self.chosen
        after = chosen or best_base(self.base, self.recheck)  # what the diagnosis ends with
        return {
            "base_model": "Bingham (n = 1)" if self.law.n == 1.0 else
                          "Herschel-Bulkley" if self.law.n is None else f"Herschel-Bulkley, n = {self.law.n}",
            "criterion": "BIC of per-frame boundary distances, N log(SSE/N) + k log N, over the fitted frames",
            "evidence": self.evidence,
            "mismatch": mismatch(self.location),
            "mismatch_after": None if self.remains is None else mismatch(self.remains),
            "base": fit(self.base),
            "candidates": [{"effect": r.name, "title": CANDIDATES[r.name].title, "decoy": CANDIDATES[r.name].decoy,
                            "delta_criterion": r.criterion - self.base.criterion, **fit(r),
                            "profile": [list(p) for p in r.profile]} for r in ranked],
            "chosen": None if chosen is None else chosen.name,
            "verdict": self.verdict(),
            "magnitude": None if chosen is None else self.values(chosen)[chosen.name],
            "refit": None if after is self.base else fit(after),
            "recheck": None if self.recheck is None else {
                **fit(self.recheck), "delta_criterion": self.recheck.criterion - self.base.criterion},
            "open": None if self.open is None else {
                **fit(self.open), "delta_criterion": self.open.criterion - self.base.criterion,
                "explains": self.open_explains, "words": open_drag_words(open_rates(self.open.x))},
            "loss_before_after_px": {"fitted": [self.base.loss, after.loss],
                                     "held_out": [self.base.held_out_loss, after.held_out_loss],
                                     "forecast": [json_number(self.base.forecast_loss),
                                                  json_number(after.forecast_loss)]},
        }


def law_steps(names: tuple[str, ...], intervals: dict[str, tuple[float, float]], largest: float) -> np.ndarray:
    """The initial simplex of a refit's law (log units): each parameter's tolerance interval in the base fit, as a
    half-width in log units, at least ``MIN_LAW_STEP`` and at most ``largest``. The loss may be ten times as sensitive
    to one parameter as to another; a step far wider than the interval spends a short refit's evaluations on points
    many times the base loss."""
    return np.array([np.clip(0.5 * np.log(intervals[n][1] / intervals[n][0]), MIN_LAW_STEP, largest) for n in names])


def refit_point(law: Law, effect: str, values: dict[str, float]) -> np.ndarray:
    """The search point of ``effect``'s refit from its ``values`` as a diagnosis record keeps them (the inverse of
    ``Diagnosis.values``): the log law of ``law`` (a candidate's flow index comes from the effect), then the effect's
    coordinate."""
    law_x = np.log([values[PARAMETER_KEYS[name]] for name in law.material_names])
    return np.r_[law_x, CANDIDATES[effect].coordinate(values[effect])]


def recheck_start(candidate: Candidate, x: np.ndarray, law: Law, band: Sequence[float] | None,
                  law_box: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Where the base model's recheck starts: the material coordinates of ``candidate``'s refit ``x``, with the flow
    curve matched over the shear-rate ``band`` at the base ``law``'s flow index where the effect changed that index,
    within ``law_box``."""
    start = np.asarray(x[:len(law.material_names)], dtype=float)
    n = candidate.flow_index(candidate.value(float(x[-1])), law.n)
    if band is not None and law.n is not None and n != law.n:
        start = np.r_[matched_law(start, n, law.n, band), start[2:]]
    return np.clip(start, *law_box)


def base_refit_from(effect: str, x: np.ndarray, law: Law, band: Sequence[float] | None,
                    law_box: tuple[np.ndarray, np.ndarray], steps: np.ndarray, evaluate: Evaluate, best: Best,
                    evaluations: int, phase: str | None = None) -> Refit:
    """The recheck of a winner: the base model searched from the law of ``effect``'s refit ``x``
    (``recheck_start``), ``evaluations`` of a simplex search (initial simplex half the law's ``steps``) in ``phase``,
    ``recheck <effect>`` unless given; its best point, from ``best``."""
    phase = phase or f"recheck {effect}"
    start = recheck_start(CANDIDATES[effect], x, law, band, law_box)
    simplex_search(evaluate, start, 0.5 * steps, evaluations, phase, box=law_box)
    return Refit.of("base", best(phase))


def diagnose(setups: dict[str, tuple[str, str]], simulation: dict, fit_settings: dict, settings: dict,
             base_values: dict[str, float], base_intervals: dict[str, tuple[float, float]], log: EvaluationLog,
             workers: int, on_evaluation: Callable[[str, np.ndarray, float], None] = lambda *_: None) -> Diagnosis:
    """Diagnose the fit ``base_values`` (tau_y, K, n; tolerance intervals ``base_intervals``) of the ``setups``
    (name: (setup.json, masks.npz)), fitted with ``fit_settings`` (its boxes, its fixed flow index) on
    ``simulation``'s grid. ``settings``: ``candidates`` (names), ``rung_evaluations`` (the law's refit at each rung
    of a profile), ``stress_step`` and ``share_step`` (its line searches' first steps and initial simplex in the
    law's stress and the yield stress' share of it, log units), ``finalists`` (the candidates of lowest criterion
    refitted with every parameter free before the choice), ``refit_evaluations`` (each such refit, and the recheck),
    ``law_step`` (largest initial simplex of the law in those refits, log units; ``law_steps``), ``evidence`` (least
    drop of the criterion), ``open_evaluations`` (the open drag's refit where no candidate is chosen; 0: none)."""
    records = {}
    for name, (record, masks) in setups.items():
        with open(record) as f:
            records[name] = Setup.from_record(json.load(f), np.load(masks)["masks"])
    law = Law(n=fit_settings.get("flow_index"), fitted_modulus=fit_settings.get("mu") is not None)
    x_base = np.log([base_values[n] for n in law.names])
    steps = law_steps(law.names, base_intervals, settings["law_step"])
    law_box = (np.log([fit_settings[n][0] for n in law.names]), np.log([fit_settings[n][1] for n in law.names]))
    candidates = [CANDIDATES[c] for c in settings["candidates"]
                  if applicable(CANDIDATES[c], list(records.values()), law)]
    skipped = sorted(set(settings["candidates"]) - {c.name for c in candidates})
    if skipped:
        logger.info("not applicable here: %s", ", ".join(skipped))
    laws = {"base": law, "open": dataclasses.replace(law, open=True),
            **{c.name: dataclasses.replace(law, candidate=c) for c in candidates}}
    with Evaluator(partial(objectives, setups, simulation, laws), workers) as evaluator:

        def evaluate(law_name: str) -> Callable[[np.ndarray, str], float]:
            def joint(points: list[np.ndarray]) -> list[dict]:
                results = evaluator.map([(f"{law_name}|{s}", x) for x in points for s in setups])
                out = [summary(results[i * len(setups):(i + 1) * len(setups)]) for i in range(len(points))]
                for x, value in zip(points, out, strict=True):
                    on_evaluation(law_name, x, value["loss"])
                return out

            return lambda x, phase: log.evaluate_many(joint, [x], phase)[0]

        # the base fit, simulated once: its comparisons (silhouettes, shear rates) and its stored record
        before = dict(zip(setups, evaluator.map([(f"base|{s}", x_base) for s in setups]), strict=True))
        record, band = stored_base(log, x_base, list(before.values()))
        on_evaluation("base", x_base, record["loss"])
        base = Refit.of("base", record)
        split_step = (settings["stress_step"], settings["share_step"])
        found = refits(candidates, lambda c: profile_refit(c, evaluate(c.name), log.best, x_base, law_box,
                                                           split_step, settings["rung_evaluations"], band,
                                                           law.n),
                       workers)  # a candidate per worker: a small setup's simulation does not wait for a large one

        def searched(law_name: str, start: np.ndarray, effect_step, effect_low, effect_high, evaluations: int,
                     phase: str) -> Refit:
            """The best point of a simplex search from ``start`` with the law and the effect's coordinates free
            (initial simplex: half the law's steps and ``effect_step``; box: the law's and the effect's)."""
            box = (np.r_[law_box[0], effect_low], np.r_[law_box[1], effect_high])
            simplex_search(evaluate(law_name), start, np.r_[0.5 * steps, effect_step], evaluations, phase, box=box)
            return Refit.of(law_name, log.best(phase))

        def refit_free(profiled: Refit) -> Refit:
            """A longer search from a profile's best point with the law and the effect free."""
            candidate = CANDIDATES[profiled.name]
            final = searched(profiled.name, profiled.x, 0.5 * candidate.step, *candidate.bounds,
                             settings["refit_evaluations"], f"final {profiled.name}")
            return dataclasses.replace(final, profile=profiled.profile) if final.loss <= profiled.loss else profiled

        if settings["refit_evaluations"] > 0:
            found = finalists_refitted(found, refit_free, settings["finalists"], workers)
        for r in sorted(found, key=lambda r: r.criterion):
            logger.info("%s: loss %.4g px (base %.4g), criterion %+.2f", r.name, r.loss, base.loss,
                        r.criterion - base.criterion)

        def base_from(refit: Refit) -> Refit:
            return base_refit_from(refit.name, refit.x, law, band, law_box, steps, evaluate("base"), log.best,
                                   settings["refit_evaluations"])

        if settings["refit_evaluations"] > 0:
            chosen, recheck = confirmed(base, found, settings["evidence"], base_from)
        else:
            chosen, recheck = choose(base, found, settings["evidence"]), None
        if recheck is not None:
            logger.info("base model refitted from the winner's law: loss %.4g px, criterion %+.2f%s", recheck.loss,
                        recheck.criterion - base.criterion, "" if chosen else "; nothing named")
        after = before if chosen is None else dict(zip(setups, evaluator.map(
            [(f"{chosen.name}|{s}", chosen.x) for s in setups]), strict=True))
        opened = None
        if chosen is None and settings["open_evaluations"] > 0:
            # what kind of physics is missing: a drag field free where and when it acts
            rates = len(OPEN_DRAG)
            opened = searched("open", np.r_[best_base(base, recheck).x, np.zeros(rates)], np.full(rates, OPEN_STEP),
                              np.full(rates, OPEN_BOX[0]), np.full(rates, OPEN_BOX[1]), settings["open_evaluations"],
                              "open")
            logger.info("open drag: loss %.4g px (base %.4g), criterion %+.2f", opened.loss, base.loss,
                        opened.criterion - base.criterion)

    def located(comparisons: dict[str, Comparison]) -> dict[str, Location]:
        return {name: locate(records[name], list(c.silhouettes), records[name].masks)
                for name, c in comparisons.items()}

    return Diagnosis(law, base, found, chosen, before, after, located(before), settings["evidence"], opened,
                     None if chosen is None else located(after), band, recheck)
