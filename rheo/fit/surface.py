"""The loss around its minimum as a smooth surface fitted to many evaluations (a response surface).

The silhouette loss is rough at the scale of pixel edges, and where the parameters trade against each other its
minimum lies in a long, nearly flat valley: a simplex stops wherever the roughness dipped, and the lowest loss
evaluated is a noisy estimate of where the valley's floor is lowest. A quadratic fitted by least squares to
evaluations spread on a design around the valley averages the roughness out; its minimiser is the estimate, and
the region where it stays within the tolerance gives the intervals with the trade-offs included (the region's
extent along each parameter, where a profile holds the others at their optimum).

The quadratic models the squared loss: a boundary distance grows like sqrt(floor^2 + error^2) with a material's
error, whose square is quadratic both near the floor and away from it.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

logger = logging.getLogger(__name__)
REACH = 2.0  # a surface is fitted to the evaluations within this many design radii of its centre


@dataclass
class Quadratic:
    """q(x) = value + gradient . d + d . hessian . d / 2 with d = x - centre."""

    centre: np.ndarray
    value: float
    gradient: np.ndarray
    hessian: np.ndarray

    def __call__(self, x: np.ndarray) -> np.ndarray:
        d = np.atleast_2d(x) - self.centre
        return self.value + d @ self.gradient + 0.5 * np.einsum("ni,ij,nj->n", d, self.hessian, d)

    @property
    def convex(self) -> bool:
        return bool(np.linalg.eigvalsh(self.hessian)[0] > 0)

    def lowest_within(self, radius: float) -> np.ndarray:
        """The lowest point within ``radius`` of the centre: the unconstrained minimiser where it lies inside, else
        the point on the sphere where the gradient of q is normal to it ((H + s I) d = -g, s found by bisection)."""
        eigenvalues, basis = np.linalg.eigh(self.hessian)
        g = basis.T @ self.gradient

        def step(shift: float) -> np.ndarray:
            return basis @ (-g / (eigenvalues + shift))

        if eigenvalues[0] > 0 and np.linalg.norm(step(0.0)) <= radius:
            return self.centre + step(0.0)
        low = max(-eigenvalues[0], 0.0) + 1e-12 * max(abs(eigenvalues).max(), 1.0)
        high = low + np.linalg.norm(self.gradient) / radius + abs(eigenvalues).max()
        if np.linalg.norm(step(low)) <= radius:
            # the "hard case": the gradient is (nearly) normal to the lowest curvature; step as far as the other
            # directions ask and go the rest of the way to the sphere along the lowest curvature
            d = step(low) - basis[:, 0] * (basis[:, 0] @ step(low))
            along = np.sqrt(max(radius ** 2 - float(d @ d), 0.0))
            return self.centre + d - np.sign(g[0] or 1.0) * along * basis[:, 0]
        for _ in range(100):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if np.linalg.norm(step(middle)) > radius else (low, middle)
        return self.centre + step(high)

    def valley_floor(self) -> np.ndarray:
        """Row i: how the other coordinates follow coordinate i along q's floor (their minimiser given x_i moves by
        d_i times row i; row i's own entry is 1): the line on which the tolerance region's extreme along axis i
        lies. Where the others' curvature is not positive definite the row is the axis."""
        k = len(self.hessian)
        rows = np.eye(k)
        for i in range(k):
            others = [j for j in range(k) if j != i]
            block = self.hessian[np.ix_(others, others)]
            if others and np.linalg.eigvalsh(block)[0] > 0:
                rows[i, others] = -np.linalg.solve(block, self.hessian[others, i])
        return rows

    def extents(self, tolerance: float, reach: float, estimate: np.ndarray,
                samples: int = 100000) -> tuple[np.ndarray, np.ndarray]:
        """For q a squared loss fitted within ``reach`` of its centre: each coordinate's range (coordinates, 2) over
        the region where the loss stays within ``tolerance`` (relative) of its lowest (of its value at ``estimate``
        where q has no minimum within the reach), and whether each end is open (coordinates, 2): the range still
        grows with the reach there (by more than 2 % of it between the reach and 1.25 times it), so it is a lower
        bound. A convex q whose ellipsoid lies within the reach gives the ellipsoid's shadow on the axes; otherwise
        the region is sampled within the reach (a valley q does not close, or one longer than the evaluations
        reach)."""
        if self.convex:
            inverse = np.linalg.inv(self.hessian)
            minimiser = self.centre - inverse @ self.gradient
            depth = ((1.0 + tolerance) ** 2 - 1.0) * max(float(self(minimiser)[0]), 0.0)
            half = np.sqrt(2.0 * depth * np.diag(inverse))
            if np.linalg.norm(minimiser - self.centre) + half.max() <= reach:
                return np.column_stack([minimiser - half, minimiser + half]), np.zeros((len(half), 2), dtype=bool)
        level = (1.0 + tolerance) ** 2 * max(float(self(estimate)[0]), 0.0)
        ranges = [self._sampled_range(level, r, samples) for r in (reach, 1.25 * reach)]
        return ranges[0], np.abs(ranges[1] - ranges[0]) > 0.02 * reach

    def _sampled_range(self, level: float, reach: float, samples: int) -> np.ndarray:
        """Each coordinate's range over the region where q <= ``level`` (or its lowest within ``reach``, if higher)
        within ``reach``, from points sampled uniformly in the ball and on its sphere."""
        rng = np.random.default_rng(0)
        directions = rng.normal(size=(samples, len(self.centre)))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        radii = reach * rng.uniform(0.0, 1.0, (samples, 1)) ** (1.0 / len(self.centre))
        points = np.r_[self.lowest_within(reach)[None], self.centre + radii * directions,
                       self.centre + reach * directions]
        values = self(points)
        inside = points[values <= max(level, values.min())]
        return np.column_stack([inside.min(axis=0), inside.max(axis=0)])


