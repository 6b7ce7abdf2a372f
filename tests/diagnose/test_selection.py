"""Choosing an effect: the information criterion against its formula, a refit that finds a known optimum, and
the rule that a free parameter must pay for itself."""

import math

import numpy as np
import pytest

from rheo.diagnose.candidates import BREAKDOWN_STRAINS, CANDIDATES, Law, matched_law
from rheo.diagnose.dam_break import MIN_LAW_STEP, law_steps, recheck_start
from rheo.diagnose.selection import (
    Refit,
    best_base,
    choose,
    confirmed,
    finalists_refitted,
    information_criterion,
    named_below,
    pays,
    profile_refit,
)
from rheo.experiments.dam_break import dam_break_scene
from rheo.experiments.effects import Effects
from rheo.fit.dam_break import stress_split
from rheo.fit.search import LINE_EXPANSIONS, EvaluationLog, line_search
from rheo.physics import HerschelBulkley

EVIDENCE = 6.0  # diagnose.evidence's default
SPLIT_STEP = (0.1, 1.0)  # diagnose.stress_step and share_step's defaults


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
    assert choose(base, [_refit("floor_friction", 0.9, 3)], EVIDENCE) is None
    strong, weak = _refit("floor_friction", 0.5, 3), _refit("air_drag", 0.7, 3)
    assert choose(base, [weak, strong], EVIDENCE) is strong
    assert choose(base, [], EVIDENCE) is None
    assert strong.criterion < base.criterion - EVIDENCE


def test_the_finalists_are_refitted_before_the_choice():
    """Air drag's profile ends just short of the decoy's criterion; refitted with every parameter free, it halves its
    residual and wins. Only the finalists are refitted; with one finalist the decoy wins and nothing is named."""
    base = _refit("base", 1.0, 2)
    found = [_refit("gravity_tilt", 0.40, 3), _refit("air_drag", 0.41, 3), _refit("density", 0.9, 3)]

    def refit(r: Refit) -> Refit:
        return _refit(r.name, r.loss / 2 if r.name == "air_drag" else r.loss * 0.99, 3)

    two = finalists_refitted(found, refit, 2, 1)
    assert choose(base, two, EVIDENCE).name == "air_drag"
    assert {r.name: r.loss for r in two} == pytest.approx({"gravity_tilt": 0.396, "air_drag": 0.205, "density": 0.9})
    assert choose(base, finalists_refitted(found, refit, 1, 1), EVIDENCE) is None


def test_a_decoy_that_wins_names_nothing():
    """A decoy is no physics of the material: where it fits best, an effect that also pays for its parameter is not
    named, and nothing is named where a decoy alone pays."""
    base = _refit("base", 1.0, 2)
    tilt, friction = _refit("gravity_tilt", 0.3, 3), _refit("floor_friction", 0.5, 3)
    assert friction.criterion < base.criterion - EVIDENCE
    assert choose(base, [friction, tilt], EVIDENCE) is None
    assert choose(base, [_refit("density", 0.3, 3)], EVIDENCE) is None
    assert choose(base, [friction, _refit("density", 0.6, 3)], EVIDENCE) is friction


def test_an_effect_is_named_only_if_the_base_model_refitted_from_its_law_does_not_come_as_close():
    """A refit that halves the residual pays against the base fit; if the base model, searched from the refit's law,
    halves it too, the gain was the law's, and nothing is named. Only a winner is rechecked."""
    base, thixotropy = _refit("base", 1.0, 2), _refit("thixotropy", 0.5, 3)
    seen = []

    def base_from(scale: float):
        def refit(r: Refit) -> Refit:
            seen.append(r.name)
            return _refit("base", scale, 2)
        return refit

    # from the winner's law the base model reaches 0.5 as well: the criterion then favours it by log 8
    chosen, recheck = confirmed(base, [thixotropy], EVIDENCE, base_from(0.5))
    assert chosen is None and recheck.loss == 0.5
    # it reaches 0.9 there: thixotropy still lowers the criterion by 8 log(0.81 / 0.25) - log 8 = 7.3 > 6
    chosen, recheck = confirmed(base, [thixotropy], EVIDENCE, base_from(0.9))
    assert chosen is thixotropy and recheck.loss == 0.9
    assert thixotropy.criterion - recheck.criterion == pytest.approx(8 * math.log(0.25 / 0.81) + math.log(8))
    # the recheck never makes the base model worse: a recheck that fits worse leaves the base fit the reference
    assert confirmed(base, [thixotropy], EVIDENCE, base_from(2.0))[0] is thixotropy
    assert seen == ["thixotropy"] * 3
    # a refit that does not pay is not rechecked
    assert confirmed(base, [_refit("air_drag", 0.9, 3)], EVIDENCE, base_from(0.5)) == (None, None)
    assert seen == ["thixotropy"] * 3


