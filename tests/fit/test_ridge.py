"""The evaluated materials within the tolerance: their ranges follow a ridge of the loss where two parameters trade
against each other, against the analytic region of a quadratic loss."""

import numpy as np
import pytest

from rheo.fit.uncertainty import Interval, best_determined_stress, tolerated

MINIMUM = np.array([1.0, 0.5, -0.7])
RIDGE = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)  # log tau_y up, log K down: the flat direction
STIFF = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
FLOOR, TOLERANCE = 0.5, 0.1


def loss(points: np.ndarray, ridge_curvature: float) -> np.ndarray:
    d = points - MINIMUM
    return FLOOR + 0.5 * (ridge_curvature * (d @ RIDGE) ** 2 + 8.0 * (d @ STIFF) ** 2 + 2.0 * d[:, 2] ** 2)


def test_materials_within_the_tolerance_spread_along_the_ridge_as_far_as_the_quadratic_allows():
    points = MINIMUM + np.random.default_rng(1).uniform(-3.0, 3.0, (20000, 3))
    points = np.vstack([MINIMUM, points])
    found = tolerated(points, loss(points, 0.02), TOLERANCE)
    assert abs(found.direction @ RIDGE) == pytest.approx(1.0, abs=0.02)
    # along the ridge 0.5 c t^2 <= tolerance * floor: log tau_y within t / sqrt(2) (plus the stiff direction's share)
    hessian = 0.02 * np.outer(RIDGE, RIDGE) + 8.0 * np.outer(STIFF, STIFF) + np.diag([0.0, 0.0, 2.0])
    half = np.sqrt(2.0 * TOLERANCE * FLOOR * np.diag(np.linalg.inv(hessian)))
    assert np.all(found.ranges[:, 0] >= MINIMUM - half - 1e-9) and np.all(found.ranges[:, 1] <= MINIMUM + half + 1e-9)
    # random points reach most of the thin region's extent
    assert np.all(found.ranges[:, 1] - found.ranges[:, 0] > 0.75 * 2.0 * half)
    assert found.ridge and found.count == np.sum(loss(points, 0.02) <= (1 + TOLERANCE) * FLOOR)


def test_a_well_curved_loss_leaves_no_ridge():
    points = MINIMUM + np.random.default_rng(2).uniform(-1.0, 1.0, (5000, 3))
    points = np.vstack([MINIMUM, points])
    assert not tolerated(points, loss(points, 8.0), TOLERANCE).ridge


def test_a_material_evaluated_twice_counts_once():
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [3.0, 0.0, 0.0]])
    found = tolerated(points, np.array([1.0, 1.0, 1.05, 2.0]), TOLERANCE)
    assert found.count == 2 and found.ranges[0].tolist() == [0.0, 0.1]


def test_intervals_grow_to_the_materials_within_the_tolerance_along_a_ridge():
    points = MINIMUM + np.random.default_rng(3).uniform(-3.0, 3.0, (20000, 3))
    points = np.vstack([MINIMUM, points])
    found = tolerated(points, loss(points, 0.02), TOLERANCE)
    # the conditional profile along log tau_y alone: 0.5 (0.02 + 8) / 2 t^2 <= tolerance * floor
    half = np.sqrt(2.0 * TOLERANCE * FLOOR / (0.5 * 8.02))
    names = ("tau_y", "K", "n")
    conditional = {name: Interval(float(np.exp(m)), float(np.exp(m - half)), float(np.exp(m + half)))
                   for name, m in zip(names, MINIMUM, strict=True)}
    widened = found.widen(conditional, names)
    for k, name in enumerate(names):
        assert widened[name].value == conditional[name].value
        assert widened[name].low == pytest.approx(min(conditional[name].low, np.exp(found.ranges[k, 0])))
        assert widened[name].high == pytest.approx(max(conditional[name].high, np.exp(found.ranges[k, 1])))
    # along the ridge tau_y and K reach far beyond their conditional intervals; n does not trade with them
    assert widened["tau_y"].high / widened["tau_y"].low > 4 * conditional["tau_y"].high / conditional["tau_y"].low
    assert not widened["tau_y"].determined and conditional["tau_y"].determined


def test_an_end_that_a_material_within_the_tolerance_holds_at_the_box_is_open():
    points = np.array([[0.0, 0.0, 0.0], [-1.0, 0.5, 0.0], [0.3, -0.2, 0.1]])
    found = tolerated(points, np.array([1.0, 1.05, 1.5]), TOLERANCE)  # the third lies beyond the tolerance
    names = ("tau_y", "K", "n")
    narrow = {name: Interval(1.0, np.exp(-0.1), np.exp(0.1)) for name in names}
    widened = found.widen(narrow, names, (np.array([-1.0, -2.0, -2.0]), np.array([2.0, 0.5, 0.3])))
    assert widened["tau_y"].open == (True, False) and widened["tau_y"].low == pytest.approx(np.exp(-1.0))
    assert widened["K"].open == (False, True) and not widened["K"].determined
    assert widened["n"].open == (False, False)  # no material within the tolerance at n's box
    assert found.widen(narrow, names)["tau_y"].open == (False, False)  # no box given, no end known at it


def laws_through(stress: float, rate: float, indices: list[float], yield_stresses: list[float]) -> np.ndarray:
    """Herschel-Bulkley laws (tau_y, K, n) whose flow curves all pass through ``stress`` at ``rate``."""
    return np.array([[tau_y, (stress - tau_y) / rate**n, n] for tau_y, n in zip(yield_stresses, indices, strict=True)])


def test_laws_that_share_one_point_of_their_flow_curves_agree_best_there():
    laws = laws_through(20.0, 6.0, [0.5, 0.8, 1.0, 1.4], [3.0, 9.0, 14.0, 17.0])
    found = best_determined_stress(laws, (0.5, 30.0))
    assert found.rate == pytest.approx(6.0, rel=0.025)  # the rates sampled lie 2.2 % apart
    # there they all carry about the common stress (a sampled rate's, so off by up to the curves' slope times 2.2 %)
    assert (found.low, found.high) == pytest.approx((20.0, 20.0), rel=0.025) and found.high / found.low < 1.002
    # outside the band the laws spread more the further from their common point: the nearer end
    assert best_determined_stress(laws, (10.0, 30.0)).rate == pytest.approx(10.0)


def test_laws_of_fewer_than_three_flow_indices_say_nothing():
    laws = laws_through(20.0, 6.0, [0.5, 1.0, 1.0], [3.0, 14.0, 15.0])  # any two flow curves cross somewhere
    assert best_determined_stress(laws, (0.5, 30.0)) is None
    assert best_determined_stress(laws[:1], (0.5, 30.0)) is None
