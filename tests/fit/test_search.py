"""The silhouette fit's search: the survey and simplex, searches from several starts, the estimate and its intervals
against an exact valley, holding undetermined parameters, and replaying stored evaluations."""

import json
import threading
import time
from functools import partial

import numpy as np
import pytest

from rheo.fit.search import EvaluationLog, estimate, simplex_search, start_searches, survey_points


def test_survey_and_simplex_find_the_minimum_of_a_curved_valley():
    target = np.log([1000.0, 50.0])

    def loss(x):  # a banana-shaped valley in log space, like the soft-and-strong / stiff-and-weak trade-off
        d = x - target
        return (d[0] - d[1] ** 2) ** 2 * 10 + d[1] ** 2 + 0.05

    def evaluate(x, phase):
        return loss(x)

    guess = np.log([100.0, 10.0])
    points = survey_points(guess, np.log(30.0), 64)
    assert np.array_equal(points[0], guess) and np.all(np.abs(points - guess) <= np.log(30.0))
    values = [loss(x) for x in points]
    assert min(values) < loss(guess)
    x, _ = simplex_search(evaluate, points[int(np.argmin(values))], 0.2, 300, "full", tolerance=1e-4)
    assert np.allclose(np.exp(x), [1000.0, 50.0], rtol=0.01)


def test_searches_from_several_starts_find_the_deeper_of_two_basins():
    shallow, deep = np.log([30.0, 3.0]), np.log([3000.0, 30.0])
    phases = []

    def evaluate(x, phase):  # two basins; the first start lies in the shallower one
        phases.append(phase)
        return min(0.11 + np.sum((x - shallow) ** 2), 0.10 + np.sum((x - deep) ** 2))

    starts = [shallow + 0.5, deep - 1.0]
    x, _ = simplex_search(evaluate, starts[0], 0.5, 200, "full", tolerance=1e-4)
    assert np.allclose(x, shallow, atol=0.01)  # one start alone stays in its basin
    phases.clear()
    x, value = start_searches(evaluate, starts, 0.5, 100)
    assert np.allclose(x, deep, atol=0.01) and value == pytest.approx(0.10, abs=1e-4)
    assert phases.count("start 1") <= 100 and phases.count("start 2") <= 100


def test_searches_side_by_side_run_at_once_and_find_what_they_find_one_after_another(tmp_path):
    shallow, deep = np.log([30.0, 3.0]), np.log([3000.0, 30.0])
    in_flight, most = [0], [0]
    lock = threading.Lock()

    def loss(x):
        return min(0.11 + np.sum((x - shallow) ** 2), 0.10 + np.sum((x - deep) ** 2))

    def slow(points):  # hands its work elsewhere and waits, as the worker processes do
        with lock:
            in_flight[0] += 1
            most[0] = max(most[0], in_flight[0])
        time.sleep(0.002)
        with lock:
            in_flight[0] -= 1
        return [loss(x) for x in points]

    starts = [shallow + 0.5, deep - 1.0]
    results, stored = [], []
    for side_by_side in (False, True):
        log = EvaluationLog(tmp_path / f"{side_by_side}.json", "key")
        evaluate = partial(lambda x, phase, log: log.evaluate_many(slow, [x], phase)[0], log=log)
        results.append(start_searches(evaluate, starts, 0.5, 40, side_by_side=side_by_side))
        assert most[0] == (2 if side_by_side else 1)
        stored.append(sorted(json.dumps(r) for r in json.loads(log.path.read_text())["records"]))
    (x0, v0), (x1, v1) = results
    assert np.array_equal(x0, x1) and v0 == v1 and np.allclose(x1, deep, atol=0.05)
    assert stored[0] == stored[1]  # the same evaluations, every one stored


FLOOR = 0.1  # the loss's floor: the fit model's own error


