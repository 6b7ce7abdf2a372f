"""Rheometer flow curves: the Lotion files read, the published Herschel-Bulkley fit found again, the log error."""

from pathlib import Path

import numpy as np
import pytest

from rheo.experiments.rheometer import RheometerError, fit_herschel_bulkley, log_rms_error, read_flow_curve

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


def test_a_file_without_points_is_refused(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("header\n\n")
    with pytest.raises(RheometerError, match=r"empty\.csv: fewer than 3 points"):
        read_flow_curve(path)
