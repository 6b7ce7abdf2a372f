"""A dam break simulated: the material released from its cuboid behind the channel's walls, in a domain sized from
how far the recording shows it going.

The base model does not simulate the gate: the material is released at once at t = 0, and the time of the first
recorded frame after the release (the gate is half open there and the material already moving) is a fitted offset.
One rollout recorded at a fine spacing serves every candidate offset. The channel is symmetric about its mid-plane:
the half z < depth / 2 is simulated and mirrored, at half the cost of the whole. ``Effects`` adds what the base
model leaves out (a gate lifted at a finite speed, a floor the material slides on, ...).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import torch

from rheo.experiments.effects import Effects
from rheo.experiments.virheometry import CONTAINER_RIM, Setup, StaticBox, container_silhouette
from rheo.physics import Box, Floor, HerschelBulkley, Simulator, dam_break_gate, kernels
from rheo.physics.optional import OPEN_LAYER
from rheo.physics.simulator import DEFAULT_CFL, Trajectory
from rheo.vision.cameras import Camera

WALL_CELLS = 2  # the least thickness of a wall, in grid cells
GRAVITY = 9.81  # m/s^2, as in the recordings' setup (981 cm/s^2)
# walls grown by this fraction of a cell: a node on a wall's face belongs to the wall, not to a rounding error
FACE_MARGIN = 1e-3


def floor_footprint(camera: Camera, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Low and high (x, z) corners of where the rays through a mask's pixels meet the floor (None if no pixel looks
    down at it): a bound on the extent on the floor of what the mask shows (the rays of points above the floor land
    beyond them, away from the camera)."""
    origin, dirs = camera.pixel_rays()
    rays = dirs[mask]
    rays = rays[rays[:, 1] < -1e-9]
    if not len(rays):
        return None
    hits = origin[None, :] + rays * (-origin[1] / rays[:, 1])[:, None]
    return hits[:, [0, 2]].min(axis=0), hits[:, [0, 2]].max(axis=0)


def runout(setup: Setup, rim: int = CONTAINER_RIM) -> float:
    """How far (m) past the gate the last frame shows material: the floor footprint of its pixels outside the
    container (grown by ``rim`` px, the container's own outline in the recordings)."""
    footprint = floor_footprint(setup.camera, setup.masks[-1] & ~container_silhouette(setup, rim))
    return 0.0 if footprint is None else max(float(footprint[1][0]) - setup.width, 0.0)