def valley_estimate(tmp_path, ignored: bool):
    """The estimate on a loss sqrt(floor^2 + d.A.d) of (a, b) (and c, which it ignores), with a log of every
    evaluation; guess and start away from the minimum."""
    target = np.log([1000.0, 50.0, 2.0])
    curvature = np.array([[3.0, 2.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 0.0 if ignored else 1.5]])

    def losses(points):
        return [float(np.sqrt(FLOOR**2 + (x - target) @ curvature @ (x - target))) for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    guess = np.log([300.0, 20.0, 7.0])
    box = (guess - np.log(30.0), guess + np.log(30.0))
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [guess], ["a", "b", "c"],
                      seen=log.seen, evaluations=200, start_step=0.5, half_width=0.25, rounds=3, tolerance=0.1,
                      box=box, guess=guess)
    return result, target, curvature, log


def test_the_estimate_is_the_valleys_floor_and_its_intervals_the_shadow_of_the_tolerance_region(tmp_path):
    result, target, curvature, _ = valley_estimate(tmp_path, ignored=False)
    assert result.held == [] and np.allclose(result.log_values, target, atol=1e-6)
    assert result.loss == pytest.approx(FLOOR)
    # loss <= 1.1 floor where d.A.d <= 0.21 floor^2: an ellipsoid whose shadow on axis i is
    # +- sqrt(0.21 floor^2 A^-1_ii), wider than the profile through the optimum (+- sqrt(0.21 floor^2 / A_ii))
    # where a and b trade against each other
    half = np.sqrt(0.21 * FLOOR**2 * np.diag(np.linalg.inv(curvature)))
    for i, name in enumerate("abc"):
        interval = result.intervals[name]
        assert interval.determined and interval.open == (False, False)
        assert np.log([interval.low, interval.high]) == pytest.approx([target[i] - half[i], target[i] + half[i]],
                                                                      abs=1e-6)
    assert half[0] > 1.7 * np.sqrt(0.21 * FLOOR**2 / curvature[0, 0])


def test_the_estimate_never_loses_more_than_the_best_material_evaluated(tmp_path):
    """A smooth valley of floor 0.1 made rough (+-0.01, as pixel edges make the silhouette loss): the surface's
    lowest point lies near the valley's floor but on a bump, within the tolerance of the best material evaluated
    yet above it. The material that reproduces the recording best is the estimate."""
    target = np.log([1000.0, 50.0])
    start = np.log([700.0, 60.0])

    def losses(points):
        return [float(np.sqrt(FLOOR**2 + np.sum((x - target) ** 2)) + 0.01 * np.sin(40 * x[0]) * np.sin(40 * x[1]))
                for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    box = (start - np.log(30.0), start + np.log(30.0))
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [start], ["a", "b"],
                      seen=log.seen, evaluations=60, start_step=0.5, half_width=0.25, rounds=3, tolerance=0.1,
                      box=box)
    best = min(log.records, key=lambda r: r["loss"])
    surface = min(r["loss"] for r in log.records if r["phase"] == "estimate")
    assert best["loss"] < surface < 1.1 * best["loss"]
    assert result.loss == best["loss"] and np.array_equal(result.log_values, best["x"])


def test_a_lower_material_found_walking_the_interval_ends_becomes_the_estimate(tmp_path):
    """A valley that goes on descending past the one design round's reach: walking the interval ends along its
    floor evaluates materials below the surface's estimate, and the lowest of them is the estimate."""
    start = np.log([700.0, 60.0])

    def losses(points):
        return [float(0.1 + 10.0 * (d[0] - d[1]) ** 2 + 0.02 * np.exp(-(d[0] + d[1]))) for d in (points - start)]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    result = estimate(lambda points, phase: log.evaluate_many(losses, np.array(points), phase), [start], ["a", "b"],
                      seen=log.seen, evaluations=8, start_step=0.1, half_width=0.1, rounds=1, tolerance=0.1,
                      box=(start - 3.0, start + 3.0))
    best = min(log.records, key=lambda r: r["loss"])
    assert best["phase"] == "surface" and best["loss"] < min(r["loss"] for r in log.records if r["phase"] == "estimate")
    assert result.loss == best["loss"] and np.array_equal(result.log_values, best["x"])
    for name, value in zip(["a", "b"], np.exp(best["x"]), strict=True):
        assert result.intervals[name].low <= value <= result.intervals[name].high
        assert result.intervals[name].value == pytest.approx(value)


