"""A dam break's silhouettes against a simulated Herschel-Bulkley flow.

The recordings' silhouettes include the container, so the simulated silhouette is the particles' joined with the
container's; what differs between materials is the material outside it. The loss of a frame is the symmetric mean
boundary distance (px) between the two (``rheo.render.silhouette.boundary_distance``), as in the virtual
experiments' fit. The first frame's time after the
release is not known: one rollout is recorded every ``OFFSET_STEP`` seconds, and the offset whose frames (1/fps
apart) fit best is taken, for every material evaluated.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import minimize_scalar

from rheo.diagnose.candidates import Law
from rheo.experiments.dam_break import DamBreakScene, dam_break_scene
from rheo.experiments.effects import Effects
from rheo.experiments.virheometry import CONTAINER_RIM, Setup, container_silhouette
from rheo.fit.search import EvaluateMany, simplex_search
from rheo.physics import HerschelBulkley
from rheo.physics.simulator import Trajectory
from rheo.render.silhouette import boundary_distance, distance_to, iou, silhouette

OFFSET_STEP = 1.0 / 240.0  # s
MOVING_RATE = 0.1  # 1/s: slower particles count as at rest in the shear-rate band
SHARE_STEP = 1.0  # the flow-index searches' initial step in the logit of the yield stress' share (0.5 -> 0.73)
STRESS_STEP = 0.1  # ... and in the log of the stress at the stress rate, which the stress search has placed
STRESS_TOLERANCE = 0.05  # log units: the stress search's resolution


def frame_steps(fps: float, where: str) -> int:
    """The offset steps between two frames recorded at ``fps``; an error naming ``where`` if not a whole number."""
    steps = 1.0 / (fps * OFFSET_STEP)
    if not np.isclose(steps, round(steps)):
        raise ValueError(f"{where}: {fps:g} fps puts its frames {steps:.3g} steps of {OFFSET_STEP:.4g} s apart, "
                         "not a whole number")
    return round(steps)


def skin(camera, points: np.ndarray, spacing: float) -> np.ndarray:
    """The particles' silhouette with gaps up to about a particle spacing closed: a thin spreading layer leaves its
    particles farther apart than the discs that draw them."""
    projection = camera.project(np.asarray(points, dtype=np.float64))
    drawn = silhouette(camera, points, spacing, projection)
    depth = projection[1]
    gap = spacing * camera.K[0, 0] / float(np.median(depth[depth > 0])) if (depth > 0).any() else 0.0
    if gap < 1.0:
        return drawn
    size = 2 * int(np.ceil(gap)) + 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    return cv2.morphologyEx(drawn.astype(np.uint8), cv2.MORPH_CLOSE, kernel).astype(bool)


def shear_rates(velocity_gradient: np.ndarray) -> np.ndarray:
    """Equivalent shear rate sqrt(2 D':D') (1/s) of velocity gradients (..., 3, 3): gamma_dot in simple shear."""
    strain_rate = 0.5 * (velocity_gradient + np.swapaxes(velocity_gradient, -1, -2))
    deviatoric = strain_rate - np.trace(strain_rate, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) / 3.0
    return np.sqrt(2.0 * np.sum(deviatoric**2, axis=(-2, -1)))


@dataclass
class Comparison:
    """A material's best agreement with one setup: loss (px) over the fitted frames, the first frame's time after
    the release (s), and per frame the boundary distance (px), the silhouettes' IoU and the IoU of the material
    outside the container."""

    loss: float
    held_out_loss: float  # over the frames held out between fitted ones (nan when none)
    forecast_loss: float  # over the last frames, held out as a prediction (nan when none)
    offset: float
    distances: np.ndarray
    iou: np.ndarray
    outflow_iou: np.ndarray
    shear_rates: np.ndarray  # 1/s, of the moving particles over the compared frames
    silhouettes: np.ndarray  # (frames, H, W) bool: the simulated silhouettes compared, container included
    fitted: np.ndarray  # (frames,) bool: fitted, or held out

    @property
    def fitted_distances(self) -> np.ndarray:
        return self.distances[self.fitted]


class DamBreakTarget:
    """One setup's silhouettes and its simulated scene with ``effects`` (none by default); the first frame comes
    ``min_offset`` to ``max_offset`` seconds after the release; every frame makes the loss but every
    ``held_out_every``-th (frames k, 2k, ...; none by default) and the last ``held_out_last`` (a prediction), held
    out."""

    def __init__(self, scene: DamBreakScene, max_offset: float, elastic: tuple[float, float],
                 min_offset: float = 0.0, held_out_every: int | None = None, effects: Effects | None = None,
                 held_out_last: int = 0) -> None:
        self.scene = scene
        self.effects = effects or Effects()  # the physics every material is simulated with
        self.setup = scene.setup
        self.masks = self.setup.masks
        self.fitted = np.ones(len(self.masks), bool)
        if held_out_every is not None:
            if held_out_every < 2:
                raise ValueError(f"held_out_every = {held_out_every} leaves no frame to fit: it must be >= 2")
            self.fitted[held_out_every - 1::held_out_every] = False
        self.forecast = np.arange(len(self.masks)) >= len(self.masks) - held_out_last
        self.fitted &= ~self.forecast
        if held_out_last < 0 or self.fitted.sum() < 2:
            raise ValueError(f"{self.setup.folder}: holding out the last {held_out_last} of {len(self.masks)} frames "
                             f"(and every {held_out_every}-th) leaves fewer than 2 frames to fit")
        self.to_mask = [distance_to(m) for m in self.masks]
        # the recorded container is a pixel or two wider than the cuboid's outline (its walls, the binarisation):
        # what every frame shows within CONTAINER_RIM px of the outline counts as container
        rim = container_silhouette(self.setup, CONTAINER_RIM)
        self.container = container_silhouette(self.setup) | (rim & np.logical_and.reduce(self.masks))
        self.first_offset = round(min_offset / OFFSET_STEP)
        self.offsets = round(max_offset / OFFSET_STEP)
        self.frame_steps = frame_steps(self.setup.fps, self.setup.folder)
        self.mu, self.lam = elastic

    def material(self, tau_y: float, K: float, n: float, mu: float | None = None) -> HerschelBulkley:
        """The material of a law, with the shear modulus ``mu`` (Pa) where given, else the target's."""
        return HerschelBulkley(tau_y=tau_y, K=K, n=n, mu=self.mu if mu is None else mu, lam=self.lam,
                               density=self.setup.density)

    def compare(self, tau_y: float, K: float, n: float, effects: Effects | None = None,
                mu: float | None = None) -> Comparison:
        return self.score(self.simulate(tau_y, K, n, effects, mu))

    def simulate(self, tau_y: float, K: float, n: float, effects: Effects | None = None,
                 mu: float | None = None) -> Trajectory:
        """The rollout every candidate offset's frames are taken from, sampled every ``OFFSET_STEP`` s."""
        steps = self.offsets + (len(self.masks) - 1) * self.frame_steps
        return self.scene.rollout(self.material(tau_y, K, n, mu), steps * OFFSET_STEP, OFFSET_STEP,
                                  self.effects if effects is None else effects)

    def score(self, trajectory: Trajectory) -> Comparison:
        """The rollout's best agreement with the recording over the candidate offsets."""
        frames = len(self.masks)
        # the whole material's silhouette is drawn; the shear rates are the simulated half's (its mirror's are equal)
        positions = self.scene.positions(trajectory)
        drawn = {}

        def simulated(step: int) -> np.ndarray:
            if step not in drawn:
                drawn[step] = skin(self.setup.camera, positions[step], self.scene.spacing) | self.container
            return drawn[step]

        starts = range(self.first_offset, self.offsets + 1)
        table = np.array([[boundary_distance(simulated(start + k * self.frame_steps), self.masks[k], self.to_mask[k])
                           for k in range(frames)] for start in starts])
        best_row = int(np.argmin(table[:, self.fitted].mean(axis=1)))
        best, distances = starts[best_row], table[best_row]
        chosen = [simulated(best + k * self.frame_steps) for k in range(frames)]
        outside = ~self.container
        overlap = np.array([iou(s, m) for s, m in zip(chosen, self.masks, strict=True)])
        outflow = np.array([iou(s & outside, m & outside) for s, m in zip(chosen, self.masks, strict=True)])
        steps_compared = best + self.frame_steps * np.arange(frames)
        rates = shear_rates(trajectory.C.numpy()[steps_compared]).ravel()
        held_out, forecast = distances[~self.fitted & ~self.forecast], distances[self.forecast]
        return Comparison(float(distances[self.fitted].mean()), float(held_out.mean()) if len(held_out) else np.nan,
                          float(forecast.mean()) if len(forecast) else np.nan, best * OFFSET_STEP, distances,
                          overlap, outflow, rates[rates > MOVING_RATE], np.stack(chosen), self.fitted)