@dataclass(frozen=True)
class DamBreakScene:
    """The simulated dam break: a cube of ``domain_size`` from ``domain_origin`` on ``resolution`` cells per axis,
    the floor and the setup's walls as colliders, ``particles_per_cell`` particles per cell and axis; the half of
    the material before ``mid_plane`` is simulated when one is given. Time steps are ``cfl`` times the time a wave
    (elastic, plus the fastest flow) takes to cross a cell; with ``transfer_cfl``, particles and grid exchange
    velocities once per that share of the time the fastest flow takes to cross a cell (else at every step)."""

    setup: Setup
    domain_size: float
    domain_origin: tuple[float, float, float]
    resolution: int
    particles_per_cell: int
    mid_plane: float | None = None  # z of the plane of symmetry when the half before it is simulated
    cfl: float = DEFAULT_CFL
    transfer_cfl: float | None = None

    @property
    def flow_speed(self) -> float:
        """About the fastest a dam break flows: the free fall from the material's height (m/s)."""
        return math.sqrt(2.0 * GRAVITY * self.setup.height)

    @property
    def dx(self) -> float:
        return self.domain_size / self.resolution

    @property
    def spacing(self) -> float:
        return self.dx / self.particles_per_cell

    def colliders(self, effects: Effects | None = None) -> list:
        """The floor, every wall above it as a box (the file's first box is the floor slab), and a lifted gate."""
        effects = effects or Effects()

        def held(contact: str) -> dict:  # a sticky contact slips by Navier's law where the effects say so
            if contact != "sticky" or effects.wall_slip is None:
                return {"contact": contact}
            return {"contact": "navier", "friction": effects.wall_slip}

        floor_contact = next((w.contact for w in self.setup.walls if w.high[1] <= 0.0), "sticky")
        floor = Floor(height=0.0, **held(floor_contact)) if effects.floor_friction is None else \
            Floor(height=0.0, contact="friction", friction=effects.floor_friction)
        cuboid_low, cuboid_high = self.setup.cuboid
        boxes = []
        for wall in standing_walls(self.setup):
            low, high = np.array(wall.low), np.array(wall.high)
            # a wall thinner than the grid holds no node and lets the material through: thickened outwards
            thick = WALL_CELLS * self.dx
            behind, beyond = high <= cuboid_low + 1e-9, low >= cuboid_high - 1e-9
            low = np.where(behind, np.minimum(low, high - thick), low) - FACE_MARGIN * self.dx
            high = np.where(beyond, np.maximum(high, low + thick), high) + FACE_MARGIN * self.dx
            boxes.append(Box(center=tuple(0.5 * (low + high)), half_extents=tuple(0.5 * (high - low)),
                             **held(wall.contact)))
        if effects.gate_lift_time > 0:
            boxes.append(self.gate(effects.gate_lift_time))
        return [floor, *boxes]

    def gate(self, lift_time: float) -> Box:
        """A slip gate plate on the cuboid's front face, two cells thick, across the channel and three material
        heights tall, sliding up from the floor at the speed that clears the material's height in ``lift_time``."""
        _, high = self.setup.cuboid
        thick = WALL_CELLS * self.dx
        low = np.array([high[0], 0.0, -thick]) - FACE_MARGIN * self.dx
        top = np.array([high[0] + thick, 3.0 * self.setup.height, self.setup.depth + thick]) + FACE_MARGIN * self.dx
        return dam_break_gate(self.setup.height / lift_time, center=tuple(0.5 * (low + top)),
                              half_extents=tuple(0.5 * (top - low)))

    @property
    def simulated_cuboid(self) -> tuple[np.ndarray, np.ndarray]:
        """The part of the cuboid that is simulated: the half before the mid-plane, or all of it."""
        low, high = self.setup.cuboid
        return low, high if self.mid_plane is None else np.array([high[0], high[1], self.mid_plane])

    def simulator(self, material: HerschelBulkley, effects: Effects | None = None, *, duration: float) -> Simulator:
        """The scene's simulator of ``material`` with ``effects``, for a rollout of ``duration`` s (the open drag's
        span)."""
        effects = effects or Effects()
        physics = effects.physics
        if any(physics.open_drag):
            physics = dataclasses.replace(physics, open_layer=OPEN_LAYER * self.setup.height, open_span=duration)
        tilt = effects.gravity_tilt
        gravity = (0.0, -GRAVITY, 0.0) if tilt == 0 else (GRAVITY * math.sin(tilt), -GRAVITY * math.cos(tilt), 0.0)
        if effects.density_factor != 1:
            material = dataclasses.replace(material, density=material.density * effects.density_factor)
        transfer_dt = None if self.transfer_cfl is None else self.transfer_cfl * self.dx / self.flow_speed
        return Simulator(material, resolution=self.resolution, domain_size=self.domain_size,
                         domain_origin=self.domain_origin, colliders=self.colliders(effects), gravity=gravity,
                         symmetry_z=self.mid_plane, physics=physics, cfl=self.cfl, transfer_dt=transfer_dt)

    @cached_property
    def initial_positions(self) -> np.ndarray:
        """Particles at the centres of a lattice of ``spacing`` filling the simulated cuboid."""
        low, high = self.simulated_cuboid
        counts = np.maximum(np.round((high - low) / self.spacing).astype(int), 1)
        axes = [low[a] + (np.arange(counts[a]) + 0.5) * (high[a] - low[a]) / counts[a] for a in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)

    @property
    def particle_volume(self) -> float:
        low, high = self.simulated_cuboid
        return float(np.prod(high - low)) / len(self.initial_positions)

    def rollout(self, material: HerschelBulkley, duration: float, sample_dt: float,
                effects: Effects | None = None) -> Trajectory:
        """The simulated particles every ``sample_dt`` seconds from the release to ``duration``: the half before the
        mid-plane where the scene has one (``positions`` gives the whole material's)."""
        effects = effects or Effects()
        frames = int(np.ceil(duration / sample_dt - 1e-9))
        simulator = self.simulator(material, effects, duration=frames * sample_dt)
        # the flow speed, not the simulator's own bound (a fall from the domain's height), sets the step (an unstable
        # step is retried at half); a gate, a slip plate sliding along its own face, pushes nothing
        dt, _ = simulator.time_step(sample_dt, self.flow_speed)
        with torch.no_grad():
            return simulator.rollout(torch.as_tensor(self.initial_positions, dtype=torch.float32), torch.zeros(3),
                                     frames=frames, frame_dt=sample_dt, particle_volume=self.particle_volume, dt=dt)

    def positions(self, trajectory: Trajectory) -> np.ndarray:
        """The whole material's positions (frames, N, 3) in a ``rollout``: the simulated particles and, where only the
        half was simulated, their mirror images."""
        x = trajectory.x if self.mid_plane is None else trajectory.positions_with_mirror_images(self.mid_plane)
        return x.numpy()