def test_a_parameter_the_loss_ignores_is_held_at_its_guess_and_flagged(tmp_path):
    result, target, curvature, log = valley_estimate(tmp_path, ignored=True)
    assert result.held == ["c"]
    c = result.intervals["c"]
    assert c.value == pytest.approx(7.0) and not c.determined and c.open == (True, True)
    assert np.allclose(result.log_values[:2], target[:2], atol=1e-6) and result.log_values[2] == np.log(7.0)
    half = np.sqrt(0.21 * FLOOR**2 * np.diag(np.linalg.inv(curvature[:2, :2])))
    for i, name in enumerate("ab"):
        interval = result.intervals[name]
        assert interval.determined and interval.low < np.exp(target[i]) < interval.high
        assert np.log(interval.high / interval.low) / 2 == pytest.approx(half[i], rel=1e-6)
    # a simplex search and the surface of a and b went on with c at its guess
    for phase in ("start, held", "surface, held"):
        held = [r for r in log.records if r["phase"] == phase]
        assert held and all(r["x"][2] == np.log(7.0) for r in held)


def test_a_guess_beyond_an_open_end_is_not_held_where_the_loss_there_is_worse(tmp_path):
    target = np.log([1000.0, 50.0, 2.0])

    def losses(points):  # flat along c within 3.5 log units of its target (past the ends' walk), steep beyond
        return [float(np.sqrt(FLOOR**2 + 3.0 * np.sum((x[:2] - target[:2]) ** 2)
                              + 10.0 * max(abs(x[2] - target[2]) - 3.5, 0.0) ** 2)) for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    guess = target + np.array([0.5, -0.5, 3.8])
    box = (target - 5.0, target + 5.0)
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [target + 0.05], ["a", "b", "c"],
                      seen=log.seen, evaluations=100, start_step=0.1, half_width=0.25, rounds=3, tolerance=0.1,
                      box=box, guess=guess)
    assert result.intervals["c"].open == (True, True)  # so the guess might lie in the region within the tolerance
    assert any(r["phase"] == "surface, held" for r in log.records)  # it was tried there
    assert result.held == [] and result.loss == pytest.approx(FLOOR, rel=1e-3)  # and given up: it loses more
    assert abs(result.log_values[2] - target[2]) < 3.5


def test_an_interrupted_search_replays_its_stored_evaluations(tmp_path):
    calls = []

    def loss(x):
        calls.append(x)
        time.sleep(0.001)
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
    assert resumed.earlier_seconds >= 0.024  # the interrupted run's time up to its 25th evaluation is carried on
    x_resumed, _ = simplex_search(lambda x, p: resumed.evaluate(loss, x, p), np.zeros(2), 0.2, 60, "full")
    calls_after_resume = len(calls)
    calls.clear()
    fresh = EvaluationLog(tmp_path / "other.json", "key")
    x_fresh, _ = simplex_search(lambda x, p: fresh.evaluate(loss, x, p), np.zeros(2), 0.2, 60, "full")
    assert np.array_equal(x_resumed, x_fresh)
    assert calls_after_resume == len(calls) - 25  # the first 25 came from the file
    assert len(EvaluationLog(path, "other key").records) == 0  # other inputs: nothing replayed


def test_a_store_written_before_runs_were_kept_resumes_with_its_time_and_evaluations(tmp_path):
    path = tmp_path / "evaluations.json"
    records = [{"phase": "full", "x": [0.0, 0.0], "loss": 2.0}, {"phase": "full", "x": [0.2, 0.0], "loss": 1.64}]
    path.write_text(json.dumps({"key": "key", "records": records, "seconds": 120.0}))  # the older form
    resumed = EvaluationLog(path, "key")
    assert resumed.evaluate(lambda x: pytest.fail("a stored point was evaluated again"), np.zeros(2), "full") == 2.0
    resumed.evaluate(lambda x: float(np.sum((x - 1.0) ** 2)), np.ones(2), "full")
    stored = json.loads(path.read_text())
    assert [(r["started"] is None, r["evaluations"]) for r in stored["runs"]] == [(True, 2), (False, 1)]
    assert stored["runtime_s"] == pytest.approx(120.0 + stored["runs"][1]["seconds"])


