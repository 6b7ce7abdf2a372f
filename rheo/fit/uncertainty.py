"""Approximate 95 % intervals of fitted parameters from the loss' curvature (Gauss-Newton / Laplace).

The residuals are the rendered-minus-observed values on a fixed set of rays. Residuals within one image are
correlated (a misplaced edge moves many pixels together), so the covariance is the cluster-robust sandwich
A^-1 B A^-1 with A = J^T J and B the sum over images of (J_c^T r_c)(J_c^T r_c)^T, rather than sigma^2 A^-1, which
would treat every pixel as independent and be far too confident. The Jacobian comes from central differences of the
log-parameters (forward simulations only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from rheo.fit.inverse import Problem

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


def residuals(problem: Problem, log_values: torch.Tensor, v0: torch.Tensor, frames: int, rays_per_view: int,
              seed: int = 12345) -> np.ndarray:
    """Rendered minus observed on fixed rays: (frames, views, values per view)."""
    with torch.no_grad():
        trajectory = problem.simulate(log_values, v0, frames)
        out = []
        for k in range(1, frames + 1):
            r = problem.frame_residual(trajectory.x[k], k, rays_per_view, np.random.default_rng(seed + k))
            out.append(r.reshape(len(problem.obs.views), -1).numpy())
    return np.asarray(out, dtype=np.float64)


def laplace_intervals(problem: Problem, log_values: torch.Tensor, v0: torch.Tensor, frames: int,
                      rays_per_view: int = 512, step: float = 0.05) -> tuple[dict[str, Interval], dict]:
    """95 % intervals of the fitted parameters and the evidence behind them (Jacobian norms per parameter, the
    loss at the optimum, and how much the loss grows when each parameter is doubled, from the Gauss-Newton model)."""
    base = residuals(problem, log_values, v0, frames, rays_per_view)
    columns = []
    for i in range(len(log_values)):
        delta = torch.zeros_like(log_values)
        delta[i] = step
        plus = residuals(problem, log_values + delta, v0, frames, rays_per_view)
        minus = residuals(problem, log_values - delta, v0, frames, rays_per_view)
        columns.append((plus - minus) / (2 * step))
    J = np.stack(columns, axis=-1)  # (frames, views, values, parameters)
    flat_J, flat_r = J.reshape(-1, J.shape[-1]), base.reshape(-1)
    A = flat_J.T @ flat_J
    scores = np.einsum("fvkp,fvk->fvp", J, base).reshape(-1, J.shape[-1])  # one score per image
    B = scores.T @ scores
    A_inv = np.linalg.pinv(A, rcond=1e-10)
    covariance = A_inv @ B @ A_inv
    loss = float(flat_r @ flat_r)
    intervals, doubling = {}, {}
    for i, name in enumerate(problem.names):
        sigma = math.sqrt(max(covariance[i, i], 0.0)) if A[i, i] > 0 else math.inf
        value = math.exp(float(log_values[i]))
        spread = math.exp(min(Z95 * sigma, 700.0))
        intervals[name] = Interval(value, value / spread, value * spread, sigma)
        doubling[name] = float(A[i, i] * math.log(2.0) ** 2 / max(loss, 1e-30))
    evidence = {"loss": loss, "rays_per_view": rays_per_view, "frames": frames, "step_log": step,
                "jacobian_norm": {n: float(math.sqrt(A[i, i])) for i, n in enumerate(problem.names)},
                "loss_increase_if_doubled": doubling, "covariance_log": covariance.tolist(),
                "correlation": (covariance / np.sqrt(np.outer(np.diag(covariance), np.diag(covariance)) + 1e-300))
                .round(3).tolist()}
    return intervals, evidence