def test_the_bar_read_from_a_diagnosis_record_is_the_rule_the_choice_applies():
    """A diagnosis record holds criteria as changes from the base fit's; an effect's change below ``named_below``
    is what pays against the base model's best refit, rechecked or not."""
    base = _refit("base", 1.0, 2)
    for scale in np.linspace(0.3, 1.2, 19):
        effect = _refit("thixotropy", scale, 3)
        delta = effect.criterion - base.criterion
        assert (delta < named_below(EVIDENCE, None)) == pays(effect, base, EVIDENCE)
        for recheck_scale in (0.4, 0.6, 0.9, 1.5):
            recheck = _refit("base", recheck_scale, 2)
            assert (delta < named_below(EVIDENCE, recheck.criterion - base.criterion)) == pays(
                effect, best_base(base, recheck), EVIDENCE)
    assert named_below(EVIDENCE, None) == -EVIDENCE and named_below(EVIDENCE, 2.0) == -EVIDENCE
    assert named_below(EVIDENCE, -3.0) == -3.0 - EVIDENCE


def _logged(log: EvaluationLog, loss):
    """evaluate(x, phase) through the log, with the details a diagnosis stores."""
    def evaluate(x, phase):
        return log.evaluate_many(lambda points: [{"loss": loss(p), "held_out_loss": 2 * loss(p),
                                                  "distances": [loss(p)] * 4} for p in points], [x], phase)[0]
    return evaluate


LAW_BOX = (np.log([0.1, 0.1]), np.log([100.0, 100.0]))


def _split(p: np.ndarray) -> np.ndarray:
    """A Bingham law's (log tau_y, log K) as its log stress at 1 1/s and the log of yield to viscous stress."""
    return stress_split(np.r_[p[:2], 0.0], 1.0)


def _valley_loss(p: np.ndarray, valley: np.ndarray, stress: float = 10.0, share: float = 0.05) -> float:
    """A dam break's law landscape: the stress at the flow's shear rates tight, the yield stress' share loose."""
    offset = _split(p) - valley
    return stress * offset[0] ** 2 + share * offset[1] ** 2


def _valley_towards(base_x: np.ndarray, truth_x: np.ndarray, along: float) -> np.ndarray:
    """The split law ``along`` the straight way from the base fit's law (0) to the truth's (1)."""
    return _split(base_x) + (_split(truth_x) - _split(base_x)) * along


def test_a_profile_follows_the_law_an_effect_needs_far_from_the_base_fit(tmp_path):
    """The data want a Coulomb coefficient of 0.3, and at each coefficient a law of the same stress (at 1 1/s) whose
    yield stress takes a larger share of it the more the material slides (log tau_y / viscous stress up 0.8 per unit
    of log coefficient): at 0.3, K a tenth of the base fit's. Climbing the rungs, the profile follows that valley."""
    candidate = CANDIDATES["floor_friction"]
    base_x = np.log([8.0, 2.5])
    null, target = candidate.nearest_null, candidate.coordinate(0.3)

    def valley(c: float) -> np.ndarray:
        return _split(base_x) + np.array([0.0, 0.8]) * (null - c)

    def loss(p: np.ndarray) -> float:
        return 0.01 + _valley_loss(p, valley(p[2])) + 0.2 * (p[2] - target) ** 2

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert candidate.value(refit.x[2]) == pytest.approx(0.3)
    assert np.all(np.abs(_split(refit.x) - valley(refit.x[2])) < [0.05, 0.3])  # the share within a factor 1.35
    assert refit.loss < 0.015 < loss(np.r_[base_x, null]) / 20
    assert refit.held_out_loss == pytest.approx(2 * refit.loss) and refit.parameters == 3
    rungs = len(candidate.rungs[0])
    # a rung: three starts (one at the first), a line search along the stress and one along the share, a short
    # simplex; and one rung halfway to the next
    assert len(log.records) <= 1 + (rungs + 1) * (3 + 2 * (3 + LINE_EXPANSIONS + 1) + 5)