def standing_walls(setup: Setup) -> list[StaticBox]:
    """The walls above the floor (the floor slab is simulated as the plane y = 0)."""
    return [w for w in setup.walls if w.high[1] > 0.0]


def mid_plane(setup: Setup) -> float | None:
    """z of the channel's mid-plane when the walls are symmetric about it, else None."""
    middle = 0.5 * setup.depth

    def mirrored(wall: StaticBox) -> np.ndarray:
        return np.array([[*wall.low[:2], 2 * middle - wall.high[2]], [*wall.high[:2], 2 * middle - wall.low[2]]])

    walls = standing_walls(setup)
    same = all(any(other.contact == wall.contact and np.allclose(mirrored(wall), [other.low, other.high], atol=1e-9)
                   for other in walls) for wall in walls)
    return middle if same else None


def dam_break_scene(setup: Setup, cells_per_height: int = 8, cells_across: int = 10, particles_per_cell: int = 2,
                    margin: float = 0.25, reach: float | None = None, cfl: float = DEFAULT_CFL,
                    transfer_cfl: float | None = None) -> DamBreakScene:
    """The scene of ``setup`` on cells of at most H / ``cells_per_height`` and at most the channel's depth /
    ``cells_across``: a cube holding the channel and the material that leaves it, the ``runout`` past the gate and
    as far to either side (grown by ``margin``), above ``kernels.BOUND`` boundary cells on every face and one more
    cell behind the back wall and under the floor. When the walls are symmetric about the channel's mid-plane, the
    half before it is simulated, and the cube needs to reach only a few cells past it. ``reach`` (m) replaces the
    recorded runout where there is no recording yet.

    The channel's walls lie on node planes (a node on a wall's face belongs to the wall): the back wall at x = 0,
    the floor at y = 0, the side walls at z = 0 and z = depth, an even number of cells apart (the mid-plane too).
    Off the node planes, the channel's width on the grid changes by up to two cells with the resolution."""
    cells = math.ceil(max(setup.depth * cells_per_height / setup.height, cells_across) - 1e-9)
    dx = setup.depth / (cells + cells % 2)  # an even number: the mid-plane is a node plane too
    spread = (1.0 + margin) * max(runout(setup) if reach is None else reach, 0.5 * setup.height)
    middle = mid_plane(setup)
    low = np.array([0.0, -spread])
    high = np.array([setup.width + spread, setup.depth + spread if middle is None
                     else middle + kernels.MIRROR_NODES * dx])
    extent = max(*(high - low), (1.0 + margin) * setup.height)
    resolution = int(np.ceil(extent / dx)) + 2 * kernels.BOUND + 1
    origin = (-(kernels.BOUND + 1) * dx, -(kernels.BOUND + 1) * dx,
              -round((0.5 * resolution * dx - 0.5 * (low[1] + high[1])) / dx) * dx)
    return DamBreakScene(setup, resolution * dx, origin, resolution, particles_per_cell, middle, cfl, transfer_cfl)
