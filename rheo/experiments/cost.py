"""What an experiment will cost (memory and time on the CPU) before anything runs, and the limits it must keep."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from rheo.config import ConfigError
from rheo.geometry.shapes import analytic_volume

# bytes per particle and per grid node of a forward simulation (two states of x, v, C, F and the eigen-decomposition;
# mass, momentum and velocity per node), float32
PARTICLE_BYTES = 2 * 24 * 4 + 12 * 4
NODE_BYTES = 7 * 4
# a step kept for the backward pass (rheo.physics.Simulator.bytes_per_step: the same particle arrays, the grid's with
# their gradients), in chunks of at most CHECKPOINT_BYTES
TAPE_PARTICLE_BYTES = PARTICLE_BYTES
TAPE_NODE_BYTES = 2 * NODE_BYTES
CHECKPOINT_BYTES = 2**30
# the lab renderer at twice the resolution, per output pixel, measured on 320 x 240 and 640 x 480 views
RENDER_BYTES_PER_PIXEL = 800
RENDER_SECONDS_PER_PIXEL = 1.2e-6
# one core's forward step, per particle (docs/performance.md); a backward pass costs twice a forward one
SECONDS_PER_PARTICLE_STEP = 1.0e-6
SECONDS_PER_NODE_STEP = 2.0e-8
FIT_WORKERS = 2


@dataclass(frozen=True)
class Cost:
    """Peak memory and total time of an experiment's stages, with what drives them."""

    memory_bytes: float
    seconds: float
    memory_driver: str
    time_driver: str

    @property
    def memory_gb(self) -> float:
        return self.memory_bytes / 1e9

    @property
    def hours(self) -> float:
        return self.seconds / 3600.0


def proxy_volume(proxy: dict) -> float:
    """The starting shape's volume (m^3): analytic for a primitive, the mesh's own (or its box's) for a mesh."""
    volume = analytic_volume(proxy)
    if volume is not None:
        return volume
    from rheo.geometry.proxy import from_config  # the mesh library: imported only for a mesh file

    mesh, _ = from_config(proxy)
    return float(mesh.volume) if mesh.is_watertight else float(math.prod(mesh.extents))


def simulation_steps(exp: dict) -> int:
    """Steps over the recorded duration: ``substeps`` per frame interval, else the simulator's step for the
    material and a fall across the domain."""
    sim = exp["simulation"]
    intervals = sim["frames"] - 1
    if sim.get("substeps"):
        return intervals * sim["substeps"]
    from rheo.experiments.scene import material  # the simulator's modules: imported only where needed
    from rheo.physics.simulator import time_step

    fall_speed = math.sqrt(2.0 * 9.8 * sim["domain_size"])
    _, steps = time_step(sim["duration"] / intervals, sim["domain_size"] / sim["resolution"],
                         material(exp["material"]), fall_speed)
    return intervals * steps


def _fit_simulations(exp: dict) -> float:
    """Full-length simulations a fit runs: the survey and the velocity refinement on the warm-up frames, the simplex
    searches, and the surface designs (a composite design over the fitted parameters)."""
    fit, frames = exp.get("fit", {}), exp["simulation"]["frames"] - 1
    warmup, full = fit.get("warmup", {}), fit.get("full", {})
    parameters = 4 if exp["material"]["convention"] == "pacnerf" else 5
    design = 2**parameters + 2 * parameters + 1
    short = (warmup.get("samples", 64) + warmup.get("velocity_evaluations", 30)) * warmup.get("frames", 5) / frames
    return short + full.get("evaluations", 75) + full.get("rounds", 3) * design