def test_a_profile_searches_a_fitted_shear_modulus_beside_the_law(tmp_path):
    """With the shear modulus fitted, the base point carries log mu after the law: each rung's short search moves it
    too. The data want a Coulomb coefficient of 0.3 and a modulus of 600 Pa, where the base fit held 300."""
    candidate = CANDIDATES["floor_friction"]
    base_x = np.log([8.0, 2.5, 300.0])
    box = (np.r_[LAW_BOX[0], np.log(30.0)], np.r_[LAW_BOX[1], np.log(3000.0)])
    target = candidate.coordinate(0.3)

    def loss(p: np.ndarray) -> float:
        return 0.01 + _valley_loss(p, _split(base_x)) + 0.2 * (p[2] - math.log(600.0)) ** 2 + 0.2 * (
            p[3] - target) ** 2

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, box, SPLIT_STEP, 8)
    assert len(refit.x) == 4 and refit.parameters == 4
    assert candidate.value(refit.x[3]) == pytest.approx(0.3)
    assert abs(refit.x[2] - math.log(600.0)) < 0.5 * math.log(2.0)  # mu moved most of the way from 300 Pa
    assert refit.loss < loss(np.r_[base_x[:2], base_x[2], target])


def test_a_line_search_doubles_its_step_while_the_loss_falls():
    """Along one coordinate of a quadratic bowl: from 2 units away, steps of 0.1 doubling reach 1.5 in four
    doublings and stop where the next step (3.1) lands further off, and the parabola through 0.7, 1.5 and 3.1 finds
    the bottom; the other coordinate stays; a start at the bottom stays; a bottom 100 units away is approached no
    further than five doublings allow (6.3); a loss that ignores the coordinate leaves the start."""
    calls = []

    def bowl(bottom: float):
        def loss(z: np.ndarray) -> float:
            calls.append(z)
            return float((z[1] - bottom) ** 2 + z[0] ** 2)
        return loss

    assert line_search(bowl(2.0), np.array([0.3, 0.0]), 1, 0.1) == pytest.approx([0.3, 2.0])
    assert len(calls) == 3 + 4 + 1
    assert line_search(bowl(0.0), np.array([0.3, 0.0]), 1, 0.1) == pytest.approx([0.3, 0.0])
    farthest = 0.1 * (2 ** (LINE_EXPANSIONS + 1) - 1)
    assert line_search(bowl(-100.0), np.zeros(2), 1, 0.1) == pytest.approx([0.0, -farthest])
    assert line_search(bowl(0.0), np.array([0.3, 0.0]), 0, 0.1) == pytest.approx([0.0, 0.0])
    assert line_search(lambda z: 1.0, np.array([0.3, 0.0]), 1, 0.1) == pytest.approx([0.3, 0.0])


