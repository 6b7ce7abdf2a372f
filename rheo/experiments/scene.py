"""An experiment's simulated scene (material, domain, floor, gravity), shared by the virtual lab and the fit."""

from __future__ import annotations

import numpy as np
import torch

from rheo.physics import Floor, HerschelBulkley, Simulator, kernels
from rheo.physics.simulator import particle_bounds


def material(cfg: dict) -> HerschelBulkley:
    """An experiment's material section as a rheo material (PAC-NeRF's sigma_y, eta converted)."""
    common = {"mu": cfg["mu"], "lam": cfg["lam"], "density": cfg.get("density", 1000.0)}
    if cfg["convention"] == "pacnerf":
        return HerschelBulkley.from_pacnerf(cfg["sigma_y"], cfg["eta"], **common)
    return HerschelBulkley(tau_y=cfg["tau_y"], K=cfg["K"], n=cfg.get("n", 1.0), **common)


def simulator(exp: dict, resolution: int, dtype=torch.float32, mat: HerschelBulkley | None = None) -> Simulator:
    """The experiment's scene at ``resolution`` (its own material unless ``mat`` is given): floor at y = 0, three
    grid cells below it in the domain; the step fixed by ``substeps`` where the experiment sets it."""
    sim_cfg = exp["simulation"]
    size = sim_cfg["domain_size"]
    substeps = sim_cfg.get("substeps")
    dt = None if substeps is None else sim_cfg["duration"] / (sim_cfg["frames"] - 1) / substeps
    return Simulator(material(exp["material"]) if mat is None else mat, resolution=resolution, domain_size=size,
                     domain_origin=_domain_origin(size / resolution), dtype=dtype,
                     colliders=[Floor(height=0.0, contact=sim_cfg["floor"], friction=sim_cfg["floor_friction"])],
                     gravity=sim_cfg["gravity"], dt=dt)


def _domain_origin(dx: float) -> tuple[float, float, float]:
    return (0.0, -kernels.BOUND * dx, 0.0)


def start_bounds(simulation: dict) -> tuple[np.ndarray, np.ndarray]:
    """The box (low, high corners) particles may start in, for an experiment's simulation section."""
    dx = simulation["domain_size"] / simulation["resolution"]
    return particle_bounds(_domain_origin(dx), simulation["domain_size"], dx)


def particle_spacing(simulation: dict) -> float:
    """Particle spacing of an experiment's simulation section: ``particles_per_cell`` per cell and axis."""
    return simulation["domain_size"] / simulation["resolution"] / simulation["particles_per_cell"]
