"""The silhouette fit's search: the quadratic model of the loss, its tolerance region, the survey and simplex, holding
undetermined parameters, and replaying stored evaluations."""

import numpy as np
import pytest

from rheo.fit.search import (
    EvaluationLog,
    design_points,
    estimate,
    fit_quadratic,
    simplex_search,
    survey,
    tolerance_region,
)

RNG = np.random.default_rng(3)
H_TRUE = np.array([[4.0, 1.5, 0.0], [1.5, 2.0, -0.5], [0.0, -0.5, 1.0]])
G_TRUE = np.array([0.3, -0.2, 0.1])


def quadratic(d: np.ndarray) -> float:
    return 2.0 + G_TRUE @ d + 0.5 * d @ H_TRUE @ d


def test_quadratic_fit_recovers_an_exact_quadratic_from_the_design():
    points = design_points(np.zeros(3), 0.2, [0, 1, 2])
    assert len(points) == 1 + 6 + 6
    c, g, H = fit_quadratic(points, np.array([quadratic(p) for p in points]))
    assert c == pytest.approx(2.0) and np.allclose(g, G_TRUE) and np.allclose(H, H_TRUE)


def test_tolerance_region_is_the_projection_of_the_ellipsoid():
    threshold = 2.5
    region, covariance = tolerance_region(2.0, G_TRUE, H_TRUE, threshold)
    # brute force: the extent along each axis of the points with quadratic <= threshold
    d = RNG.uniform(-2.5, 2.5, size=(400_000, 3))
    values = 2.0 + d @ G_TRUE + 0.5 * np.einsum("ni,ij,nj->n", d, H_TRUE, d)
    inside = d[values <= threshold]
    for i, (low, high) in enumerate(region):
        assert low == pytest.approx(inside[:, i].min(), abs=0.03)
        assert high == pytest.approx(inside[:, i].max(), abs=0.03)
        assert 1.959964 * np.sqrt(covariance[i, i]) == pytest.approx((high - low) / 2)


def test_tolerance_region_is_unbounded_along_a_flat_direction():
    H = np.diag([2.0, 0.0, 1.0])
    region, _ = tolerance_region(1.0, np.zeros(3), H, 1.1)
    assert region[1] is None and region[0] is not None and region[2] is not None


def test_survey_and_simplex_find_the_minimum_of_a_curved_valley():
    target = np.log([1000.0, 50.0])

    def loss(x):  # a banana-shaped valley in log space, like the soft-and-strong / stiff-and-weak trade-off
        d = x - target
        return (d[0] - d[1] ** 2) ** 2 * 10 + d[1] ** 2 + 0.05

    def evaluate(x, phase):
        return loss(x)

    guess = np.log([100.0, 10.0])
    x, value = survey(evaluate, guess, np.log(30.0), 64)
    assert value < loss(guess)
    x, value = simplex_search(evaluate, x, 0.2, 300, "full", tolerance=1e-4)
    assert np.allclose(np.exp(x), [1000.0, 50.0], rtol=0.01)


def test_a_parameter_the_loss_ignores_is_held_at_its_guess_and_flagged():
    target = np.log([1000.0, 50.0, 2.0])

    def evaluate(x, phase):
        d = (x - target)[:2]  # the third parameter changes nothing
        return 0.1 + d @ np.array([[3.0, 1.0], [1.0, 2.0]]) @ d

    guess = np.log([300.0, 20.0, 7.0])
    box = (guess - np.log(30.0), guess + np.log(30.0))
    result = estimate(evaluate, guess, guess, ["a", "b", "c"], evaluations=400, step=0.2, design_step=0.2,
                      tolerance=0.1, box=box)
    assert result.held == ["c"]
    assert result.intervals["c"].value == pytest.approx(7.0) and not result.intervals["c"].determined
    for i, name in enumerate("ab"):
        interval = interval_of = result.intervals[name]
        assert interval.determined and interval_of.low < np.exp(target[i]) < interval.high
        assert interval.value == pytest.approx(np.exp(target[i]), rel=0.02)
    # 95 % of the region where the loss is within 10 % of its minimum: along a alone d = sqrt(0.01 / 2.6)
    half = np.log(result.intervals["a"].high / result.intervals["a"].value)
    assert half == pytest.approx(np.sqrt(2 * 0.01 * np.linalg.inv([[6.0, 2.0], [2.0, 4.0]])[0, 0]), rel=0.1)


def test_an_interrupted_search_replays_its_stored_evaluations(tmp_path):
    calls = []

    def loss(x):
        calls.append(x)
        return float(np.sum((x - 1.0) ** 2))

    class Interrupt(Exception):
        pass

    def interrupted(x):
        if len(calls) == 25:
            raise Interrupt
        return loss(x)

    path = tmp_path / "evaluations.json"
    first = EvaluationLog(path, "key")
    with pytest.raises(Interrupt):
        simplex_search(lambda x, p: first.evaluate(interrupted, x, p), np.zeros(2), 0.2, 60, "full")
    assert len(first.records) == 25
    calls.clear()
    resumed = EvaluationLog(path, "key")
    x_resumed, _ = simplex_search(lambda x, p: resumed.evaluate(loss, x, p), np.zeros(2), 0.2, 60, "full")
    calls_after_resume = len(calls)
    calls.clear()
    fresh = EvaluationLog(tmp_path / "other.json", "key")
    x_fresh, _ = simplex_search(lambda x, p: fresh.evaluate(loss, x, p), np.zeros(2), 0.2, 60, "full")
    assert np.array_equal(x_resumed, x_fresh)
    assert calls_after_resume == len(calls) - 25  # the first 25 came from the file
    assert len(EvaluationLog(path, "other key").records) == 0  # other inputs: nothing replayed