def test_a_floor_friction_profile_crosses_the_rungs_where_the_floor_barely_holds(tmp_path):
    """A sticky-floor fit (coefficient 5) compensated a floor of 0.18 with a soft, weak material (the fifth suite's
    floor-friction cases: the modulus at its lower bound, the yield stress a tenth of the truth's). The loss rises
    while the floor barely holds (0.5 and 0.3 fit worse than the base fit) and falls six-fold at the true
    coefficient, where the law that fits is an order of magnitude stronger (log stress +2.5) and stiffer (mu 700
    Pa). The profile climbs past the rise, and each rung's line searches move the law that far."""
    candidate = CANDIDATES["floor_friction"]
    base_x = np.log([1.4, 0.9, 30.0])
    box = (np.r_[LAW_BOX[0], np.log(30.0)], np.r_[LAW_BOX[1], np.log(3000.0)])
    coefficients = np.log([0.1, 0.18, 0.3, 0.5, 1.0, 2.0, 5.0])
    floor = [0.3, 0.013, 0.2, 0.11, 0.087, 0.081, 0.089]
    sliding = candidate.coordinate(0.5)

    def valley(c: float) -> np.ndarray:
        along = min(max((sliding - c) / (sliding - candidate.coordinate(0.18)), 0.0), 1.0)
        return np.r_[_split(base_x) + np.array([2.5, 0.0]) * along, base_x[2] + math.log(700.0 / 30.0) * along]

    def loss(p: np.ndarray) -> float:
        offset = np.r_[_split(p), p[2]] - valley(p[3])
        return float(np.interp(p[3], coefficients, floor)) + 10 * offset[0] ** 2 + 0.05 * offset[1] ** 2 + (
            offset[2] ** 2)

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, box, SPLIT_STEP, 5)
    assert candidate.value(refit.x[3]) == pytest.approx(0.18) and refit.loss < 0.03
    assert abs(_split(refit.x)[0] - valley(refit.x[3])[0]) < 0.05 and abs(refit.x[2] - math.log(700.0)) < 0.15


def test_a_profile_follows_a_valley_that_turns_back_to_the_base_law(tmp_path):
    """A sticky-floor fit compensated a floor of coefficient 0.3 with a weaker material; along the rungs the law
    that fits first moves away from the base fit (log tau_y / viscous stress down 1.5 at 1.0) and then back to it at
    the true coefficient. Extrapolating the first rungs' laws would start the last rung's search far off the valley."""
    candidate = CANDIDATES["floor_friction"]
    base_x = np.log([8.0, 2.5])
    null, target = candidate.nearest_null, candidate.coordinate(0.3)
    turn = candidate.coordinate(1.0)

    def valley(c: float) -> np.ndarray:
        away = (null - c) / (null - turn) if c >= turn else max(c - target, 0.0) / (turn - target)
        return _split(base_x) + np.array([0.0, -1.5]) * away

    def loss(p: np.ndarray) -> float:
        return 0.01 + 10 * _valley_loss(p, valley(p[2])) + 0.2 * (p[2] - target) ** 2

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert candidate.value(refit.x[2]) == pytest.approx(0.3)
    assert refit.loss < 0.02


def test_matched_law_keeps_the_flow_curve_over_the_band():
    band = (0.5, 20.0)
    rates = np.geomspace(*band, 50)
    tau_y, K = np.exp(matched_law(np.log([20.0, 1.5]), 0.5, 1.0, band))
    error = (tau_y + K * rates) / (20.0 + 1.5 * np.sqrt(rates)) - 1.0
    assert np.abs(error).max() < 0.03  # a Bingham line through a square-root curve, 20-27 Pa over the band
    assert matched_law(np.log([20.0, 1.5]), 0.5, 0.5, band) == pytest.approx(np.log([20.0, 1.5]))


def test_the_recheck_starts_from_the_winners_material_on_the_base_laws_flow_curve():
    law, box = Law(n=1.0, fitted_modulus=True), (np.log([0.5, 0.1, 30.0]), np.log([100.0, 50.0, 3000.0]))
    thinning = np.r_[np.log([20.0, 1.5, 200.0]), np.log(0.5)]
    start = recheck_start(CANDIDATES["shear_thinning"], thinning, law, (0.5, 20.0), box)
    # the Bingham line through the square-root curve over the band, the shear modulus kept
    assert start == pytest.approx(np.r_[matched_law(thinning[:2], 0.5, 1.0, (0.5, 20.0)), np.log(200.0)])
    # an effect that leaves the flow index: the refit's material as it is, within the box
    sliding = np.r_[np.log([200.0, 1.5, 200.0]), np.log(0.3)]
    assert recheck_start(CANDIDATES["floor_friction"], sliding, law, (0.5, 20.0), box) == pytest.approx(
        np.log([100.0, 1.5, 200.0]))