def shear_rate_band(results: list[Comparison]) -> list[float] | None:
    """The shear rates (1/s) the simulated flows reach: 5th-95th percentile of the moving particles' over the
    compared frames of every setup (None when nothing moved)."""
    rates = np.concatenate([r.shear_rates for r in results])
    return np.percentile(rates, [5, 95]).tolist() if len(rates) else None


def setup_files(records: list[str], masks: list[str]) -> dict[str, tuple[str, str]]:
    """The imported setups by name (their source folder's): (setup.json, masks.npz)."""
    names = [Path(json.loads(Path(r).read_text())["folder"]).name for r in records]
    return dict(zip(names, zip(records, masks, strict=True), strict=True))


def target(setup: Setup, simulation: dict) -> DamBreakTarget:
    """A setup as a target, simulated with ``simulation``'s grid, particles, time step, elastic constants and wall
    slip (if given); its first frame ``min_offset`` (default 0) to ``max_offset`` s after the release, every
    ``held_out_every``-th frame (if given) and the last ``forecast_share`` of the frames (default none) held out of
    the loss."""
    scene = dam_break_scene(setup, simulation["cells_per_height"], simulation["cells_across"],
                            simulation["particles_per_cell"], cfl=simulation["cfl"],
                            transfer_cfl=simulation.get("transfer_cfl"))
    return DamBreakTarget(scene, simulation["max_offset"], (simulation["mu"], simulation["lam"]),
                          simulation.get("min_offset", 0.0), simulation.get("held_out_every"),
                          Effects(wall_slip=simulation.get("wall_slip")),
                          round(simulation.get("forecast_share", 0.0) * len(setup.masks)))


