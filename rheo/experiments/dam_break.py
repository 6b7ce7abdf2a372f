"""A dam break simulated: the material released from its cuboid behind the channel's walls, the domain sized from
where the recording shows it going.

The gate is not simulated: the material is released at once at t = 0, and the time of the first recorded frame
after the release (the gate is half open there and the material already moving) is a fitted offset. One rollout
recorded at a fine spacing serves every candidate offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from rheo.experiments.virheometry import Setup
from rheo.physics import Box, Floor, HerschelBulkley, Simulator, kernels
from rheo.physics.simulator import Trajectory


class DamBreakError(ValueError):
    """A dam break that cannot be simulated as asked."""


def floor_footprint(setup: Setup, frame: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Low and high (x, z) corners of where the rays through a silhouette's pixels meet the floor: a bound on the
    material's extent on the floor (pixels of the material's top land beyond it, away from the camera)."""
    camera = setup.camera
    origin, dirs = camera.pixel_rays()
    rays = dirs[setup.masks[frame]]
    down = rays[:, 1] < -1e-9
    if not down.any():
        raise DamBreakError(f"{setup.folder}: no silhouette pixel of frame {frame % len(setup.masks) + 1} looks "
                            "down at the floor")
    hits = origin[None, :] + rays[down] * (-origin[1] / rays[down, 1])[:, None]
    return hits[:, [0, 2]].min(axis=0), hits[:, [0, 2]].max(axis=0)


@dataclass(frozen=True)
class DamBreakScene:
    """The simulated dam break: a cube of ``domain_size`` from ``domain_origin`` on ``resolution`` cells per axis,
    the floor and the setup's walls as colliders, ``particles_per_cell`` particles per cell and axis."""

    setup: Setup
    domain_size: float
    domain_origin: tuple[float, float, float]
    resolution: int
    particles_per_cell: int

    @property
    def dx(self) -> float:
        return self.domain_size / self.resolution

    @property
    def spacing(self) -> float:
        return self.dx / self.particles_per_cell

    def colliders(self) -> list:
        """The floor, and every wall above it as a box (the file's first box is the floor slab)."""
        floor_contact = next((w.contact for w in self.setup.walls if w.high[1] <= 0.0), "sticky")
        boxes = [Box(center=tuple(0.5 * (np.add(w.low, w.high))), half_extents=tuple(0.5 * np.subtract(w.high, w.low)),
                     contact=w.contact) for w in self.setup.walls if w.high[1] > 0.0]
        return [Floor(height=0.0, contact=floor_contact), *boxes]

    def simulator(self, material: HerschelBulkley) -> Simulator:
        return Simulator(material, resolution=self.resolution, domain_size=self.domain_size,
                         domain_origin=self.domain_origin, colliders=self.colliders())

    def initial_positions(self) -> np.ndarray:
        """Particles at the centres of a lattice of ``spacing`` filling the cuboid."""
        low, high = self.setup.cuboid
        counts = np.maximum(np.round((high - low) / self.spacing).astype(int), 1)
        axes = [low[a] + (np.arange(counts[a]) + 0.5) * (high[a] - low[a]) / counts[a] for a in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)

    def particle_volume(self) -> float:
        low, high = self.setup.cuboid
        return float(np.prod(high - low)) / len(self.initial_positions())

    def rollout(self, material: HerschelBulkley, duration: float, sample_dt: float) -> Trajectory:
        """Positions every ``sample_dt`` seconds from the release to ``duration``."""
        frames = int(np.ceil(duration / sample_dt - 1e-9))
        with torch.no_grad():
            return self.simulator(material).rollout(
                torch.as_tensor(self.initial_positions(), dtype=torch.float32), torch.zeros(3), frames=frames,
                frame_dt=sample_dt, particle_volume=self.particle_volume())


def dam_break_scene(setup: Setup, resolution: int, particles_per_cell: int = 2, margin: float = 0.2) -> DamBreakScene:
    """The scene of ``setup``: a cube holding the cuboid and the last frame's floor footprint (grown by ``margin``
    of its size on every side) above ``kernels.BOUND`` boundary cells on every face, on ``resolution`` cells."""
    low, high = floor_footprint(setup)
    cuboid_low, cuboid_high = setup.cuboid
    low = np.minimum(low, cuboid_low[[0, 2]])
    high = np.maximum(high, cuboid_high[[0, 2]])
    grow = margin * (high - low)
    low, high = low - grow, high + grow
    low[0] = 0.0  # nothing passes the back wall
    extent = max(*(high - low), (1.0 + margin) * setup.height)
    # boundary cells on every face, one more behind the back wall and under the floor for their colliders
    cells_inside = resolution - 2 * kernels.BOUND - 1
    if cells_inside < 8:
        raise DamBreakError(f"resolution {resolution} leaves fewer than 8 cells for the material")
    dx = extent / cells_inside
    origin = (low[0] - (kernels.BOUND + 1) * dx, -(kernels.BOUND + 1) * dx,
              0.5 * (low[1] + high[1]) - 0.5 * resolution * dx)
    return DamBreakScene(setup, resolution * dx, origin, resolution, particles_per_cell)