def test_a_shear_thinning_profile_starts_each_rung_on_the_last_rungs_flow_curve(tmp_path):
    """The data's flow curve is tau = 20 + 1.5 gamma_dot^0.5 over the shear rates 0.5-20 1/s, and the loss is the
    law's distance from it there. The base Bingham fit matches it closely; at n = 0.85 the base fit's K means a far
    lower stress, and a short refit from there ends above the base loss: the profile finds nothing past n = 0.85.
    Started on the last rung's flow curve, the profile reaches the truth's neighbourhood."""
    candidate = CANDIDATES["shear_thinning"]
    band = (0.5, 20.0)
    rates = np.geomspace(*band, 25)
    truth = 20.0 + 1.5 * np.sqrt(rates)

    def loss(p: np.ndarray) -> float:
        tau_y, K = np.exp(p[:2])
        stress = tau_y + K * rates ** candidate.value(p[2])
        return 0.005 + 0.05 * math.sqrt(float(np.mean(np.log(stress / truth) ** 2)))

    base_x = matched_law(np.log([20.0, 1.5]), 0.5, 1.0, band)
    box = (np.log([0.1, 0.01]), np.log([100.0, 100.0]))
    found = {}
    for name, given in (("without", None), ("with", band)):
        log = EvaluationLog(tmp_path / f"{name}.json", "key")
        found[name] = profile_refit(candidate, _logged(log, loss), log.best, base_x, box, SPLIT_STEP, 5, given)
    assert candidate.value(found["without"].x[2]) > 0.85
    assert 0.45 < candidate.value(found["with"].x[2]) < 0.6
    assert found["with"].loss < found["without"].loss - 5e-4


def test_a_profile_refits_halfway_between_its_best_rung_and_the_next(tmp_path):
    """Walls adhering with 8 Pa, between the rungs of 5 and 15 Pa: the profile climbs every rung, and the rung
    halfway between the best (5 Pa) and the next one out (8.7 Pa) comes within 10 % of the truth."""
    candidate = CANDIDATES["wall_adhesion"]
    base_x = np.log([8.0, 2.5])

    def loss(p: np.ndarray) -> float:
        return 0.01 + float(np.sum((p[:2] - base_x) ** 2)) + 2.0 * (p[2] - math.log(8.0)) ** 2

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert [value for value, _ in refit.profile] == pytest.approx([0.1, 5.0, math.sqrt(75.0), 15.0, 45.0, 135.0])
    assert candidate.value(refit.x[2]) == pytest.approx(math.sqrt(75.0)) and refit.loss < 0.03  # 5 Pa: 0.45


def test_a_profile_moves_the_law_far_along_the_valley_of_equal_stress(tmp_path):
    """Walls adhering with 20 Pa, which the base fit compensated with a weaker, more viscous law (tau_y 14, K 4.5
    Pa s against the truth's 20 and 1.5); the law that fits moves log-linearly with the adhesion's logarithm, its
    stress nearly fixed, the yield stress' share tripling. A simplex along log tau_y and log K (0.3 wide) ended at
    8.7 Pa, 14 times the truth's loss; one in the stress and its share reaches the truth's law."""
    candidate = CANDIDATES["wall_adhesion"]
    base_x, truth_x = np.log([14.0, 4.5]), np.log([20.0, 1.5])
    target = candidate.coordinate(20.0)

    def loss(p: np.ndarray) -> float:
        along = min(max(p[2] / target, 0.0), 1.0)
        return 0.004 + _valley_loss(p, _valley_towards(base_x, truth_x, along)) + 0.01 * (p[2] - target) ** 2

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert 15.0 - 1e-9 <= candidate.value(refit.x[2]) <= 26.0 and refit.loss < 2 * 0.004
    assert np.exp(refit.x[:2]) == pytest.approx([20.0, 1.5], rel=0.3)


