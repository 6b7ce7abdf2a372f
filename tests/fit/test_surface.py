"""The quadratic surface of the squared loss: its fit against exact quadratics, its trust-region step against a
brute-force search on the sphere, its tolerance region against the analytic ellipsoid and a dense sampling, and the
refinement's estimate on a rough, flat valley like the silhouette loss's."""

import json

import numpy as np
import pytest

from rheo.fit.search import EvaluationLog
from rheo.fit.surface import Quadratic, composite_design, fit_quadratic, refine

RNG = np.random.default_rng(4)
HESSIAN = np.array([[4.0, 1.5, 0.3], [1.5, 2.0, -0.4], [0.3, -0.4, 1.0]])
GRADIENT = np.array([0.5, -1.0, 0.2])
CENTRE = np.array([0.1, -0.2, 0.3])


def exact(points: np.ndarray) -> np.ndarray:
    d = points - CENTRE
    return 2.0 + d @ GRADIENT + 0.5 * np.einsum("ni,ij,nj->n", d, HESSIAN, d)


def test_a_quadratic_is_recovered_exactly_from_a_composite_design():
    design = composite_design(CENTRE + 0.05, 0.3)
    assert design.shape == (1 + 8 + 6, 3)
    surface = fit_quadratic(design, exact(design), CENTRE)
    assert surface.value == pytest.approx(2.0) and np.allclose(surface.gradient, GRADIENT)
    assert np.allclose(surface.hessian, HESSIAN)
    others = RNG.normal(size=(20, 3))
    assert np.allclose(surface(others), exact(others))


def test_too_few_points_for_a_quadratic_is_an_error():
    with pytest.raises(ValueError, match="needs 10 points"):
        fit_quadratic(np.zeros((9, 3)), np.zeros(9), CENTRE)


@pytest.mark.parametrize(("hessian", "gradient"), [(HESSIAN, GRADIENT), (np.diag([2.0, -1.0, 0.5]), GRADIENT),
                                                  (np.diag([2.0, -1.0, 0.5]), GRADIENT * [1.0, 0.0, 1.0])],
                         ids=["convex", "saddle", "saddle, gradient normal to its lowest curvature"])