def test_a_store_whose_runs_list_only_the_later_ones_keeps_the_earlier_evaluations_and_time(tmp_path):
    path = tmp_path / "evaluations.json"
    records = [{"phase": "full", "x": [float(i), 0.0], "loss": 1.0} for i in range(3)]
    later = {"started": "2026-11-30T03:45:00+00:00", "evaluations": 1, "seconds": 100.0}
    path.write_text(json.dumps({"key": "key", "records": records, "seconds": 300.0, "runs": [later]}))
    runs = EvaluationLog(path, "key").runs
    assert [(r["started"], r["evaluations"], r["seconds"]) for r in runs[:2]] == [(None, 2, 200.0),
                                                                                  (later["started"], 1, 100.0)]


def test_the_simplex_stays_inside_its_box():
    seen = []

    def evaluate(x, phase):
        seen.append(x.copy())
        return float(np.sum((x - 3.0) ** 2))  # the minimum lies outside the box

    box = (np.zeros(2), np.ones(2))
    x, _ = simplex_search(evaluate, np.full(2, 0.5), 0.2, 200, "full", tolerance=1e-4, box=box)
    assert np.all((np.array(seen) >= 0.0) & (np.array(seen) <= 1.0))
    assert np.allclose(x, 1.0, atol=1e-3)


def test_points_evaluated_together_are_stored_and_not_evaluated_again(tmp_path):
    batches = []

    def objective(points):
        batches.append(len(points))
        return [float(np.sum(x**2)) for x in points]

    points = [np.array([i, 1.0]) for i in range(4)]
    log = EvaluationLog(tmp_path / "evaluations.json", "key")
    assert log.evaluate_many(objective, points[:3], "survey") == [1.0, 2.0, 5.0]
    again = EvaluationLog(tmp_path / "evaluations.json", "key")
    assert again.evaluate_many(objective, points, "survey") == [1.0, 2.0, 5.0, 10.0]
    assert batches == [3, 1]  # only the new point is evaluated after the restart


@pytest.mark.parametrize("one_objective, batches_expected", [(False, [2, 2]), (True, [2, 1])])
def test_a_point_stored_by_one_phase_serves_another_when_they_share_the_objective(tmp_path, one_objective,
                                                                                  batches_expected):
    batches = []

    def objective(points):
        batches.append(len(points))
        return [float(np.sum(x**2)) for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=one_objective)
    log.evaluate_many(objective, [np.array([1.0, 2.0]), np.array([0.0, 1.0])], "survey")
    assert log.evaluate_many(objective, [np.array([1.0, 2.0]), np.array([3.0, 0.0])], "start 1") == [5.0, 9.0]
    assert batches == batches_expected
    resumed = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=one_objective)
    assert resumed.evaluate_many(objective, [np.array([3.0, 0.0])], "profile") == [9.0]
    assert batches == batches_expected + ([] if one_objective else [1])


def test_interval_ends_walk_out_to_where_the_loss_itself_leaves_the_tolerance(tmp_path):
    """Along c the loss curves near the minimum, then levels off below the tolerance (a viscosity too low to show)
    until 1.5 log units out: the quadratic surface puts c's ends at +-0.46, the walk and its bisections find the
    level's edge."""
    target = np.log([1000.0, 50.0, 2.0])

    def losses(points):
        def along_c(d: float) -> float:
            return min(d * d, 0.15) if abs(d) < 1.5 else 10.0
        return [float(FLOOR * np.sqrt(1.0 + 30.0 * np.sum((x[:2] - target[:2]) ** 2) + along_c(x[2] - target[2])))
                for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [target + 0.05], ["a", "b", "c"],
                      seen=log.seen, evaluations=100, start_step=0.1, half_width=0.25, rounds=3, tolerance=0.1,
                      box=(target - 5.0, target + 5.0))
    c = result.intervals["c"]
    assert np.log([c.low, c.high]) - target[2] == pytest.approx([-1.5, 1.5], abs=0.25 / 4)  # a step, halved twice
    assert c.open == (False, False)


