"""Differentiable MLS-MPM rollouts: Warp kernels inside a torch.autograd.Function, with chunked checkpointing.

A rollout advances particles from an initial state through ``frames`` frames of ``substeps`` steps each and returns
the particle states (x, v, C, F) at every frame. Gradients of any scalar function of those states flow back to the
initial positions and velocities, the material parameters and the boundary parameters.

Memory stays bounded on long rollouts: the forward pass keeps one state snapshot per chunk of steps; the backward pass
recomputes one chunk at a time with Warp's tape and runs its adjoint. The last chunk's tape is kept from the forward
pass, so a rollout that fits in one chunk is never recomputed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import threading
from dataclasses import dataclass

import numpy as np
import torch
import warp as wp
from tqdm.auto import tqdm

from rheo.physics import kernels
from rheo.physics.boundaries import Collider, pack
from rheo.physics.device import SimulationError, resolve_device
from rheo.physics.materials import Material, MaterialError
from rheo.physics.optional import OptionalPhysics

logger = logging.getLogger(__name__)

# arguments of kernels.grid_update that change every step
GRID_UPDATE_TIME, GRID_UPDATE_LOW = 3, 12
ADD_MOMENTUM_LOW = 2
CAPILLARY_STRESS_TIME, CAPILLARY_STRESS_LOW = 3, 9
CAPILLARY_FORCE_LOW = 3
# the default step: this share of the time a wave (elastic, plus the fastest flow) takes to cross a cell
DEFAULT_CFL = 0.4


def time_step(frame_dt: float, dx: float, material: Material, max_speed: float, cfl: float = DEFAULT_CFL,
              surface_tension: float = 0.0) -> tuple[float, int]:
    """The largest step that divides the frame interval ``frame_dt`` on cells of ``dx`` and obeys the CFL limit
    (waves plus a flow of ``max_speed``), the viscous one and, with ``surface_tension``, the capillary one; and the
    steps per interval."""
    dt_max = min(cfl * dx / (material.wave_speed() + max_speed), material.diffusive_time_step(dx))
    if surface_tension > 0.0:  # the period of the shortest capillary wave the grid holds, over 2 pi
        dt_max = min(dt_max, math.sqrt(material.density * dx**3 / (2 * math.pi * surface_tension)))
    substeps = max(1, math.ceil(frame_dt / dt_max - 1e-9))
    return frame_dt / substeps, substeps


# Warp's default device and its CUDA context guard are shared by the threads of a process, so two threads that
# simulate at once (a fit's searches side by side) would switch each other's device mid-rollout
_WARP_LOCK = threading.RLock()


def _new_lock() -> None:
    global _WARP_LOCK
    _WARP_LOCK = threading.RLock()


os.register_at_fork(after_in_child=_new_lock)  # a worker forked while a thread simulates starts unlocked


@contextlib.contextmanager
def _on_device(device: str):
    """Warp's default device set to ``device`` for the block, one thread of the process at a time."""
    with _WARP_LOCK, wp.ScopedDevice(device):
        yield


def _host(arr: wp.array) -> torch.Tensor:
    """A Warp array's values as a CPU tensor (a view on the CPU, a copy from a GPU)."""
    return torch.from_numpy(arr.numpy())


def _assign(arr: wp.array, values: torch.Tensor) -> None:
    """Set a Warp array, wherever it lives, to a CPU tensor's values (shaped as ``_host`` gives them)."""
    arr.assign(np.ascontiguousarray(values.detach().numpy()))


