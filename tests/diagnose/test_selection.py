"""Choosing an effect: the information criterion against its formula, a refit that finds a known optimum, and
the rule that a free parameter must pay for itself."""

import math

import numpy as np
import pytest

from rheo.diagnose.candidates import CANDIDATES, Law
from rheo.diagnose.selection import EVIDENCE, Refit, choose, information_criterion, refit_with
from rheo.experiments.dam_break import Effects
from rheo.fit.search import EvaluationLog


def test_information_criterion_is_the_gaussian_bic_of_the_frames():
    d = np.array([0.1, 0.2, 0.3, 0.4])
    sse = float(np.sum(d**2))
    assert information_criterion(d, 2) == pytest.approx(4 * math.log(sse / 4) + 2 * math.log(4))
    # halving every distance is worth N log 4; one more parameter costs log N
    assert information_criterion(d / 2, 3) - information_criterion(d, 2) == pytest.approx(-4 * math.log(4)
                                                                                          + math.log(4))


def _refit(name: str, scale: float, parameters: int) -> Refit:
    return Refit(name, np.zeros(parameters), scale, scale, np.full(8, scale), parameters)


def test_an_effect_is_named_only_when_it_pays_for_its_parameter():
    base = _refit("base", 1.0, 2)
    # one parameter more costs log 8 = 2.08: a 10 % smaller residual gains 8 log 0.81 = -1.69, short of it
    assert choose(base, [_refit("floor_friction", 0.9, 3)]) is None
    strong, weak = _refit("floor_friction", 0.5, 3), _refit("air_drag", 0.7, 3)
    assert choose(base, [weak, strong]) is strong
    assert choose(base, []) is None
    assert strong.criterion < base.criterion - EVIDENCE


def test_a_short_refit_finds_the_effect_and_the_law_of_a_known_optimum(tmp_path):
    """A loss whose minimum lies at tau_y 10, K 3 and a Coulomb coefficient 0.4, evaluated through the log."""
    candidate = CANDIDATES["floor_friction"]
    optimum = np.array([math.log(10.0), math.log(3.0), candidate.coordinate(0.4)])
    log = EvaluationLog(tmp_path / "log.json", "key")

    def evaluate(x, phase):
        def details(points):
            out = []
            for p in points:
                loss = 0.01 + float(np.sum((p - optimum) ** 2))
                out.append({"loss": loss, "held_out_loss": 2 * loss, "distances": [loss] * 4})
            return out
        return log.evaluate_many(details, [x], phase)[0]

    base_x = np.log([8.0, 2.5])
    refit = refit_with(candidate, evaluate, log.record, base_x, (np.log([0.1, 0.1]), np.log([100.0, 100.0])),
                       0.15, 200)
    assert refit.x == pytest.approx(optimum, abs=0.02)
    assert refit.loss == pytest.approx(0.01, abs=1e-3) and refit.held_out_loss == pytest.approx(2 * refit.loss)
    assert refit.parameters == 3 and len(log.records) <= 200


def test_candidates_at_their_null_values_give_back_the_base_law_and_effects():
    law = Law(n=1.0)
    x = np.log([8.0, 2.0])
    assert law.names == ("tau_y", "K") and Law().names == ("tau_y", "K", "n")
    values, effects = law.unpack(x)
    assert values == pytest.approx({"tau_y": 8.0, "K": 2.0, "n": 1.0}) and effects == Effects()
    for candidate in CANDIDATES.values():
        if math.isfinite(candidate.null):  # (a sticky floor is the limit of an infinite coefficient)
            null = -math.inf if candidate.log and candidate.null == 0 else candidate.coordinate(candidate.null)
            with_null = Law(1.0, candidate).unpack(np.r_[x, null])
            assert with_null[0] == pytest.approx(values) and with_null[1] == effects, candidate.name
        low, high = candidate.bounds
        assert low < candidate.coordinate(candidate.start) < high or candidate.start == candidate.null
    _, sliding = Law(1.0, CANDIDATES["floor_friction"]).unpack(np.r_[x, math.log(0.3)])
    assert sliding.floor_friction == pytest.approx(0.3)
    _, tilted = Law(1.0, CANDIDATES["gravity_tilt"]).unpack(np.r_[x, 5.0])
    assert tilted.gravity_tilt == pytest.approx(math.radians(5.0))
    thinning, _ = Law(1.0, CANDIDATES["shear_thinning"]).unpack(np.r_[x, math.log(0.5)])
    assert thinning["n"] == pytest.approx(0.5)