def targets(setups: dict[str, tuple[str, str]], simulation: dict) -> dict[str, DamBreakTarget]:
    """Every setup (name: (setup.json, masks.npz) of its import) as a ``target``."""
    out = {}
    for name, (record, masks) in setups.items():
        with open(record) as f:
            out[name] = target(Setup.from_record(json.load(f), np.load(masks)["masks"]), simulation)
    return out


def comparisons(setups: dict[str, tuple[str, str]], simulation: dict,
                law: Law | None = None) -> dict[str, Callable[[np.ndarray], Comparison]]:
    """For every setup, the comparison with it of a material and effects given as a search vector of ``law`` (log
    tau_y, K and n by default); built once per worker process."""
    return {name: partial(compare_law, target, law or Law()) for name, target in targets(setups, simulation).items()}


def compare_law(target: DamBreakTarget, law: Law, x: np.ndarray) -> Comparison:
    values, effects = law.unpack(x, target.effects)
    return target.compare(**values, effects=effects)


def stress_split(x: np.ndarray, rate: float) -> np.ndarray:
    """A law's (log tau_y, log K, log n) as (log S, logit s): S = tau_y + K rate^n, its stress at the shear rate
    ``rate``, and s = tau_y / S, the yield stress' share of it."""
    tau_y, viscous = np.exp(x[0]), np.exp(x[1]) * rate ** np.exp(x[2])
    return np.array([np.log(tau_y + viscous), np.log(tau_y / viscous)])


def from_stress_split(z: np.ndarray, n: float, rate: float) -> np.ndarray:
    """The law (log tau_y, log K, log n) of flow index ``n`` whose ``stress_split`` at ``rate`` is ``z``."""
    share = 1.0 / (1.0 + np.exp(-z[1]))
    stress = np.exp(z[0])
    return np.log([share * stress, (1.0 - share) * stress / rate ** n, n])


def clipped_law(z: np.ndarray, n: float, rate: float, box: tuple[np.ndarray, np.ndarray],
                free_n: bool = True) -> np.ndarray:
    """``from_stress_split``'s law (``z``'s first two entries; its log n dropped where the flow index is fixed,
    ``free_n`` False), then ``z``'s further coordinates (the shear modulus' log, where fitted), clipped to ``box``."""
    law = from_stress_split(z[:2], n, rate)
    return np.clip(np.r_[law if free_n else law[:2], z[2:]], *box)


def stress_level(evaluate_many: EvaluateMany, rate: float, box: tuple[np.ndarray, np.ndarray], evaluations: int,
                 n: float = 1.0, rest: Sequence[float] = (), free_n: bool = True) -> float:
    """The log of the stress at ``rate`` that fits best among the laws of flow index ``n`` whose stress is split
    evenly (phase "stress"), the coordinates after the law held at ``rest``: bounded Brent over the stresses whose
    law lies in ``box`` (of laws with log n unless ``free_n`` is False), at most ``evaluations`` iterations, to
    ``STRESS_TOLERANCE``. A dam break's silhouettes fix that stress tightly and the rest of the law loosely, so one
    line search places the searches' starts in the valley of good laws (on Lotion a survey of 12 points of the box
    came within 3 to 5 times the fit's loss at best)."""
    (tau_y_low, k_low), (tau_y_high, k_high) = np.exp(box[0][:2]), np.exp(box[1][:2])
    viscous = rate ** n
    bounds = (np.log(2.0 * max(tau_y_low, k_low * viscous)), np.log(2.0 * min(tau_y_high, k_high * viscous)))
    result = minimize_scalar(lambda z: evaluate_many([clipped_law(np.r_[z, 0.0, rest], n, rate, box, free_n)],
                                                     "stress")[0],
                             bounds=bounds, method="bounded",
                             options={"xatol": STRESS_TOLERANCE, "maxiter": evaluations})
    return float(result.x)