def test_a_profile_brackets_the_stress_an_effect_takes_away(tmp_path):
    """Walls adhering with 8 Pa, which the base fit compensated with a stronger law (22.4, 1.87 against the truth's
    20, 1.5): at the first rung, 5 Pa, the law that fits has its stress a step below the base fit's, and the yield
    stress' share is steep enough that a simplex stepping the stress up first spends its evaluations climbing out
    (concealed adhesion 8 Pa: 0.0195 px at 5 Pa against 0.0060 a step of stress down; the profile stopped there and
    named nothing). Bracketing the stress a step down and up before the simplex reaches the truth's neighbourhood."""
    candidate = CANDIDATES["wall_adhesion"]
    base_x, truth_x = np.log([22.4, 1.87]), np.log([20.0, 1.5])
    target = candidate.coordinate(8.0)

    def loss(p: np.ndarray) -> float:
        valley = _valley_towards(base_x, truth_x, max(p[2] / target, 0.0))
        return 0.005 + _valley_loss(p, valley, 1.8, 0.1) + 0.008 * min((p[2] - target) ** 2, 1.0)

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert 5.0 <= candidate.value(refit.x[2]) <= 15.0 and refit.loss < 0.008


def test_a_thixotropy_profile_starts_from_the_intact_materials_yield_stress(tmp_path):
    """Concealed thixotropy 1.0 of a material of tau_y 20 Pa, which the base fit saw broken down (0.5 Pa): the law
    that fits at each breakdown rate has the yield stress that a plastic strain of 3.7 takes away restored, and a
    basin around the base fit's law, where thixotropy acts on a yield stress too small to matter, holds every short
    search started there. Started also from the base law with that breakdown restored, the profile reaches the truth's
    neighbourhood."""
    candidate = CANDIDATES["thixotropy"]
    base_x = np.log([0.5, 1.7])
    target = candidate.coordinate(1.0)

    def loss(p: np.ndarray) -> float:
        valley = base_x + np.array([3.7 * candidate.value(p[2]), 0.0])
        intact = 0.0068 + 0.02 * (p[2] - target) ** 2 + 0.005 * float(np.sum((p[:2] - valley) ** 2))
        return min(0.013 + 0.002 * float(np.sum((p[:2] - base_x) ** 2)), intact + 0.01 * (intact > 0.011))

    starts = candidate.rung_starts(base_x, 0.3, 1.0, None, base_x)
    assert np.allclose(starts, [base_x + np.array([strain, 0.0]) for strain in BREAKDOWN_STRAINS])
    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert 0.3 <= candidate.value(refit.x[2]) <= 3.0 and refit.loss < 0.009


