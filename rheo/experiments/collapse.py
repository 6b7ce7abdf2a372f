"""Column collapse of the thesis (Tables 4.1 and 4.2): a cylinder of Bingham material on a sticky floor.

The thesis gives (sigma_y, eta) in PAC-NeRF's convention (see ``HerschelBulkley.from_pacnerf``).
The height is the top of the material above the floor (highest particle plus half a particle spacing). The floor is
wide enough (a 1.5 m box by default) that the low-yield piles never reach the domain walls.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from rheo.geometry.sampling import cylinder
from rheo.physics import Floor, HerschelBulkley, Simulator


@dataclass(frozen=True)
class CollapseSetup:
    domain_size: float = 1.5
    resolution: int = 48
    radius: float = 0.2
    height: float = 0.4
    density: float = 1000.0
    gravity: float = 9.8
    duration: float = 1.0
    frames: int = 24



def simulate_collapse(material: HerschelBulkley, setup: CollapseSetup, progress: bool = False) -> dict:
    """Heights of the material over time (m), from t = 0 to ``setup.duration``."""
    sim = Simulator(material, resolution=setup.resolution, domain_size=setup.domain_size,
                    colliders=[Floor(height=3.0 * setup.domain_size / setup.resolution, contact="sticky")],
                    gravity=(0.0, -setup.gravity, 0.0))
    floor = 3.0 * sim.dx
    spacing = sim.dx / 2
    center = (setup.domain_size / 2, setup.domain_size / 2)
    x0, vol = cylinder(center, floor, setup.radius, setup.height, spacing, dtype=torch.float32)
    tr = sim.rollout(x0, torch.zeros(3), frames=setup.frames, frame_dt=setup.duration / setup.frames,
                     particle_volume=vol, progress=progress)
    heights = tr.x[..., 1].max(dim=1).values + spacing / 2 - floor
    return {"times": tr.times.tolist(), "heights": heights.tolist(), "height": float(heights[-1]),
            "dt": tr.dt, "particles": len(x0)}
