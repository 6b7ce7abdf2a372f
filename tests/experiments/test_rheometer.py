"""Rheometer flow curves: the Lotion files read, the published Herschel-Bulkley fit found again, the log error."""

from pathlib import Path

import numpy as np
import pytest

from rheo.experiments.rheometer import FlowCurve, RheometerError, fit_herschel_bulkley, log_rms_error, read_flow_curve

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "rheometer"


def test_the_lotion_curves_read_with_21_points_at_their_temperatures():
    for path, temperature in zip(sorted(DATA.glob("Lotion_*.csv")), (22, 23, 24, 25), strict=True):
        curve = read_flow_curve(path)
        assert len(curve.shear_rate) == 21 and curve.temperature == pytest.approx(temperature, abs=0.1)
        assert curve.shear_rate[[0, -1]] == pytest.approx([0.1, 1000.0])
        assert np.all(np.diff(curve.stress) > 0)


def test_the_published_fit_of_the_23C_curve_is_found_again():
    curve = read_flow_curve(DATA / "Lotion_20230114_1204_23C.csv").within((1.0, 398.0))
    tau_y, K, n = fit_herschel_bulkley(curve)
    assert (tau_y, K, n) == pytest.approx((7.0, 5.3, 0.53), rel=0.01)  # the data's README: about 7.0, 5.3, 0.53
    assert log_rms_error(tau_y, K, n, curve) < 0.02
    # a law 10^0.1 times the fit is 0.1 off
    assert log_rms_error(tau_y * 10**0.1, K * 10**0.1, n, curve) == pytest.approx(np.sqrt(
        np.mean((0.1 + np.log10((tau_y + K * curve.shear_rate**n) / curve.stress)) ** 2)))


def test_the_stress_between_points_follows_a_power_law_segment():
    """At a measured rate the measured stress (the 23 C file's 25.346 Pa at 10 1/s); between two points the power law
    through both, whatever their order in the file; beyond the ends, the end's stress."""
    assert read_flow_curve(DATA / "Lotion_20230114_1204_23C.csv").stress_at(10.0) == pytest.approx(25.346)
    rates = np.array([10.0, 1.0, 100.0])
    curve = FlowCurve("power law", rates, 3.0 * rates**0.4, 20.0)
    assert curve.stress_at(2.5) == pytest.approx(3.0 * 2.5**0.4, rel=1e-12)
    assert curve.stress_at(0.1) == pytest.approx(3.0)


def test_a_file_without_points_is_refused(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("header\n\n")
    with pytest.raises(RheometerError, match=r"empty\.csv: fewer than 3 points"):
        read_flow_curve(path)