@pytest.mark.parametrize("name", ["shear_thinning", "thixotropy", "floor_friction", "gravity_tilt"])
def test_a_refit_is_never_worse_than_the_base_fit_with_the_effect_at_its_null(tmp_path, name):
    """A loss that any amount of the effect worsens, on a rough law landscape whose best lies at the base fit: the
    profile climbs every rung (on each side) and keeps the effect's nearest null value and the base fit's loss."""
    candidate = CANDIDATES[name]
    base_x = np.log([8.0, 2.5])

    def loss(p: np.ndarray) -> float:
        law = float(np.sum((p[:2] - base_x) ** 2) + 0.05 * np.sum(np.abs(np.sin(40 * (p[:2] - base_x)))))
        return 0.02 + law + 0.5 * abs(p[2] - candidate.nearest_null)

    log = EvaluationLog(tmp_path / "log.json", "key")
    refit = profile_refit(candidate, _logged(log, loss), log.best, base_x, LAW_BOX, SPLIT_STEP, 5)
    assert refit.loss == pytest.approx(0.02) and refit.x[2] == candidate.nearest_null
    # each rung and one halfway to the first: three starts and the candidate's own, the line search, the simplex
    extra = len(candidate.rung_starts(base_x, 1.0, 1.0, None, base_x))
    per_rung = 3 + extra + 3 + LINE_EXPANSIONS + 5
    assert len(log.records) <= 1 + per_rung * sum(len(branch) + 1 for branch in candidate.rungs)


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
        for branch in candidate.rungs:  # outward from the null, inside the box
            coordinates = [candidate.nearest_null, *map(candidate.coordinate, branch)]
            assert all(low <= c <= high for c in coordinates)
            assert np.all(np.diff(coordinates) > 0) or np.all(np.diff(coordinates) < 0), candidate.name
        assert low <= candidate.nearest_null <= high
        if candidate.null != 0 or not candidate.log:
            null = candidate.coordinate(candidate.null)
            assert candidate.nearest_null == (null if low <= null <= high else high), candidate.name
        else:
            assert candidate.nearest_null == low
    _, sliding = Law(1.0, CANDIDATES["floor_friction"]).unpack(np.r_[x, math.log(0.3)])
    assert sliding.floor_friction == pytest.approx(0.3)
    _, tilted = Law(1.0, CANDIDATES["gravity_tilt"]).unpack(np.r_[x, 5.0])
    assert tilted.gravity_tilt == pytest.approx(math.radians(5.0))
    thinning, _ = Law(1.0, CANDIDATES["shear_thinning"]).unpack(np.r_[x, math.log(0.5)])
    assert thinning["n"] == pytest.approx(0.5)
    # the shear modulus, where fitted, follows the law and stays what it is under every effect
    assert Law(n=1.0, fitted_modulus=True).names == ("tau_y", "K", "mu")
    assert Law(candidate=CANDIDATES["air_drag"], fitted_modulus=True).names == ("tau_y", "K", "n", "mu", "air_drag")
    thinning, _ = Law(1.0, CANDIDATES["shear_thinning"], fitted_modulus=True).unpack(np.r_[x, math.log(400.0),
                                                                                            math.log(0.5)])
    assert thinning == pytest.approx({"tau_y": 8.0, "K": 2.0, "n": 0.5, "mu": 400.0})


def test_each_profile_starts_from_the_base_dam_break_but_where_the_floor_lets_the_material_leave_it(channel):
    """Every candidate at its box's weak end, in a channel of smooth walls on a sticky floor: the front within a
    thirtieth of a cell of the base model's, but for the sliding floors, whose contact laws let the material leave the
    floor (a Coulomb floor; a Navier floor, which also holds only the nodes at its face)."""
    smooth = channel((0.0, 0.05, 0.0, 0.04), walls="slip")
    scene = dam_break_scene(smooth, cells_per_height=6)
    law = {"tau_y": 5.0, "K": 0.5, "n": 1.0}

    def front_shift(candidate, value: float) -> float:  # at the end, in cells
        values, effects = candidate.apply(value, law, Effects())
        front = scene.rollout(HerschelBulkley(**values, mu=2e4, lam=2e4), 0.2, 0.05, effects).x[:, :, 0].max()
        return float(front - base) / scene.dx

    base = scene.rollout(HerschelBulkley(**law, mu=2e4, lam=2e4), 0.2, 0.05).x[:, :, 0].max()
    shifts = {c.name: front_shift(c, c.value(c.nearest_null)) for c in CANDIDATES.values()}
    assert {name for name, shift in shifts.items() if abs(shift) > 1 / 30} == {"floor_friction", "wall_slip"}
    assert 0 < shifts["floor_friction"] < 0.5 and 0 < shifts["wall_slip"] < 0.5
    assert front_shift(CANDIDATES["wall_adhesion"], 1.0) < -1 / 30  # a weak end of 1 Pa would hold the front back


def test_a_refits_first_simplex_is_as_wide_as_the_base_fits_interval():
    intervals = {"tau_y": (19.5, 20.5), "K": (2.0, 2.0 * math.exp(0.2)), "n": (0.2, 5.0)}
    steps = law_steps(("tau_y", "K", "n"), intervals, 0.3)
    assert steps == pytest.approx([MIN_LAW_STEP, 0.1, 0.3])  # the least (for 2.5 %), 0.1, the largest