def test_interval_ends_walk_along_the_valley_where_two_parameters_trade(tmp_path):
    """a and b trade against each other (the loss depends on a - b steeply, on a + b only within 1.5 log units of
    the optimum, and there little): the region within the tolerance reaches a and b +- 1.5 / sqrt(2) = 1.06 along the
    valley's floor. Walked along their axes, with the other held at the estimate, the ends stop at once (+-0.33)."""
    target = np.log([1000.0, 1000.0, 50.0])

    def losses(points):
        values = []
        for x in points:
            d = x - target
            across, along = (d[0] - d[1]) / np.sqrt(2), (d[0] + d[1]) / np.sqrt(2)
            floor = min(along**2, 0.15) if abs(along) < 1.5 else 10.0
            values.append(float(FLOOR * np.sqrt(1.0 + 30.0 * (across**2 + d[2] ** 2) + floor)))
        return values

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [target + 0.05], ["a", "b", "c"],
                      seen=log.seen, evaluations=100, start_step=0.1, half_width=0.25, rounds=3, tolerance=0.1,
                      box=(target - 5.0, target + 5.0))
    for i, name in enumerate("ab"):
        interval = result.intervals[name]
        assert np.log([interval.low, interval.high]) - target[i] == pytest.approx([-1.06, 1.06], abs=0.15)


def test_an_interval_end_at_the_box_that_the_loss_there_leaves_is_bisected_back_from_the_estimate(tmp_path):
    """Along c the loss is nearly flat (the surface's region reaches past the box) up to a cliff 0.5 log units below
    the optimum, inside the box's end at 0.6: the probe at the box loses more than the tolerance, so the end lies
    between the estimate and the box, not at the box."""
    target = np.log([1000.0, 50.0, 2.0])

    def losses(points):
        return [float(FLOOR * np.sqrt(1.0 + 30.0 * np.sum((x[:2] - target[:2]) ** 2) + 0.01 * (x[2] - target[2]) ** 2)
                      if x[2] - target[2] > -0.5 else 10.0) for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    box = (target - np.array([5.0, 5.0, 0.6]), target + 5.0)
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [target + 0.05], ["a", "b", "c"],
                      seen=log.seen, evaluations=100, start_step=0.1, half_width=0.25, rounds=3, tolerance=0.1,
                      box=box)
    c = result.intervals["c"]
    assert -0.5 <= np.log(c.low) - target[2] <= -0.5 + 0.6 / 4  # bisected twice between the estimate and the box
    assert c.open == (False, True)  # the high end goes on past the walk's reach


def test_a_flow_index_is_determined_only_within_a_narrower_span_than_a_stress(tmp_path):
    """tau_y and n with the same curvature get the same interval, a factor of about 3.7 wide: enough to pin a stress,
    not to tell a thinning flow index from 1."""
    target = np.log([10.0, 0.8])

    def losses(points):  # within the 10 % tolerance where |d| <= sqrt(0.21 FLOOR^2 / 0.005) = 0.65 log units
        return [float(np.sqrt(FLOOR**2 + 0.005 * np.sum((x - target) ** 2))) for x in points]

    log = EvaluationLog(tmp_path / "evaluations.json", "key", one_objective=True)
    box = (target - 3.0, target + 3.0)
    result = estimate(lambda points, phase: log.evaluate_many(losses, points, phase), [target + 0.2], ["tau_y", "n"],
                      seen=log.seen, evaluations=60, start_step=0.3, half_width=0.25, rounds=3, tolerance=0.1,
                      box=box)
    tau_y, n = result.intervals["tau_y"], result.intervals["n"]
    assert tau_y.high / tau_y.low == pytest.approx(np.exp(2 * np.sqrt(0.21 * FLOOR**2 / 0.005)), rel=0.05)
    assert n.high / n.low == pytest.approx(tau_y.high / tau_y.low, rel=1e-3)
    assert tau_y.determined and not n.determined
