"""Rheometer flow curves (steady shear: stress against shear rate) and their comparison with a recovered law.

The files are the tab-separated exports of an Anton Paar rheometer: a few header lines, then one row per point with
point number, time (s), shear rate (1/s), shear stress (Pa), viscosity (mPa s), torque (mN m), temperature (degC).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares


class RheometerError(ValueError):
    """A flow-curve file that cannot be read."""


@dataclass
class FlowCurve:
    name: str
    shear_rate: np.ndarray  # 1/s
    stress: np.ndarray  # Pa
    temperature: float  # degC, the mean over the points

    def within(self, band: tuple[float, float]) -> FlowCurve:
        keep = (self.shear_rate >= band[0]) & (self.shear_rate <= band[1])
        return FlowCurve(self.name, self.shear_rate[keep], self.stress[keep], self.temperature)

    def stress_at(self, rate: float) -> float:
        """The stress (Pa) at ``rate`` (1/s), interpolated between the points in log-log (held at the ends)."""
        order = np.argsort(self.shear_rate)
        return float(np.exp(np.interp(np.log(rate), np.log(self.shear_rate[order]), np.log(self.stress[order]))))


def read_flow_curve(path: str | Path) -> FlowCurve:
    """The points of an exported flow curve (rows whose first field is the point number)."""
    path = Path(path)
    if not path.is_file():
        raise RheometerError(f"{path}: missing")
    rows = []
    for line in path.read_text(encoding="utf-8-sig", errors="replace").splitlines():
        fields = line.strip().split("\t")
        if not fields[0].strip().isdigit():
            continue
        try:
            rows.append([float(fields[2]), float(fields[3]), float(fields[6])])
        except (IndexError, ValueError) as err:
            raise RheometerError(f"{path}: point {fields[0]} does not have a numeric shear rate, stress and "
                                 "temperature in columns 3, 4 and 7") from err
    if len(rows) < 3:
        raise RheometerError(f"{path}: fewer than 3 points")
    data = np.array(rows)
    if np.any(data[:, :2] <= 0):
        raise RheometerError(f"{path}: shear rates and stresses must be positive")
    return FlowCurve(path.stem, data[:, 0], data[:, 1], float(data[:, 2].mean()))


def pooled(curves: list[FlowCurve], name: str = "pooled") -> FlowCurve:
    """The points of several curves as one (their mean temperature)."""
    return FlowCurve(name, np.concatenate([c.shear_rate for c in curves]), np.concatenate([c.stress for c in curves]),
                     float(np.mean([c.temperature for c in curves])))


RESULT_KEYS = {"tau_y": "tau_y_Pa", "K": "K_Pa_s_n", "n": "n"}  # the law's parameters' keys in a fit's params.json
PARAMETER_KEYS = RESULT_KEYS | {"mu": "mu_Pa"}  # and the shear modulus', where fitted


def fitted_law(params: dict) -> tuple[float, float, float]:
    """The law (tau_y, K, n) of a fit's params.json, read."""
    return tuple(params[key]["value"] for key in RESULT_KEYS.values())


def herschel_bulkley(rate: np.ndarray, tau_y: float, K: float, n: float) -> np.ndarray:
    return tau_y + K * np.asarray(rate) ** n


def fit_herschel_bulkley(curve: FlowCurve) -> tuple[float, float, float]:
    """tau_y (Pa), K (Pa s^n), n: least squares in stress (as the rheometer's own fits), tau_y >= 0."""
    def residuals(p):
        return herschel_bulkley(curve.shear_rate, *p) - curve.stress

    start = [0.5 * curve.stress.min(), curve.stress.max() / curve.shear_rate.max() ** 0.5, 0.5]
    p = least_squares(residuals, start, bounds=([0.0, 1e-12, 0.05], [np.inf, np.inf, 3.0])).x
    return float(p[0]), float(p[1]), float(p[2])


def log_rms_error(tau_y: float, K: float, n: float, curve: FlowCurve) -> float:
    """RMS of log10(tau_law / tau_measured) over the curve's points."""
    return float(np.sqrt(np.mean(np.log10(herschel_bulkley(curve.shear_rate, tau_y, K, n) / curve.stress) ** 2)))