def valley_search(evaluate_many: EvaluateMany, start: np.ndarray, n: float, rate: float, evaluations: int,
                  box: tuple[np.ndarray, np.ndarray], phase: str, rest_step: float = 0.5,
                  free_n: bool = True) -> tuple[np.ndarray, float]:
    """Nelder-Mead over laws of flow index ``n`` from ``start`` in (log stress at ``rate``, logit of the yield
    stress' share, the coordinates after the law), initial steps ``STRESS_STEP``, ``SHARE_STEP`` and ``rest_step``,
    at most ``evaluations``, laws clipped to ``box`` (``clipped_law``): the best law and its loss."""
    steps = np.r_[STRESS_STEP, SHARE_STEP, np.full(len(start) - 2, rest_step)]
    z, loss = simplex_search(lambda z, ph: evaluate_many([clipped_law(z, n, rate, box, free_n)], ph)[0], start,
                             steps, evaluations, phase)
    return clipped_law(z, n, rate, box, free_n), loss


def flow_index_profile(evaluate_many: EvaluateMany, log_stress: float, flow_indices: Sequence[float], rate: float,
                       evaluations: int, box: tuple[np.ndarray, np.ndarray], rest: Sequence[float] = (),
                       rest_step: float = 0.5) -> list[tuple[np.ndarray, float]]:
    """A ``valley_search`` at each of ``flow_indices`` (phases "n <value>", side by side), each from the law of that
    index with the stress exp(``log_stress``) at ``rate`` (``stress_level``'s) split evenly between yield and viscous
    stress and the coordinates after the law (the shear modulus' log, where fitted) at ``rest``: each search's best
    point and its loss.

    A dam break's silhouettes fix the stress at the shear rates of its flow tightly and its split between yield and
    viscous stress and the flow index loosely, so equally good laws lie along a curved valley in (tau_y, K, n), with
    basins along it that a survey of the box is too coarse to tell apart. Keeping the stress puts every search's
    start in the valley; the even split lets it reach a basin on either side, where a survey's best may lie at an
    extreme split in a worse basin (docs/settings.md, `flow_index_searches`)."""
    start = np.r_[log_stress, 0.0, rest]

    def search(n: float) -> tuple[np.ndarray, float]:
        return valley_search(evaluate_many, start, n, rate, evaluations, box, f"n {n:g}", rest_step)

    with ThreadPoolExecutor(len(flow_indices)) as threads:
        return list(threads.map(search, flow_indices))


def valley_points(log_stress: float, shares: Sequence[float], rests: Sequence[Sequence[float]]) -> list[np.ndarray]:
    """A survey along the valley at a fixed flow index: the stress exp(``log_stress``) at the stress rate split at
    each of ``shares`` (the yield stress' share), with each of ``rests`` after it (the shear modulus' log, where
    fitted), as ``valley_search`` coordinates. At a fixed stress, basins far apart in that split and the modulus lose
    very different amounts, and a survey of the whole box may land in the shallower (docs/settings.md, `shares`)."""
    return [np.r_[log_stress, np.log(share / (1.0 - share)), rest] for share in shares for rest in rests]


def valley_searches(evaluate_many: EvaluateMany, starts: Sequence[np.ndarray], n: float, rate: float,
                    evaluations: int, box: tuple[np.ndarray, np.ndarray],
                    rest_step: float = 0.5) -> list[tuple[np.ndarray, float]]:
    """A ``valley_search`` at the fixed flow index ``n`` from each of ``starts`` (phases "start 1", "start 2", ...,
    side by side): each one's best law (log tau_y, log K, then the rest) and its loss."""

    def search(k: int) -> tuple[np.ndarray, float]:
        return valley_search(evaluate_many, starts[k], n, rate, evaluations, box, f"start {k + 1}", rest_step,
                             free_n=False)

    with ThreadPoolExecutor(len(starts)) as threads:
        return list(threads.map(search, range(len(starts))))