def fit_quadratic(points: np.ndarray, values: np.ndarray, centre: np.ndarray, relative: bool = False) -> Quadratic:
    """The quadratic (expanded about ``centre``) nearest to ``values`` at ``points`` in least squares, of the
    residuals relative to the values if ``relative`` (for values whose noise grows in proportion, as the squared
    loss's roughness does: the valley's floor then counts as much as its walls); needs at least (k + 1)(k + 2)/2
    points in general position for k coordinates."""
    d = np.asarray(points, dtype=float) - centre
    values = np.asarray(values, dtype=float)
    k = d.shape[1]
    pairs = list(itertools.combinations_with_replacement(range(k), 2))
    features = np.column_stack([np.ones(len(d)), d, *[d[:, i] * d[:, j] for i, j in pairs]])
    if len(d) < features.shape[1]:
        raise ValueError(f"a quadratic in {k} coordinates needs {features.shape[1]} points, got {len(d)}")
    scale = 1.0 / np.abs(values) if relative else np.ones(len(values))
    coefficients = np.linalg.lstsq(features * scale[:, None], values * scale, rcond=None)[0]
    hessian = np.zeros((k, k))
    for (i, j), c in zip(pairs, coefficients[1 + k:], strict=True):
        hessian[i, j] += c
        hessian[j, i] += c  # the diagonal gets 2 c: the Hessian of c x_i^2
    return Quadratic(np.asarray(centre, dtype=float), float(coefficients[0]), coefficients[1:1 + k], hessian)


def composite_design(centre: np.ndarray, half_width: float) -> np.ndarray:
    """A spherical central composite design: the centre, the 2^k corners of the cube centre +- half_width and the
    2k points on the axes at sqrt(k) half_widths, all but the centre as far from it; it determines every
    coefficient of a quadratic."""
    k = len(centre)
    corners = np.array(list(itertools.product([-1.0, 1.0], repeat=k)))
    axes = np.sqrt(k) * np.r_[np.eye(k), -np.eye(k)]
    return centre + half_width * np.r_[np.zeros((1, k)), corners, axes]


@dataclass
class Refinement:
    """The estimate (log-parameters), the surface of the squared loss fitted around it, the design's half width, the
    rounds it took, whether the last surface's lowest point lay within a half width of its design's centre
    (``converged``) and whether the last surface promised too little from a further move to make it (``flat``)."""

    x: np.ndarray
    surface: Quadratic
    half_width: float
    rounds: int
    converged: bool
    flat: bool = False

    @property
    def reach(self) -> float:
        """How far from its centre the surface was fitted."""
        return REACH * np.sqrt(len(self.x)) * self.half_width


def refine(evaluate_many: Callable[[list[np.ndarray]], list[float]], centre: np.ndarray, half_width: float,
           box: tuple[np.ndarray, np.ndarray], evaluated: Callable[[], tuple[np.ndarray, np.ndarray]],
           rounds: int = 3, flat: float = 0.0) -> Refinement:
    """Rounds of a composite design around ``centre`` (clipped to ``box``; a point evaluated near a design point
    stands in for it), each followed by a quadratic fitted to the squared losses of every evaluation within
    ``REACH`` design radii (``evaluated()``: all points and losses so far, the design's among them) and a move to
    its lowest point within the design's radius; until the move stays within a half width (the minimum lies inside
    the design), the surface promises to lower the loss by less than the fraction ``flat`` at its lowest point
    (a valley whose floor is flat at that scale: walking along it would follow the roughness of the loss), or
    ``rounds`` are done. The estimate is the last surface's lowest point within the design's radius of the last
    centre."""
    radius = np.sqrt(len(centre)) * half_width
    for done in range(1, rounds + 1):
        design = np.unique(np.clip(composite_design(centre, half_width), *box), axis=0)
        points, _ = evaluated()
        if len(points):  # a point evaluated within a quarter half width stands in for a design point
            nearest = np.linalg.norm(design[:, None] - points[None], axis=2).min(axis=1)
            design = design[nearest > 0.25 * half_width]
        evaluate_many(list(design))
        points, losses = evaluated()
        near = np.linalg.norm(points - centre, axis=1) <= REACH * radius
        surface = fit_quadratic(points[near], np.asarray(losses)[near] ** 2, centre, relative=True)
        lowest = np.clip(surface.lowest_within(radius), *box)
        moved = float(np.linalg.norm(lowest - centre))
        promise = 1.0 - float(np.sqrt(max(float(surface(lowest)[0]), 0.0) / max(float(surface(centre)[0]), 1e-300)))
        logger.info("surface round %d: %d evaluations, %s, lowest point moved %.3g log units, promising a loss %.2g %% "
                    "lower", done, int(near.sum()), "convex" if surface.convex else "not convex", moved, 100 * promise)
        if moved <= half_width or promise < flat or done == rounds:
            return Refinement(lowest, surface, half_width, done, moved <= half_width, promise < flat)
        centre = lowest
    raise AssertionError("unreachable")


def describe_surface(surface: Quadratic, names: Sequence[str]) -> dict:
    """The surface as JSON-ready numbers."""
    return {"of": "squared loss (px^2) against log-parameters", "names": list(names),
            "centre_log": surface.centre.tolist(), "value": surface.value, "gradient": surface.gradient.tolist(),
            "hessian": surface.hessian.tolist(), "convex": surface.convex}
