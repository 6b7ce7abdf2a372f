"""A recovered material on a new shape: the mesh scaled and set on the floor, simulated, filmed with the lab
renderer."""

from __future__ import annotations

import numpy as np
import torch

from rheo.geometry.proxy import load_mesh, voxelize
from rheo.physics import HerschelBulkley, Simulator


def mesh_particles(path: str, height: float, base_centre: tuple[float, float], spacing: float) -> np.ndarray:
    """Particles filling the mesh at ``path`` scaled to ``height``, its base centre at (x, 0, z) = ``base_centre``."""
    mesh = load_mesh(path, require_watertight=False)
    mesh.apply_scale(height / mesh.extents[1])
    lo, hi = mesh.bounds
    mesh.apply_translation([base_centre[0] - 0.5 * (lo[0] + hi[0]), -lo[1], base_centre[1] - 0.5 * (lo[2] + hi[2])])
    return voxelize(mesh, spacing, directions=3).particles


def simulate(sim: Simulator, particles: np.ndarray, spacing: float, duration: float, frames: int,
             progress: bool = True) -> np.ndarray:
    """Positions (frames, N, 3) of the particles released at rest."""
    x0 = torch.as_tensor(particles, dtype=sim.dtype)
    with torch.no_grad():
        tr = sim.rollout(x0, torch.zeros(3, dtype=sim.dtype), frames=frames - 1, frame_dt=duration / (frames - 1),
                         particle_volume=spacing**3, progress=progress)
    return tr.x.numpy()


def recovered_material(herschel_bulkley: dict) -> HerschelBulkley:
    return HerschelBulkley(**{k: herschel_bulkley[k] for k in ("tau_y", "K", "n", "mu", "lam", "density")})