def experiment_cost(exp: dict) -> Cost | None:
    """The estimated peak memory and total time of an experiment (a validated config with its defaults); None for
    one that simulates nothing it can say in advance (no proxy, or frames and duration from a recording)."""
    sim = exp.get("simulation", {})
    if "proxy" not in exp or "frames" not in sim or "duration" not in sim:
        return None
    cams = exp.get("cameras", {})
    spacing = sim["domain_size"] / sim["resolution"] / sim["particles_per_cell"]
    particles = proxy_volume(exp["proxy"]) / spacing**3
    nodes = sim["resolution"] ** 3
    steps = simulation_steps(exp)
    step_seconds = particles * SECONDS_PER_PARTICLE_STEP + nodes * SECONDS_PER_NODE_STEP
    simulation_bytes = particles * PARTICLE_BYTES + nodes * NODE_BYTES
    scene = f"a {sim['resolution']}^3 grid, {particles:,.0f} particles, {steps:,} steps"

    memory = {f"the simulation: {scene}": simulation_bytes}
    seconds = {f"one simulation: {scene}": steps * step_seconds}
    if exp.get("kind") == "virtual":
        memory[f"the lab's {sim['frames']:,} stored frames of {particles:,.0f} particles"] = (
            sim["frames"] * particles * 12 + simulation_bytes)
        width, height, count = cams.get("width", 400), cams.get("height", 400), cams.get("count", 11)
        views = f"{count} cameras of {width} x {height} px, {sim['frames']:,} frames"
        memory[f"the lab's renderer: {views}, {FIT_WORKERS} at a time"] = (
            FIT_WORKERS * width * height * RENDER_BYTES_PER_PIXEL)
        seconds[f"the lab's renderer: {views}"] = count * sim["frames"] * width * height * RENDER_SECONDS_PER_PIXEL
    velocity = exp.get("fit", {}).get("velocity", {})
    tape_steps = steps * velocity.get("frames", 2) / (sim["frames"] - 1)
    tape_step_bytes = particles * TAPE_PARTICLE_BYTES + nodes * TAPE_NODE_BYTES
    memory[f"the velocity stage's gradient tape: {scene}"] = max(tape_step_bytes,
                                                                 min(tape_steps * tape_step_bytes, CHECKPOINT_BYTES))
    seconds[f"the velocity stage: {scene}"] = 3 * velocity.get("iterations", 20) * tape_steps * step_seconds
    runs = _fit_simulations(exp)
    memory[f"the fit's simulations, {FIT_WORKERS} at a time: {scene}"] = FIT_WORKERS * simulation_bytes
    seconds[f"the fit's {runs:,.0f} simulations, {FIT_WORKERS} at a time: {scene}"] = (
        runs * steps * step_seconds / FIT_WORKERS)

    memory_driver = max(memory, key=memory.get)
    time_driver = max(seconds, key=seconds.get)
    return Cost(memory[memory_driver], sum(seconds.values()), memory_driver, time_driver)


def _about(value: float) -> str:
    """A figure to about two significant digits, without an exponent."""
    return f"{value:,.0f}" if value >= 100 else f"{value:.2g}"


def default_memory_limit_gb() -> float:
    """Four fifths of this machine's memory."""
    try:
        return 0.8 * os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1e9
    except (ValueError, OSError):
        return 16.0


def check_cost(cost: Cost | None, limits: dict, source: str) -> None:
    """Refuse an experiment whose estimate exceeds ``limits`` (memory_gb, null for four fifths of this machine's
    memory; hours), saying the limit and how to raise it."""
    if cost is None:
        return
    memory_limit = limits.get("memory_gb") or default_memory_limit_gb()
    how = "reduce it, or raise limits.{0} in config/config.yaml or run with --config 'limits={{{0}: {1}}}'"
    if cost.memory_gb > memory_limit:
        raise ConfigError(f"{source}: would need about {_about(cost.memory_gb)} GB of memory ({cost.memory_driver}), "
                          f"above the limit of {_about(memory_limit)} GB; "
                          + how.format("memory_gb", math.ceil(cost.memory_gb * 1.5)))
    if cost.hours > limits["hours"]:
        raise ConfigError(f"{source}: would take about {_about(cost.hours)} h on the CPU ({cost.time_driver}), above "
                          f"the limit of {limits['hours']:g} h; " + how.format("hours", math.ceil(cost.hours * 1.5)))
