"""Approximate 95 % intervals of fitted parameters from the loss' curvature (Gauss-Newton / Laplace).

The residuals are rendered-minus-observed values of every image (frame and view) on fixed pixels. Residuals within
one image are correlated (a misplaced edge moves many pixels together), so the covariance is the cluster-robust
sandwich A^-1 B A^-1 with A = J^T J and B the sum over images of (J_c^T r_c)(J_c^T r_c)^T, rather than
sigma^2 A^-1, which would treat every pixel as independent and be far too confident. The Jacobian comes from central
differences of the log-parameters (forward simulations only).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

Z95 = 1.959964
# A parameter is determined when its 95 % interval spans less than this factor (low to high).
DETERMINED_SPAN = 4.0


@dataclass
class Interval:
    value: float
    low: float
    high: float
    sigma_log: float

    @property
    def determined(self) -> bool:
        return self.high / self.low < DETERMINED_SPAN


def laplace_intervals(residuals: Callable[[np.ndarray], list[np.ndarray]], log_values: np.ndarray,
                      names: Sequence[str], step: float = 0.05) -> tuple[dict[str, Interval], dict]:
    """95 % intervals of the parameters ``names`` fitted at ``log_values``, from ``residuals(log_values)`` (one
    array per image), and the evidence behind them: Jacobian norms, the loss at the optimum, how much the loss grows
    when each parameter is doubled (Gauss-Newton model), the covariance and correlations of the log-parameters."""
    log_values = np.asarray(log_values, dtype=np.float64)
    base = residuals(log_values)
    columns = []
    for i in range(len(log_values)):
        delta = np.zeros_like(log_values)
        delta[i] = step
        plus, minus = residuals(log_values + delta), residuals(log_values - delta)
        columns.append([(p - m) / (2 * step) for p, m in zip(plus, minus, strict=True)])
    jacobians = [np.stack(per_image, axis=1) for per_image in zip(*columns, strict=True)]  # per image (values, p)
    A = sum(J.T @ J for J in jacobians)
    scores = np.stack([J.T @ r for J, r in zip(jacobians, base, strict=True)])  # one score per image
    B = scores.T @ scores
    A_inv = np.linalg.pinv(A, rcond=1e-10)
    covariance = A_inv @ B @ A_inv
    loss = float(sum(r @ r for r in base))
    intervals, doubling = {}, {}
    for i, name in enumerate(names):
        sigma = math.sqrt(max(covariance[i, i], 0.0)) if A[i, i] > 0 else math.inf
        value = math.exp(float(log_values[i]))
        spread = math.exp(min(Z95 * sigma, 700.0))
        intervals[name] = Interval(value, value / spread, value * spread, sigma)
        doubling[name] = float(A[i, i] * math.log(2.0) ** 2 / max(loss, 1e-30))
    scale = np.sqrt(np.outer(np.diag(covariance), np.diag(covariance))) + 1e-300
    evidence = {"loss": loss, "images": len(base), "step_log": step,
                "jacobian_norm": {n: float(math.sqrt(A[i, i])) for i, n in enumerate(names)},
                "loss_increase_if_doubled": doubling, "covariance_log": covariance.tolist(),
                "correlation": (covariance / scale).round(3).tolist()}
    return intervals, evidence