@pytest.mark.parametrize("radius", [0.05, 0.3, 5.0])
def test_the_lowest_point_within_a_radius_is_the_lowest_of_the_sphere_and_the_ball(hessian, gradient, radius):
    surface = Quadratic(CENTRE, 1.0, gradient, hessian)
    lowest = surface.lowest_within(radius)
    assert np.linalg.norm(lowest - CENTRE) <= radius * (1 + 1e-9)
    directions = RNG.normal(size=(200000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    ball = CENTRE + radius * directions * RNG.uniform(0, 1, (len(directions), 1)) ** (1 / 3)
    sphere = CENTRE + radius * directions
    brute = min(surface(ball).min(), surface(sphere).min())
    assert surface(lowest)[0] <= brute + 1e-6 * max(1.0, abs(brute))


def test_the_tolerance_region_is_the_shadow_of_the_ellipsoid_on_each_axis():
    """Loss sqrt(floor^2 + d.A.d): within a relative tolerance t where d.A.d <= ((1 + t)^2 - 1) floor^2."""
    floor, tolerance, minimum = 0.5, 0.08, np.array([1.0, 0.4, -0.6])
    design = composite_design(minimum + 0.1, 0.4)
    losses = np.sqrt(floor**2 + np.einsum("ni,ij,nj->n", design - minimum, HESSIAN, design - minimum))
    surface = fit_quadratic(design, losses**2, minimum + 0.1)
    extents, open_ends = surface.extents(tolerance, 1.0, minimum)
    assert surface.convex and not open_ends.any() and np.allclose(extents.mean(axis=1), minimum)
    half = np.sqrt(((1 + tolerance) ** 2 - 1) * floor**2 * np.diag(np.linalg.inv(HESSIAN)))
    assert np.allclose(extents, np.c_[minimum - half, minimum + half])
    samples = minimum + RNG.uniform(-0.5, 0.5, (400000, 3))
    d = samples - minimum
    inside = samples[np.sqrt(floor**2 + np.einsum("ni,ij,nj->n", d, HESSIAN, d)) <= (1 + tolerance) * floor]
    assert np.allclose(extents[:, 0], inside.min(axis=0), atol=0.01)
    assert np.allclose(extents[:, 1], inside.max(axis=0), atol=0.01)


@pytest.mark.parametrize("curvature", [0.0, -0.02, 0.01], ids=["flat", "saddle", "longer than the reach"])
def test_a_region_past_the_surfaces_reach_is_sampled_within_it_and_its_open_ends_said(curvature):
    """A valley along the first axis that does not close (or closes past the reach): the region is the valley's
    part within the reach, its ends along the valley are open, those across it closed."""
    reach, tolerance = 1.0, 0.1
    surface = Quadratic(np.zeros(3), 0.04, np.zeros(3), np.diag([curvature, 8.0, 2.0]))
    extents, open_ends = surface.extents(tolerance, reach, np.zeros(3))
    samples = RNG.normal(size=(400000, 3))
    samples *= reach * RNG.uniform(0, 1, (len(samples), 1)) ** (1 / 3) / np.linalg.norm(samples, axis=1)[:, None]
    values = surface(samples)
    inside = samples[values <= (1 + tolerance) ** 2 * surface(np.zeros(3))[0]]  # of the estimate's loss
    assert np.allclose(extents, np.c_[inside.min(axis=0), inside.max(axis=0)], atol=0.03)
    assert open_ends.tolist() == [[True, True], [False, False], [False, False]]
    assert extents[0, 1] - extents[0, 0] > 1.9 * reach


def test_refinement_finds_the_floor_of_a_rough_flat_valley_and_its_tolerance_region():
    """A valley 8 times longer than wide (tolerance half-widths 0.45 and 0.06 log units at 8 %, as Lotion's tau_y
    and n) whose loss is rough at the 1 % level (pixel edges): from a point far along it, the rounds move to the
    minimum."""
    minimum, floor, tolerance = np.array([1.0, 1.5, -0.6]), 0.03, 0.08
    valley = np.array([1.0, -1.0, 0.3]) / np.linalg.norm([1.0, -1.0, 0.3])
    across = np.linalg.qr(np.c_[valley, RNG.normal(size=(3, 2))])[0][:, 1:]
    depth = ((1 + tolerance) ** 2 - 1) * floor**2  # of the squared loss at the tolerance
    hessian = depth / 0.45**2 * np.outer(valley, valley) + depth / 0.06**2 * across @ across.T
    evaluated_points, evaluated_losses = [], []

    def evaluate_many(points):
        points = np.array(points)
        d = points - minimum
        rough = 1.0 + 0.01 * np.sin(40.0 * points @ np.array([1.0, 2.0, 3.0])) * np.cos(37.0 * points[:, 0])
        losses = np.sqrt(floor**2 + np.einsum("ni,ij,nj->n", d, hessian, d)) * rough
        evaluated_points.extend(points)
        evaluated_losses.extend(losses)
        return list(losses)

    box = (minimum - 3.0, minimum + 3.0)
    start = minimum + 0.8 * valley
    found = refine(evaluate_many, start, 0.25, box, lambda: (np.array(evaluated_points), np.array(evaluated_losses)))
    assert 2 <= found.rounds <= 3 and found.converged
    assert np.linalg.norm(found.x - minimum) < 0.05
    # the intervals: the tolerance region's shadow, 0.45 along the valley
    half = np.sqrt(depth * np.diag(np.linalg.inv(hessian)))
    extents, open_ends = found.surface.extents(tolerance, found.reach, found.x)
    assert not open_ends.any() and np.allclose(extents[:, 1] - extents[:, 0], 2.0 * half, rtol=0.1)


@pytest.mark.parametrize("flat, rounds", [(0.0, 3), (0.02, 1)])
def test_refinement_stops_where_the_valley_floor_is_flat_at_the_tolerances_scale(flat, rounds):
    """A valley whose floor falls by 0.2 % per log unit: each surface's lowest point lies on the edge of its design,
    so the rounds would walk along the floor as long as they are allowed; a surface that promises less than the
    fraction ``flat`` ends them at once (as flat, not converged)."""
    floor, evaluated_points, evaluated_losses = 0.03, [], []

    def evaluate_many(points):
        points = np.array(points)
        losses = floor * np.sqrt(1.0 - 0.004 * points[:, 0] + 4.0 * (points[:, 1] ** 2 + points[:, 2] ** 2))
        evaluated_points.extend(points)
        evaluated_losses.extend(losses)
        return list(losses)

    found = refine(evaluate_many, np.zeros(3), 0.25, (np.full(3, -5.0), np.full(3, 5.0)),
                   lambda: (np.array(evaluated_points), np.array(evaluated_losses)), flat=flat)
    assert found.rounds == rounds and found.flat == (flat > 0) and not found.converged
    assert type(found.flat) is bool  # written to params.json
    assert found.x[0] == pytest.approx(rounds * np.sqrt(3) * 0.25, abs=0.01)  # a full radius along the floor each


def test_an_interrupted_refinement_replays_its_stored_evaluations_and_ends_where_an_uninterrupted_one_does(tmp_path):
    """The surface of a resumed fit sees only the evaluations replayed so far, not those the log holds from later
    rounds: it takes the same steps, and evaluates nothing the first run had."""
    minimum = np.array([0.3, -0.2, 0.1])
    calls = []

    def losses(points, stop_after=None):
        if stop_after is not None and len(calls) >= stop_after:
            raise KeyboardInterrupt
        calls.extend(points)
        return [float(np.sqrt(1e-4 + (p - minimum) @ HESSIAN @ (p - minimum) + 3.0 * np.sum((p - minimum) ** 2) ** 2))
                for p in points]  # not quadratic: different evaluations give different surfaces

    def run(log, stop_after=None):
        return refine(lambda points: log.evaluate_many(lambda p: losses(p, stop_after), points, "surface"),
                      minimum + 0.6, 0.2, (minimum - 3.0, minimum + 3.0), log.seen)

    whole = run(EvaluationLog(tmp_path / "whole.json", "key"))
    evaluations = len(calls)
    calls.clear()
    with pytest.raises(KeyboardInterrupt):
        run(EvaluationLog(tmp_path / "cut.json", "key"), stop_after=20)
    interrupted = len(calls)
    log = EvaluationLog(tmp_path / "cut.json", "key")
    resumed = run(log)
    assert np.array_equal(resumed.x, whole.x) and resumed.rounds == whole.rounds
    assert len(calls) == evaluations  # nothing evaluated twice
    # each run's share of the evaluations is kept with them
    assert [r["evaluations"] for r in log.runs] == [interrupted, evaluations - interrupted]
    assert json.loads(log.path.read_text())["runs"] == log.runs
