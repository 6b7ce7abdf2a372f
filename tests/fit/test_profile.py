"""A parameter's interval grown to its profile: where the lowest loss at each value of the parameter stays within
the tolerance, against the closed-form ends of a profile quadratic in the parameter's logarithm."""

import json

import numpy as np
import pytest

from rheo.fit.uncertainty import Interval, grown_to_profile

FLOOR, CURVATURE, TOLERANCE, BEST = 0.02, 2.0, 0.08, 0.8


def profile(values: np.ndarray) -> np.ndarray:
    return FLOOR * (1.0 + CURVATURE * np.log(values / BEST) ** 2)


# the profile is within (1 + TOLERANCE) * FLOOR for |log(n / BEST)| <= sqrt(TOLERANCE / CURVATURE)
REACH = np.sqrt(TOLERANCE / CURVATURE)
LEVEL = (1.0 + TOLERANCE) * FLOOR
NARROW = Interval(BEST, 0.95 * BEST, 1.05 * BEST)


def test_on_a_fine_row_the_ends_are_where_the_profile_crosses_the_level():
    values = np.geomspace(0.3, 2.0, 81)
    grown = grown_to_profile(NARROW, values, profile(values), LEVEL)
    assert grown.low == pytest.approx(BEST * np.exp(-REACH), rel=2e-3)
    assert grown.high == pytest.approx(BEST * np.exp(REACH), rel=2e-3)
    assert grown.value == BEST and grown.open == (False, False)


def test_on_a_coarse_row_the_ends_lie_between_the_values_within_and_the_closed_form():
    values = np.array([1.4, 0.4, 0.55, 0.7, 0.85, 1.0, 1.2])  # in any order
    grown = grown_to_profile(NARROW, values, profile(values), LEVEL)
    within = values[profile(values) <= LEVEL]
    # a convex profile lies below its chords: linear between values, the crossing falls short of the true one
    assert BEST * np.exp(-REACH) <= grown.low <= within.min()
    assert within.max() <= grown.high <= BEST * np.exp(REACH)
    assert grown.open == (False, False)


def test_a_profile_within_the_level_at_the_row_s_end_leaves_that_end_open_there():
    values = np.array([0.7, 0.85, 1.0, 1.2, 1.4])
    grown = grown_to_profile(NARROW, values, profile(values), LEVEL)
    assert grown.low == 0.7 and grown.open == (True, False)
    assert json.loads(json.dumps(grown.open)) == [True, False]  # plain booleans, as params.json stores them


def test_an_interval_reaching_past_the_profile_keeps_its_ends():
    wide = Interval(BEST, 0.1, 5.0, (False, True))
    values = np.geomspace(0.3, 2.0, 9)
    assert grown_to_profile(wide, values, profile(values), LEVEL) == wide


def test_a_single_value_or_a_profile_above_the_level_says_nothing():
    assert grown_to_profile(NARROW, [0.5], [FLOOR], LEVEL) == NARROW
    values = np.geomspace(0.3, 2.0, 9)
    assert grown_to_profile(NARROW, values, profile(values) + FLOOR, LEVEL) == NARROW