def particle_bounds(domain_origin, domain_size: float, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """The box (low, high corners) particles must start in: the domain less its boundary cells."""
    margin = kernels.BOUND * dx
    lo = np.asarray(domain_origin, dtype=float) + margin
    return lo, lo + domain_size - 2 * margin


class SimulationUnstable(SimulationError):
    """The simulation blew up even at the smallest allowed time step."""


class _Unstable(Exception):
    def __init__(self, step: int) -> None:
        super().__init__(step)
        self.step = step


@dataclass(frozen=True)
class Trajectory:
    """Particle states at every frame: x, v of shape (frames + 1, N, 3); C, F of shape (frames + 1, N, 3, 3)."""

    x: torch.Tensor
    v: torch.Tensor
    C: torch.Tensor
    F: torch.Tensor
    times: torch.Tensor
    dt: float
    substeps: int

    def positions_with_mirror_images(self, z: float) -> torch.Tensor:
        """x with the particles' mirror images in the plane z = ``z`` appended: the whole of a flow simulated as its
        half about a plane of symmetry (``Simulator(symmetry_z=z)``)."""
        mirror_x = self.x * torch.tensor([1.0, 1.0, -1.0], dtype=self.x.dtype)
        mirror_x[..., 2] += 2.0 * z
        return torch.cat([self.x, mirror_x], dim=1)


class Simulator:
    """A 3D MLS-MPM simulator on the cube ``domain_origin`` + [0, domain_size]^3 with ``resolution`` cells per axis.

    ``gravity`` is a vector in m/s^2 (y is up). Particles must stay ``kernels.BOUND`` cells away from the domain faces,
    which act as slip walls. ``checkpoint_mb`` bounds the memory kept for the backward pass.

    With ``symmetry_z``, a node plane z = ``symmetry_z``, the particles given are the half z < ``symmetry_z`` of a flow
    symmetric about that plane (with its colliders): the grid gets their mirror images' share too, so the half
    moves exactly as in the whole flow at half the cost. Such rollouts are not differentiated.

    ``physics`` switches on effects beyond the base model (``OptionalPhysics``); a thixotropic rollout, or one with
    surface tension, is not differentiated.

    ``device`` is "cpu", "cuda" or "auto" (``set_default_device``'s choice if None); tensors go in and come out on
    the CPU whatever it is.

    ``dt`` fixes the step of every rollout (rounded to divide the frame interval); without it each rollout takes the
    largest step its material's stability limit allows; an unstable rollout is retried at half the step (and half the
    interval between transfers). The particle-grid transfers dissipate a little each time, so with a transfer at
    every step the flow depends on the step. With ``transfer_dt`` (s) the particles and the grid exchange velocities
    once per interval of at most that length (whole intervals per frame, whole steps per interval); between
    transfers the particles are held in place and the grid's momentum advances under their stresses, so the flow
    depends on the interval, not on the step. Such rollouts are not differentiated.
    """

    def __init__(self, material: Material, *, resolution: int = 32, domain_size: float = 1.0,
                 colliders: tuple[Collider, ...] | list[Collider] = (), gravity=(0.0, -9.8, 0.0),
                 dtype: torch.dtype = torch.float32, cfl: float = DEFAULT_CFL, max_halvings: int = 4,
                 checkpoint_mb: float = 1024.0, domain_origin=(0.0, 0.0, 0.0),
                 symmetry_z: float | None = None, physics: OptionalPhysics | None = None,
                 dt: float | None = None, transfer_dt: float | None = None, device: str | None = None) -> None:
        if not isinstance(material, Material):
            raise MaterialError(f"expected a Material, got {material!r}")
        if not (isinstance(resolution, int) and resolution >= 2 * kernels.BOUND + 2):
            raise SimulationError(f"grid resolution {resolution!r} must be an integer >= {2 * kernels.BOUND + 2}")
        if not (math.isfinite(domain_size) and domain_size > 0):
            raise SimulationError(f"domain size {domain_size!r} must be finite and > 0")
        if not (0 < cfl <= 1):
            raise SimulationError(f"CFL number {cfl!r} must lie in (0, 1]")
        if dt is not None and not (math.isfinite(dt) and dt > 0):
            raise SimulationError(f"time step {dt!r} s must be finite and > 0")
        if transfer_dt is not None and not (math.isfinite(transfer_dt) and transfer_dt > 0):
            raise SimulationError(f"transfer interval {transfer_dt!r} s must be finite and > 0")
        gravity = tuple(float(g) for g in gravity)
        if len(gravity) != 3 or not all(math.isfinite(g) for g in gravity):
            raise SimulationError(f"gravity {gravity!r} must be three finite numbers")
        self.material = material
        self.resolution = resolution
        self.domain_size = float(domain_size)
        origin = tuple(float(o) for o in domain_origin)
        if len(origin) != 3 or not all(math.isfinite(o) for o in origin):
            raise SimulationError(f"domain origin {domain_origin!r} must be three finite numbers")
        self.domain_origin = origin
        self.dx = self.domain_size / resolution
        self.symmetry_node = None if symmetry_z is None else self._node_plane(symmetry_z)
        self.colliders = tuple(colliders)
        self.collider_arrays = pack(self.colliders, self.domain_origin)
        self.gravity = gravity
        physics = OptionalPhysics() if physics is None else physics
        if not isinstance(physics, OptionalPhysics):
            raise SimulationError(f"physics must be an OptionalPhysics, got {physics!r}")
        self.physics = physics
        self.dtype = dtype
        self.scalar = kernels.scalar_type(dtype)
        self.cfl = cfl
        self.dt = dt
        self.transfer_dt = transfer_dt
        self.max_halvings = max_halvings
        self.checkpoint_mb = checkpoint_mb
        self.device = resolve_device(device)
        self.kernels = kernels.build(self.scalar)
        self._free_buffers: list[_Buffers] = []

    # ------------------------------------------------------------------ set-up helpers

    def _node_plane(self, z: float) -> int:
        """The index of the node plane at ``z``, with room for the mirror's fold on both sides."""
        index = (z - self.domain_origin[2]) / self.dx
        margin = kernels.BOUND + kernels.MIRROR_NODES
        if not (math.isfinite(index) and abs(index - round(index)) < 1e-6
                and margin <= round(index) <= self.resolution - 1 - margin):
            raise SimulationError(f"plane of symmetry z = {z!r} m must be a node plane (cells of {self.dx:.4g} m from "
                                  f"z = {self.domain_origin[2]:.4g} m) at least {margin} nodes inside the domain")
        return round(index)

    def material_parameters(self) -> torch.Tensor:
        return self.material.parameters(self.dtype)

    def boundary_parameters(self) -> torch.Tensor:
        return self.collider_arrays.parameters.to(self.dtype)

    def time_step(self, frame_dt: float, max_speed: float, material: Material | None = None) -> tuple[float, int]:
        """``time_step`` on this simulator's cells, with its CFL number and surface tension."""
        return time_step(frame_dt, self.dx, material or self.material, max_speed, self.cfl,
                         self.physics.surface_tension)

    def bytes_per_step(self, n_particles: int) -> int:
        """Memory the backward pass keeps per step: particle state, grid, their gradients, the eigen-decomposition."""
        size = 8 if self.dtype == torch.float64 else 4
        state = n_particles * 24 * size
        grid = self.resolution**3 * 7 * size
        eigen = n_particles * 12 * size  # decomposition of the trial strain, no gradient
        return 2 * (state + grid) + eigen

    def _acquire(self, n: int, steps: int, requires_grad: bool) -> _Buffers:
        """Per-step arrays, reused across rollouts of one size (allocating them costs about as much as a step).
        A rollout holds its buffers until its backward pass, so rollouts can be combined in one loss."""
        key = (n, steps if requires_grad else 0, requires_grad)
        for i, buf in enumerate(self._free_buffers):
            if buf.key == key:
                return self._free_buffers.pop(i)
        return _Buffers(self, n, steps, requires_grad)

    def _release(self, buf: _Buffers) -> None:
        self._free_buffers = [buf, *self._free_buffers[:1]]

    def particle_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box (low, high corners) particles must start in: the domain less its boundary cells."""
        return particle_bounds(self.domain_origin, self.domain_size, self.dx)

    def _check_particles(self, x0: torch.Tensor) -> None:
        if x0.ndim != 2 or x0.shape[1] != 3 or x0.shape[0] == 0:
            raise SimulationError(f"initial positions must have shape (N, 3) with N > 0, got {tuple(x0.shape)}")
        if not torch.isfinite(x0).all():
            raise SimulationError("initial positions contain NaN or infinite values")
        lo, hi = (torch.tensor(b, dtype=x0.dtype) for b in self.particle_bounds())
        bad = ((x0 < lo) | (x0 > hi)).any(dim=1)
        if bad.any():
            i = int(torch.nonzero(bad)[0])
            bounds = ", ".join(f"{a} in [{lo[k]:.4g}, {hi[k]:.4g}]" for k, a in enumerate("xyz"))
            raise SimulationError(
                f"{int(bad.sum())} particle(s) lie outside the simulation domain, e.g. particle {i} at "
                f"{x0[i].tolist()}: positions must have {bounds} m (domain {self.domain_size:g} m from "
                f"{list(self.domain_origin)}, {kernels.BOUND} boundary cells of {self.dx:.4g} m)")
        if self.symmetry_node is not None:
            plane = self.domain_origin[2] + self.symmetry_node * self.dx
            beyond = int((x0[:, 2] > plane).sum())
            if beyond:
                raise SimulationError(f"{beyond} particle(s) lie beyond the plane of symmetry z = {plane:.4g} m: "
                                      "give the half z <= the plane")

    # ------------------------------------------------------------------ rollout

    def rollout(self, x0: torch.Tensor, v0: torch.Tensor, *, frames: int, frame_dt: float, particle_volume: float,
                material_params: torch.Tensor | None = None, boundary_params: torch.Tensor | None = None,
                dt: float | None = None, progress: bool = False) -> Trajectory:
        """Simulate ``frames`` frames of ``frame_dt`` seconds from positions ``x0`` (N, 3) and velocity ``v0``.

        ``v0`` is one vector (3,) or one per particle (N, 3). ``material_params`` (ordered as the material's
        ``parameter_names``) and ``boundary_params`` (one row [friction, vx, vy, vz] per collider) default to the
        values the simulator was built with. Without ``dt`` the step is the simulator's own or else comes from the CFL
        limit; an unstable run is retried at half the step, up to ``max_halvings`` times.
        """
        x0 = x0.to(self.dtype)
        self._check_particles(x0.detach())
        origin = torch.tensor(self.domain_origin, dtype=self.dtype)
        if not (isinstance(frames, int) and frames >= 1):
            raise SimulationError(f"frames = {frames!r} must be an integer >= 1")
        if not (math.isfinite(frame_dt) and frame_dt > 0):
            raise SimulationError(f"frame interval {frame_dt!r} s must be finite and > 0")
        if not (math.isfinite(particle_volume) and particle_volume > 0):
            raise SimulationError(f"particle volume {particle_volume!r} m^3 must be finite and > 0")
        v0 = v0.to(self.dtype)
        if v0.shape == (3,):
            v0 = v0.expand_as(x0)
        if v0.shape != x0.shape or not torch.isfinite(v0).all():
            raise SimulationError(f"initial velocity must be finite with shape (3,) or {tuple(x0.shape)}, "
                                  f"got {tuple(v0.shape)}")
        mat = self.material_parameters() if material_params is None else material_params.to(self.dtype)
        try:
            material = dataclasses.replace(self.material, **dict(zip(self.material.parameter_names,
                                                                        mat.detach().tolist(), strict=True)))
        except (TypeError, ValueError) as err:
            raise MaterialError(f"material parameters {mat.detach().tolist()} for "
                                f"{self.material.parameter_names}: {err}") from err
        bnd = self.boundary_parameters() if boundary_params is None else boundary_params.to(self.dtype)
        if bnd.shape != (len(self.colliders), kernels.N_BOUNDARY_PARAMS) or not torch.isfinite(bnd).all():
            raise SimulationError(f"boundary parameters must be finite with shape ({len(self.colliders)}, 4)")
        if (bnd[:, kernels.B_FRICTION] < 0).any():
            raise SimulationError(f"friction coefficients {bnd[:, 0].tolist()} must be >= 0")
        dt = self.dt if dt is None else dt
        if dt is None:
            speed = float(v0.detach().norm(dim=-1).max()) + max(bnd[:, 1:].detach().norm(dim=-1).tolist(), default=0.0)
            speed += math.sqrt(2.0 * float(np.linalg.norm(self.gravity)) * self.domain_size)
            dt, substeps = self.time_step(frame_dt, speed, material)
        else:
            substeps = max(1, round(frame_dt / dt))
            dt = frame_dt / substeps
        steps_per_transfer = 1
        if self.transfer_dt is not None:  # whole transfer intervals per frame, whole steps per interval
            transfers = math.ceil(frame_dt / self.transfer_dt - 1e-9)
            steps_per_transfer = math.ceil(substeps / transfers - 1e-9)
            substeps = transfers * steps_per_transfer
            dt = frame_dt / substeps
        kernel_mat = material.kernel_vector(mat)
        for attempt in range(self.max_halvings + 1):
            try:
                with _on_device(self.device):
                    run = _Run(self, material, dt, substeps, frames, particle_volume, progress, steps_per_transfer)
                    x, v, C, F = _RolloutFunction.apply(run, x0 - origin, v0, kernel_mat, bnd)
                break
            except _Unstable as err:
                if attempt == self.max_halvings:
                    raise SimulationUnstable(
                        f"simulation unstable at step {err.step} (t = {err.step * dt:.4g} s): a particle moved more "
                        f"than one cell ({self.dx:.4g} m) in a step or became NaN, even at dt = {dt:.3g} s, the "
                        f"smallest allowed step ({self.max_halvings} halvings)") from None
                # the step and the interval between transfers halved (particles held in place too long go
                # unstable as steps too long do)
                logger.warning("simulation unstable at step %d (dt = %.3g s, transfers every %d steps); retrying at "
                               "dt = %.3g s", err.step, dt, steps_per_transfer, dt / 2)
                dt, substeps = dt / 2, substeps * 2
        times = torch.arange(frames + 1, dtype=self.dtype) * frame_dt
        return Trajectory(x=x + origin, v=v, C=C, F=F, times=times, dt=dt, substeps=substeps)


class _Buffers:
    """Per-step particle and grid arrays of one chunk (two ping-pong states when no gradient is needed)."""

    def __init__(self, sim: Simulator, n: int, steps: int, requires_grad: bool) -> None:
        k, res, s = sim.kernels, sim.resolution, sim.scalar
        self.key = (n, steps if requires_grad else 0, requires_grad)
        states = steps + 1 if requires_grad else 2
        grids = steps if requires_grad else 1

        def alloc(count: int, shape, dtype) -> list[wp.array]:
            return [wp.zeros(shape, dtype=dtype, requires_grad=requires_grad) for _ in range(count)]

        self.x = alloc(states, n, k.vec3)
        self.v = alloc(states, n, k.vec3)
        self.C = alloc(states, n, k.mat33)
        self.F = alloc(states, n, k.mat33)
        # accumulated plastic shear strain of a thixotropic material (not differentiated)
        self.structure = [wp.zeros(n, dtype=s) for _ in range(states)]
        # eigen-decompositions of the trial strain, inputs of the plastic return (constants for the tape)
        self.eig_q = [wp.zeros(n, dtype=k.mat33) for _ in range(grids)]
        # the first step's guess of the decomposition's basis (a rollout starts from it, whatever ran before)
        self.identity = wp.array(np.ascontiguousarray(np.broadcast_to(np.eye(3), (n, 3, 3))), dtype=k.mat33)
        self.eig_l = [wp.zeros(n, dtype=k.vec3) for _ in range(grids)]
        self.m = alloc(grids, (res, res, res), s)
        self.mv = alloc(grids, (res, res, res), k.vec3)
        self.gv = alloc(grids, (res, res, res), k.vec3)

    def state(self, i: int) -> tuple[wp.array, wp.array, wp.array, wp.array]:
        i %= len(self.x)
        return self.x[i], self.v[i], self.C[i], self.F[i]

    def zero_grads(self) -> None:
        for group in (self.x, self.v, self.C, self.F, self.m, self.mv, self.gv):
            for a in group:
                a.grad.zero_()


class _Run:
    """One rollout: its forward pass, checkpoints and backward pass."""

    def __init__(self, sim: Simulator, material: Material, dt: float, substeps: int, frames: int,
                 particle_volume: float, progress: bool, steps_per_transfer: int = 1) -> None:
        self.sim, self.material, self.dt, self.substeps, self.frames = sim, material, dt, substeps, frames
        self.steps_per_transfer = steps_per_transfer
        self.particle_volume = particle_volume
        self.min_mass = 1e-6 * material.density * particle_volume  # a millionth of a particle's mass
        self.progress = progress
        self.steps = frames * substeps
        ca = sim.collider_arrays
        s = sim.scalar
        self.shapes = wp.array(ca.shapes, dtype=int)
        self.laws = wp.array(ca.laws, dtype=int)
        self.geom = wp.array(np.asarray(ca.geometry, dtype=np.float64).reshape(-1, kernels.N_GEOM), dtype=s)
        self.timing = wp.array(np.asarray(ca.timing, dtype=np.float64).reshape(-1, 2), dtype=s)
        self.unstable = wp.zeros(1, dtype=int)
        self.reached = wp.zeros(6, dtype=int)
        self.unreached = wp.array([sim.resolution] * 3 + [-1] * 3, dtype=int)
        self.backward_done = False
        # walls' adhesion (Pa) on a layer a cell thick: its velocity change per step
        self.adhesion_cut = sim.physics.wall_adhesion * dt / (material.density * sim.dx)
        self.full_mass = material.density * sim.dx**3  # a node's mass inside the material at rest
        # a wall-face node's mass under material on one side: half a cell's (the B-spline's weight beyond the face)
        self.face_mass = 0.5 * self.full_mass
        self._recorded: dict[tuple[str, int], wp.Launch] = {}

    def _launch(self, name: str, i: int, build, dim=None, changed: dict[int, object] | None = None) -> None:
        """Launch ``build()``'s (kernel, dim, inputs, outputs). Without gradients, step ``i``'s arrays are those of
        step ``i - 2``: each kernel's launch of either parity is recorded once and replayed with only ``dim`` and
        the ``changed`` arguments (by index) set anew, which saves packing every argument every step (about a tenth
        of a forward step's time)."""
        if self.requires_grad:
            kernel, full_dim, inputs, outputs = build()
            wp.launch(kernel, dim=full_dim, inputs=inputs, outputs=outputs)
            return
        command = self._recorded.get((name, i % 2))
        if command is None:
            kernel, full_dim, inputs, outputs = build()
            command = self._recorded[name, i % 2] = wp.launch(kernel, dim=full_dim, inputs=inputs, outputs=outputs,
                                                               record_cmd=True)
        elif dim is not None:
            command.set_dim(dim)
            for index, value in (changed or {}).items():
                command.set_param_at_index(index, value)
        command.launch()

    def _step(self, buf: _Buffers, i: int, grid: int, step: int, tape: wp.Tape | None) -> None:
        k, sim, s = self.sim.kernels, self.sim, self.sim.scalar
        x, v, C, F = buf.state(i)
        x1, v1, C1, F1 = buf.state(i + 1)
        m, mv, gv = buf.m[grid], buf.mv[grid], buf.gv[grid]
        eig_q, eig_l = buf.eig_q[grid], buf.eig_l[grid]
        structure, structure_next = buf.structure[i % len(buf.x)], buf.structure[(i + 1) % len(buf.x)]
        physics = sim.physics
        inv_dx = 1.0 / sim.dx
        phase = step % self.steps_per_transfer  # steps since the last particle-to-grid transfer
        if phase == 0:
            m.zero_()
            wp.copy(self.reached, self.unreached)
            self._launch("reached_nodes", i, lambda: (
                k.reached_nodes, len(x), [x, s(inv_dx), sim.resolution], [self.reached]))
            bounds = self.reached.numpy()
            self.low, self.high = bounds[:3], bounds[3:]
            rate = C  # the velocity gradient of the constitutive update
        else:  # the particles held in place since the transfer: the grid's velocity gradient at them
            rate = self.rate
            self._launch("grid_gradient", i, lambda: (k.grid_gradient, len(x), [x, gv, s(inv_dx)], [rate]))
        mv.zero_()
        low, high = self.low, self.high
        if self.material.model in (kernels.MODEL_HERSCHEL_BULKLEY, kernels.MODEL_PLASTICINE):
            # from the last step's basis: in place without gradients, else the last step's own array
            guess = eig_q if not self.requires_grad else buf.eig_q[grid - 1] if grid > 0 else buf.identity
            # recorded apart for the steps that transfer and those between (their velocity gradients differ)
            self._launch(f"eigen {phase == 0}", i, lambda: (
                k.eigen, len(x), [F, rate, s(self.dt), guess], [eig_q, eig_l]))
            if physics.thixotropy > 0.0:
                self._launch(f"structure_update {phase == 0}", i, lambda: (
                    k.structure_update, len(x), [F, rate, eig_l, self.mat, self.material.model, s(self.dt),
                                                 s(physics.thixotropy), s(physics.thixotropy_floor),
                                                 s(physics.thixotropy_exponent), structure],
                    [structure_next]))
        # only the nodes the particles reach hold mass and are read back (the grid is mostly empty)
        box = tuple(int(h - lo + 1) for lo, h in zip(low, high, strict=True))
        now, corner = s(step * self.dt), wp.vec3i(*low)
        with tape if tape is not None else contextlib.nullcontext():
            self._launch(f"p2g {phase == 0}", i, lambda: (
                k.p2g, len(x), [x, v, rate, F, self.mat, self.material.model, s(self.particle_volume), s(self.dt),
                                s(inv_dx), eig_q, eig_l, structure, s(physics.thixotropy),
                                s(physics.thixotropy_floor), int(phase == 0)],
                [F1, m, mv]))
            if sim.symmetry_node is not None:
                self._launch(f"mirror_fold {phase == 0}", i, lambda: (
                    k.mirror_fold, (m.shape[0], m.shape[1], kernels.MIRROR_NODES + 1),
                    [m, mv, sim.symmetry_node, int(phase == 0)], []))
            if phase > 0:
                self._launch("add_momentum", i, lambda: (k.add_momentum, box, [m, gv, corner], [mv]),
                             dim=box, changed={ADD_MOMENTUM_LOW: corner})
            if physics.surface_tension > 0.0:
                cells, cell_corner = tuple(b + 1 for b in box), wp.vec3i(*(low - 1))
                self._launch("capillary_stress", i, lambda: (
                    k.capillary_stress, cells, [m, s(1.0 / self.full_mass), s(physics.surface_tension), now,
                                                s(sim.dx), self.shapes, self.geom, self.timing, self.bnd,
                                                cell_corner], [self.cell_stress]),
                             dim=cells, changed={CAPILLARY_STRESS_TIME: now, CAPILLARY_STRESS_LOW: cell_corner})
                self._launch("capillary_force", i, lambda: (
                    k.capillary_force, box, [self.cell_stress, s(self.dt), s(sim.dx), corner], [mv]),
                             dim=box, changed={CAPILLARY_FORCE_LOW: corner})
            self._launch("grid_update", i, lambda: (
                k.grid_update, box, [m, mv, s(self.dt), now, s(sim.dx), k.vec3(*sim.gravity), self.shapes, self.laws,
                                     self.geom, self.timing, self.bnd, s(self.min_mass), corner,
                                     s(self.adhesion_cut), s(physics.air_drag), s(self.face_mass),
                                     k.vec4(*physics.open_drag), s(-sim.domain_origin[1]), s(physics.open_layer),
                                     s(physics.open_span if any(physics.open_drag) else 0.0)], [gv]),
                         dim=box, changed={GRID_UPDATE_TIME: now, GRID_UPDATE_LOW: corner})
            if phase == self.steps_per_transfer - 1:
                self._launch("g2p", i, lambda: (k.g2p, len(x), [x, gv, s(self.dt * self.steps_per_transfer),
                                                                s(inv_dx)], [x1, v1, C1, self.unstable]))
            else:
                for source, target in ((x, x1), (v, v1), (C, C1)):
                    wp.copy(target, source)

    def _run_chunk(self, buf: _Buffers, start: int, length: int, record: list | None, bar) -> wp.Tape | None:
        """Advance ``length`` steps from buffer state 0; record frames into ``record`` if given."""
        tape = wp.Tape() if self.requires_grad else None
        for i in range(length):
            step = start + i
            self._step(buf, i, i if tape is not None else 0, step, tape)
            if self.unstable.numpy()[0]:
                raise _Unstable(step)
            if (step + 1) % self.substeps == 0:
                if record is not None:
                    frame = (step + 1) // self.substeps
                    for out, arr in zip(record, buf.state(i + 1), strict=True):
                        out[frame].copy_(_host(arr).reshape(out[frame].shape))
                if bar is not None:
                    bar.update(1)
        return tape

    def _load(self, buf: _Buffers, state: tuple[torch.Tensor, ...]) -> None:
        for arr, t in zip(buf.state(0), state, strict=True):
            _assign(arr, t)

    def _save(self, buf: _Buffers, i: int) -> tuple[torch.Tensor, ...]:
        return tuple(_host(a).clone() for a in buf.state(i))

    def forward(self, x0: torch.Tensor, v0: torch.Tensor, mat: torch.Tensor, bnd: torch.Tensor,
                requires_grad: bool) -> tuple[torch.Tensor, ...]:
        sim = self.sim
        n = x0.shape[0]
        if requires_grad and sim.symmetry_node is not None:
            raise SimulationError("a rollout about a plane of symmetry cannot be differentiated")
        if requires_grad and sim.physics.thixotropy > 0.0:
            raise SimulationError("a thixotropic rollout cannot be differentiated")
        if requires_grad and sim.physics.surface_tension > 0.0:
            raise SimulationError("a rollout with surface tension cannot be differentiated")
        if requires_grad and self.steps_per_transfer > 1:
            raise SimulationError("a rollout with transfers every few steps (transfer_dt) cannot be differentiated")
        self.requires_grad = requires_grad
        self.mat = wp.array(mat.detach().cpu().numpy(), dtype=sim.scalar, requires_grad=requires_grad)
        self.bnd = wp.array(bnd.detach().cpu().numpy().reshape(-1, kernels.N_BOUNDARY_PARAMS), dtype=sim.scalar,
                            requires_grad=requires_grad)
        budget = max(1, int(sim.checkpoint_mb * 2**20 // sim.bytes_per_step(n)))
        self.chunk = min(self.steps, budget) if requires_grad else self.steps
        self.buf = sim._acquire(n, self.chunk, requires_grad)
        if self.steps_per_transfer > 1:
            self.rate = wp.zeros(n, dtype=sim.kernels.mat33)
        if sim.physics.surface_tension > 0.0:
            self.cell_stress = wp.zeros((sim.resolution,) * 3, dtype=sim.kernels.mat33)
        eye = torch.eye(3, dtype=sim.dtype).expand(n, 3, 3)
        state0 = (x0.detach(), v0.detach(), torch.zeros(n, 3, 3, dtype=sim.dtype), eye)
        record = [torch.empty((self.frames + 1, *t.shape), dtype=sim.dtype) for t in state0]
        for out, t in zip(record, state0, strict=True):
            out[0].copy_(t)
        self.snapshots: dict[int, tuple[torch.Tensor, ...]] = {}
        self._load(self.buf, state0)
        self.buf.structure[0].zero_()
        wp.copy(self.buf.eig_q[0], self.buf.identity)
        bar = tqdm(total=self.frames, desc="simulate", unit="frame", leave=False) if self.progress else None
        try:
            for start in range(0, self.steps, self.chunk):
                length = min(self.chunk, self.steps - start)
                if start > 0:
                    self._load(self.buf, self._save(self.buf, self.last_length))
                if requires_grad and start + length < self.steps:
                    self.snapshots[start] = self._save(self.buf, 0)
                self.tape = self._run_chunk(self.buf, start, length, record, bar)
                self.last_length = length
        except BaseException:
            sim._release(self.buf)  # a retry at a smaller step reuses the buffers
            self.buf = None
            raise
        finally:
            if bar is not None:
                bar.close()
        if not requires_grad:
            sim._release(self.buf)
            self.buf = None
        return tuple(record)

    def backward(self, grads: tuple[torch.Tensor | None, ...]) -> tuple[torch.Tensor, ...]:
        if self.backward_done:
            raise SimulationError("a rollout can be differentiated once; run it again for a second backward pass")
        self.backward_done = True
        sim, buf = self.sim, self.buf
        n = len(buf.x[0])
        grads = tuple(torch.zeros((self.frames + 1, n, *shape), dtype=sim.dtype) if g is None else g
                      for g, shape in zip(grads, ((3,), (3,), (3, 3), (3, 3)), strict=True))
        starts = list(range(0, self.steps, self.chunk))
        adjoint: tuple[torch.Tensor, ...] | None = None
        for start in reversed(starts):
            length = min(self.chunk, self.steps - start)
            if start != starts[-1]:
                self._load(buf, self.snapshots.pop(start))
                self.tape = self._run_chunk(buf, start, length, None, None)
            buf.zero_grads()
            for i in range(1, length + 1):
                step = start + i
                seeds = []
                if step % self.substeps == 0:
                    seeds.append(tuple(g[step // self.substeps] for g in grads))
                if i == length and adjoint is not None:
                    seeds.append(adjoint)
                for seed in seeds:
                    for arr, g in zip(buf.state(i), seed, strict=True):
                        grad = _host(arr.grad)
                        _assign(arr.grad, grad + g.reshape(grad.shape).to(sim.dtype))
            self.tape.backward()
            adjoint = tuple(_host(a.grad).clone() for a in buf.state(0))
            self.tape = None
        gx0 = adjoint[0] + grads[0][0]
        gv0 = adjoint[1] + grads[1][0]
        gmat = _host(self.mat.grad).clone()
        gbnd = _host(self.bnd.grad).clone()
        sim._release(buf)
        self.buf = None
        return gx0, gv0, gmat, gbnd


class _RolloutFunction(torch.autograd.Function):
    @staticmethod
    def forward(ctx, run: _Run, x0, v0, mat, bnd):
        ctx.run = run
        return run.forward(x0, v0, mat, bnd, requires_grad=any(ctx.needs_input_grad[1:]))

    @staticmethod
    def backward(ctx, gx, gv, gC, gF):
        with _on_device(ctx.run.sim.device):
            gx0, gv0, gmat, gbnd = ctx.run.backward((gx, gv, gC, gF))
        return None, gx0, gv0, gmat, gbnd
