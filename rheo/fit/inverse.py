"""An experiment's inverse problem: the seed particles, the simulator and the observations, with the differentiable
rendering loss (particle-field renderer against the matted frames) and Adam phases that descend it (the velocity
stage); the material itself is searched on silhouettes (rheo.fit.search).

Parameters are fitted as logarithms, in the experiment's convention: PAC-NeRF's (mu, lam, sigma_y, eta; n = 1,
tau_y = sigma_y / sqrt(3), K = eta / 2) or rheo's (mu, lam, tau_y, K, n).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

from rheo.experiments.scene import material, simulator
from rheo.fit.observations import Observations, load, sample_rays
from rheo.fit.search import SilhouetteTarget
from rheo.io import write_atomic
from rheo.physics import Simulator
from rheo.physics.simulator import Trajectory
from rheo.render.field import WHITE, render_particles

logger = logging.getLogger(__name__)

PARAMETERS = {"pacnerf": ("mu", "lam", "sigma_y", "eta"), "rheo": ("mu", "lam", "tau_y", "K", "n")}


def simulator_parameters(values: dict[str, torch.Tensor], convention: str, density: float) -> torch.Tensor:
    """The simulator's Herschel-Bulkley parameter vector (density, tau_y, K, n, mu, lam) from fitted values."""
    one = torch.ones((), dtype=torch.float64)
    if convention == "pacnerf":
        tau_y, K, n = values["sigma_y"] / math.sqrt(3.0), values["eta"] / 2.0, one
    else:
        tau_y, K, n = values["tau_y"], values["K"], values.get("n", one)
    return torch.stack([density * one, tau_y, K, n, values["mu"], values["lam"]])


@dataclass
class Problem:
    """One experiment's fit: the simulator, the observations and the seed (positions (N, 3), densities, colours)."""

    sim: Simulator
    obs: Observations
    positions: torch.Tensor
    density: torch.Tensor
    colour: torch.Tensor
    spacing: float
    convention: str
    material_density: float = 1000.0
    silhouette: bool = False  # compare opacities with masks instead of colours with matted frames

    @property
    def anchor(self) -> np.ndarray:
        """A point of the seed's particle lattice: the render grid keeps that lattice at its cell centres."""
        return self.positions[0].detach().cpu().numpy()

    @property
    def names(self) -> tuple[str, ...]:
        return PARAMETERS[self.convention]

    def simulate(self, log_values: torch.Tensor, v0: torch.Tensor, frames: int) -> Trajectory:
        values = dict(zip(self.names, torch.exp(log_values.double()), strict=True))
        params = simulator_parameters(values, self.convention, self.material_density)
        return self.sim.rollout(self.positions, v0, frames=frames, frame_dt=float(self.obs.times[1]),
                                particle_volume=self.spacing**3, material_params=params)

    def frame_loss(self, positions: torch.Tensor, frame: int, rays_per_view: int,
                   rng: np.random.Generator) -> torch.Tensor:
        """Mean squared error of one frame over random rays of every view: rendered against observed colours, or
        opacities against masks in silhouette mode."""
        batch = sample_rays(self.obs, frame, rays_per_view, rng)
        colour = None if self.silhouette else self.colour
        rgb, opacity = render_particles(positions.float(), self.density, colour, self.spacing, batch.origins,
                                        batch.dirs, WHITE, anchor=self.anchor)
        residual = opacity - batch.masks if self.silhouette else rgb - batch.colours
        return torch.mean(residual**2)

    def loss(self, log_values: torch.Tensor, v0: torch.Tensor, frames: int, rays_per_view: int,
             rng: np.random.Generator) -> torch.Tensor:
        """Mean image loss over frames 1 .. ``frames`` (frame 0 is the seed itself)."""
        trajectory = self.simulate(log_values, v0, frames)
        return torch.stack([self.frame_loss(trajectory.x[k], k, rays_per_view, rng)
                            for k in range(1, frames + 1)]).mean()


def cosine_rate(base: float, step: int, steps: int, floor: float = 0.05) -> float:
    """Cosine annealing from ``base`` to ``floor * base`` over ``steps`` steps."""
    return base * (floor + (1.0 - floor) * 0.5 * (1.0 + math.cos(math.pi * step / max(steps, 1))))


@dataclass
class Phase:
    """One phase of a fit: ``iterations`` Adam steps on frames 1 .. ``frames``, cosine-annealed from ``rate``."""

    name: str
    frames: int
    iterations: int
    rate: float


@dataclass
class FitState:
    """Where a fit stands: the iteration within the phase, the variables and the optimiser, the history so far."""

    phase: str
    iteration: int
    variables: torch.Tensor
    optimizer: dict
    history: list[dict] = field(default_factory=list)
    rng: dict | None = None
    key: str = ""


def run_phase(phase: Phase, variables: torch.Tensor, loss_fn: Callable[[torch.Tensor, int, np.random.Generator],
                                                                        torch.Tensor],
              describe: Callable[[torch.Tensor], dict[str, float]], checkpoint: str | Path, key: str,
              seed: int = 0, progress: bool = True) -> tuple[torch.Tensor, list[dict]]:
    """Adam with cosine annealing over one phase; every iteration's loss, rate and ``describe(variables)`` recorded.
    The state is checkpointed after every step (atomically) and resumed from ``checkpoint`` when its ``key`` (the
    fit's inputs and settings) matches."""
    variables = variables.detach().clone().requires_grad_(True)
    optimizer = torch.optim.Adam([variables], lr=phase.rate)
    rng = np.random.default_rng(seed)
    history: list[dict] = []
    start = 0
    checkpoint = Path(checkpoint)
    if checkpoint.is_file():
        state: FitState = torch.load(checkpoint, weights_only=False)
        if state.key == key and state.phase == phase.name:
            with torch.no_grad():
                variables.copy_(state.variables)
            optimizer.load_state_dict(state.optimizer)
            rng.bit_generator.state = state.rng
            history, start = state.history, state.iteration
            logger.info("%s: resuming at iteration %d of %d from %s", phase.name, start, phase.iterations, checkpoint)
    for step in tqdm(range(start, phase.iterations), desc=phase.name, initial=start, total=phase.iterations,
                     disable=not progress):
        rate = cosine_rate(phase.rate, step, phase.iterations)
        for group in optimizer.param_groups:
            group["lr"] = rate
        loss = loss_fn(variables, phase.frames, rng)
        optimizer.zero_grad()
        loss.backward()
        if not torch.isfinite(variables.grad).all():
            raise FloatingPointError(f"{phase.name}: the gradient at iteration {step} is not finite "
                                     f"({variables.grad.tolist()})")
        row = {"phase": phase.name, "iteration": step, "loss": loss.item(), "learning_rate": rate,
               **describe(variables.detach())}
        optimizer.step()
        history.append(row)
        logger.info("%s %d/%d: loss %.5g, %s", phase.name, step + 1, phase.iterations, row["loss"],
                    ", ".join(f"{k} {v:.4g}" for k, v in row.items() if k not in ("phase", "iteration", "loss")))
        state = FitState(phase.name, step + 1, variables.detach().clone(), optimizer.state_dict(), history,
                         rng.bit_generator.state, key)
        write_atomic(checkpoint, lambda p, s=state: torch.save(s, p))
    return variables.detach(), history


def log_values(values: dict[str, float], names: Sequence[str]) -> torch.Tensor:
    """Named positive values as the log-space vector a fit works on."""
    bad = [n for n in names if not (n in values and values[n] > 0)]
    if bad:
        raise ValueError(f"initial guess needs positive values for {', '.join(bad)}")
    return torch.log(torch.tensor([float(values[n]) for n in names], dtype=torch.float64))


def initial_guess(exp: dict) -> dict[str, float]:
    """The fit's starting values: the experiment's fit.initial_guess, else (real recordings) its material section;
    a virtual experiment's material is the truth, so there every value must be guessed."""
    section = exp["material"]
    guess = exp["fit"]["initial_guess"]
    names = PARAMETERS[section["convention"]]
    if exp.get("kind") == "virtual":
        missing = [name for name in names if name not in guess and not (name == "n" and "n" not in section)]
        if missing:
            raise ValueError(f"experiment {exp['name']}: a virtual experiment's material is the truth; give "
                             f"fit.initial_guess for {', '.join(missing)}")
        section = {}
    values = {name: guess.get(name, section.get(name, 1.0 if name == "n" else None)) for name in names}
    missing = [name for name, value in values.items() if value is None]
    if missing:
        raise ValueError(f"experiment {exp['name']}: no initial value for {', '.join(missing)} (fit.initial_guess "
                         "or material)")
    return values


def survey_velocities(estimate: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """The initial velocities a fit's survey tries every material with, by phase name: the velocity stage's
    ``estimate`` and a release from rest. The estimate was made with the material at its guess, whose different
    collapse it partly absorbs, and from one view the motion along the line of sight goes unseen."""
    return [("survey", estimate)] + ([("survey, from rest", np.zeros(3))] if np.any(estimate) else [])


def build_problem(exp: dict, obs: Observations, seed_file: str | Path, dtype=torch.float32) -> Problem:
    """The fit of experiment ``exp`` against ``obs``, from the seed particles in ``seed_file``."""
    seed = np.load(seed_file)
    start = material({**exp["material"], **initial_guess(exp)})  # never the truth, not even for the time step
    return Problem(simulator(exp, exp["simulation"]["resolution"], dtype=dtype, mat=start), obs,
                   torch.as_tensor(seed["positions"], dtype=dtype), torch.as_tensor(seed["density"],
                                                                                    dtype=torch.float32),
                   torch.as_tensor(seed["colour"], dtype=torch.float32), float(seed["spacing"]),
                   exp["material"]["convention"], exp["material"].get("density", 1000.0),
                   silhouette=exp["fit"]["loss"] == "silhouette")


def silhouette_objectives(exp: dict, recordings: str, matte: str, cameras: str, seed_file: str,
                          frames: int | None = None) -> dict[str, Callable[[np.ndarray], float]]:
    """The objective "loss" for ``rheo.fit.parallel.Evaluator``: the mean boundary distance (px) between the
    silhouettes simulated from z = (log-parameters, initial velocity) and the masks of frames 1 .. ``frames`` - 1
    (every frame if None)."""
    problem = build_problem(exp, load(recordings, matte, cameras, frames=frames), seed_file)
    target = SilhouetteTarget(problem.obs, problem.obs.frames - 1)
    count = len(problem.names)

    def loss(z: np.ndarray) -> float:
        with torch.no_grad():
            trajectory = problem.simulate(torch.as_tensor(z[:count]), torch.as_tensor(z[count:]), target.frames)
        return float(target.distances(trajectory.x.numpy(), problem.spacing).mean())

    return {"loss": loss}
