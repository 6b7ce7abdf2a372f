"""Optional physics against closed forms: quadratic air drag, the open linear drag, wall adhesion's hold, thixotropic
breakdown, a drop's capillary pressure and oscillation; each off at its null value."""

import math

import numpy as np
import pytest
import torch
import warp as wp

from rheo.geometry.sampling import box, lattice_fill
from rheo.physics import Box, Floor, HerschelBulkley, NeoHookean, NewtonianFluid, OptionalPhysics, Simulator
from rheo.physics import kernels as kn
from rheo.physics.optional import open_drag_rate
from rheo.physics.simulator import SimulationError


def _fall(physics: OptionalPhysics, g: float = 2.0, duration: float = 0.6) -> tuple[torch.Tensor, torch.Tensor]:
    """Centroid drop of a free-falling elastic block, and the frame times."""
    sim = Simulator(NeoHookean(mu=1.0e3, lam=1.0e3), resolution=16, gravity=(0.0, -g, 0.0), dtype=torch.float64,
                    physics=physics)
    x0, vol = box((0.4, 0.7, 0.4), (0.6, 0.8, 0.6), sim.dx / 2)
    tr = sim.rollout(x0, torch.zeros(3), frames=6, frame_dt=duration / 6, particle_volume=vol, dt=5e-4)
    return x0[:, 1].mean() - tr.x[:, :, 1].mean(dim=1), tr.times


def test_air_drag_fall_follows_the_quadratic_drag_law():
    """dv/dt = g - c v^2: drop = (v_t^2 / g) ln cosh(g t / v_t), v_t = sqrt(g / c)."""
    g, c = 2.0, 2.0
    drop, times = _fall(OptionalPhysics(air_drag=c), g)
    terminal = math.sqrt(g / c)
    expected = terminal**2 / g * torch.log(torch.cosh(g * times / terminal))
    rel = (drop[1:] - expected[1:]).abs() / expected[1:]
    assert rel.max() < 5e-3, rel
    free, _ = _fall(OptionalPhysics(), g)
    assert float(free[-1] / drop[-1]) > 1.15  # the drag did slow the fall


def _glide(open_drag: tuple[float, float, float, float], layer: float, span: float = 0.4) -> tuple[torch.Tensor,
                                                                                                    torch.Tensor]:
    """Mean x velocity (m/s) of an elastic block gliding from 0.5 m/s without gravity, its centre 0.5 m above y = 0,
    and the frame times."""
    sim = Simulator(NeoHookean(mu=1.0e3, lam=1.0e3), resolution=16, gravity=(0.0, 0.0, 0.0), dtype=torch.float64,
                    physics=OptionalPhysics(open_drag=open_drag, open_layer=layer, open_span=span))
    x0, vol = box((0.25, 0.45, 0.4), (0.4, 0.55, 0.6), sim.dx / 2)
    tr = sim.rollout(x0, torch.tensor([0.5, 0.0, 0.0], dtype=torch.float64), frames=6, frame_dt=0.1,
                     particle_volume=vol, dt=5e-4)
    return tr.v[:, :, 0].mean(dim=1), tr.times


@pytest.mark.parametrize(("drag", "layer"), [((0.0, 0.0, 2.0, -1.0), 0.01),  # the bulk's rates, far from the floor
                                             ((2.0, -1.0, 0.0, 0.0), 1.0e4)])  # the floor's, a layer wider than all
def test_open_drag_slows_or_drives_a_glide_as_its_rate_turns_from_early_to_late(drag, layer):
    """dv/dt = -r(t) v, r going linearly from the early rate a to the late one b over the span T:
    v = v0 exp(-(a t + (b - a) t^2 / (2 T))) up to T, then at the rate b."""
    span, (a, b) = 0.4, [r for r in drag if r != 0.0]
    v, times = _glide(drag, layer, span)
    within = torch.clamp(times, max=span)
    exponent = a * within + (b - a) * within**2 / (2 * span) + b * (times - within)
    assert torch.allclose(v, 0.5 * torch.exp(-exponent), rtol=2e-3), (v, 0.5 * torch.exp(-exponent))
    unchanged, _ = _glide((drag[2], drag[3], drag[0], drag[1]), layer, span)  # the same rates on the other part
    assert torch.allclose(unchanged, torch.full_like(unchanged, 0.5), rtol=1e-4)


def test_open_drag_rate_blends_the_floor_and_the_bulk_early_and_late():
    rates, layer, span = (4.0, 2.0, 1.0, -1.0), 0.1, 2.0
    assert open_drag_rate(rates, 0.0, 0.0, layer, span) == 4.0  # on the floor at the release: floor early
    assert open_drag_rate(rates, -0.05, 3.0, layer, span) == 2.0  # below the floor, after the span: floor late
    assert open_drag_rate(rates, 100.0, 3.0, layer, span) == pytest.approx(-1.0)  # far above, late: bulk late
    # half the floor's weight (height layer ln 2), half way through the span: the mean of the four
    assert open_drag_rate(rates, layer * math.log(2.0), 1.0, layer, span) == pytest.approx(1.5)


def _hanging_drop(adhesion: float, contact: str = "slip") -> float:
    """How far (m) a 0.1 m thick elastic block starting against a ceiling's underside has fallen after 0.3 s."""
    sim = Simulator(NeoHookean(mu=1.0e5, lam=1.0e5), resolution=16, colliders=[
        Box(center=(0.5, 0.9, 0.5), half_extents=(0.3, 0.1, 0.3), contact=contact)], dtype=torch.float64,
        physics=OptionalPhysics(wall_adhesion=adhesion))
    x0, vol = box((0.4, 0.7, 0.4), (0.6, 0.8, 0.6), sim.dx / 2)
    tr = sim.rollout(x0, torch.zeros(3), frames=3, frame_dt=0.1, particle_volume=vol)
    return float(x0[:, 1].mean() - tr.x[-1, :, 1].mean())


def test_wall_adhesion_holds_a_block_under_a_ceiling_above_its_weight_per_area():
    """The block's weight per contact area is rho g h = 980 Pa: half of it lets the block fall, one and a half times
    holds it; a sticky ceiling holds it anyway and adhesion changes nothing there."""
    weight = 1000.0 * 9.8 * 0.1
    free_fall = 0.5 * 9.8 * 0.3**2
    assert _hanging_drop(0.0) > 0.9 * free_fall
    assert _hanging_drop(weight / 2) > 0.3 * free_fall
    assert _hanging_drop(1.5 * weight) < 1e-3
    assert _hanging_drop(weight / 2, contact="sticky") == _hanging_drop(0.0, contact="sticky")


def _simple_shear(thixotropy: float, floor: float = 0.0, exponent: float = 1.0, rate: float = 2.0, dt: float = 1e-3,
                  steps: int = 2000):
    """A material point sheared at a constant rate, stepped through the kernels' return mapping and structure
    update: the accumulated plastic shear strain and the equivalent shear stress |s| / sqrt(2) at every step."""
    k = kn.build(wp.float64)
    material = HerschelBulkley(tau_y=50.0, K=5.0, n=0.5, mu=2.0e4, lam=2.0e4)
    mat = wp.array(material.kernel_vector(material.parameters()).numpy(), dtype=wp.float64)
    F = wp.array(np.eye(3)[None], dtype=k.mat33)
    C = wp.array(np.array([[[0.0, rate, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]]), dtype=k.mat33)
    structure = wp.zeros(1, dtype=wp.float64)
    q, lam_b = wp.array(np.eye(3)[None], dtype=k.mat33), wp.zeros(1, dtype=k.vec3)  # q: the last step's basis
    strain, stress = [], []
    for _ in range(steps):
        F_out, tau_out, next_structure = wp.zeros_like(F), wp.zeros_like(F), wp.zeros_like(structure)
        wp.launch(k.eigen, 1, inputs=[F, C, wp.float64(dt), q], outputs=[q, lam_b])
        wp.launch(k.structure_update, 1, inputs=[F, C, lam_b, mat, material.model, wp.float64(dt),
                                                 wp.float64(thixotropy), wp.float64(floor), wp.float64(exponent),
                                                 structure],
                  outputs=[next_structure])
        wp.launch(k.return_mapping, 1, inputs=[F, C, mat, material.model, wp.float64(dt), structure,
                                               wp.float64(thixotropy), wp.float64(floor)], outputs=[F_out, tau_out])
        F, structure = F_out, next_structure
        tau = tau_out.numpy()[0]
        dev = tau - np.trace(tau) / 3 * np.eye(3)
        strain.append(float(structure.numpy()[0]))
        stress.append(float(np.linalg.norm(dev) / math.sqrt(2.0)))
    return np.array(strain), np.array(stress), material


@pytest.mark.parametrize("thixotropy, floor, exponent", [(0.0, 0.0, 1.0), (0.5, 0.0, 1.0), (1.5, 0.3, 1.0),
                                                          (3.0, 0.3, 0.0), (1.0, 0.0, 0.5)])
def test_thixotropic_yield_stress_decays_with_the_plastic_strain(thixotropy, floor, exponent):
    """In steady simple shear the structure measure xi grows at the imposed rate to the power ``exponent`` (the
    plastic strain with 1, the time yielding with 0), and the stress follows the law with the broken-down yield
    stress: tau_y (floor + (1 - floor) exp(-thixotropy xi)) + K gamma_dot^n."""
    rate, dt = 2.0, 1e-3
    strain, stress, m = _simple_shear(thixotropy, floor, exponent, rate, dt)
    late = slice(1000, None)
    assert np.allclose(np.diff(strain[late]) / dt, rate**exponent, rtol=0.01)
    expected = m.tau_y * (floor + (1 - floor) * np.exp(-thixotropy * strain[late])) + m.K * rate**m.n
    assert np.allclose(stress[late], expected, rtol=0.02)
    if floor:  # broken down, the structure keeps its floor: the stress levels off there, not at the bare K rate^n
        assert stress[-1] == pytest.approx(m.tau_y * floor + m.K * rate**m.n, rel=0.02)


KAPPA, GAMMA, RADIUS = 1.0e4, 12.5, 0.25


def _drop(resolution: int, axes, frames: int, frame_dt: float, viscosity: float):
    """A free drop of a nearly incompressible liquid (bulk modulus ``KAPPA``) with surface tension ``GAMMA``, no
    gravity: its ellipsoid ``axes`` (m) centred in the unit domain at rest at t = 0."""
    sim = Simulator(NewtonianFluid(viscosity=viscosity, bulk_modulus=KAPPA), resolution=resolution,
                    gravity=(0.0, 0.0, 0.0), dtype=torch.float64, physics=OptionalPhysics(surface_tension=GAMMA))
    axes = torch.tensor(axes, dtype=torch.float64)
    x0, vol = lattice_fill(lambda x: (((x - 0.5) / axes) ** 2).sum(-1) < 1.0, (0.1,) * 3, (0.9,) * 3, sim.dx / 2)
    return sim, sim.rollout(x0, torch.zeros(3), frames=frames, frame_dt=frame_dt, particle_volume=vol)


@pytest.mark.parametrize("resolution", [24, 32])
def test_surface_tension_holds_laplace_s_pressure_in_a_drop(resolution):
    """Inside a spherical drop the pressure is 2 gamma / R (Laplace): -kappa ln J averaged over the drop's core
    (more than 3 cells in) and over 0.16-0.96 s, a few periods of the drop's undamped breathing."""
    sim, tr = _drop(resolution, (RADIUS,) * 3, frames=48, frame_dt=0.02, viscosity=5.0)
    core = (tr.x[8:] - 0.5).norm(dim=-1) < RADIUS - 3 * sim.dx
    pressure = -KAPPA * torch.log(torch.linalg.det(tr.F[8:]))
    mean = float(((pressure * core).sum(dim=1) / core.sum(dim=1)).mean())
    assert mean == pytest.approx(2 * GAMMA / RADIUS, rel=0.05)


def test_surface_tension_makes_a_drop_oscillate_at_rayleigh_s_frequency():
    """A drop stretched 10 % along y oscillates in its l = 2 mode: omega^2 = 8 gamma / (rho R^3) less the viscous
    decay rate's square (Lamb: 5 nu / R^2). Its period, between the first and third zero crossings of the second
    moments' anisotropy, within 5 %."""
    stretch, frame_dt, viscosity = 1.1, 0.05, 1.0
    _sim, tr = _drop(24, (RADIUS / stretch**0.5, RADIUS * stretch, RADIUS / stretch**0.5), 64, frame_dt, viscosity)
    d = (tr.x - tr.x.mean(dim=1, keepdim=True)) ** 2
    anisotropy = (d[..., 1].mean(1) - 0.5 * (d[..., 0].mean(1) + d[..., 2].mean(1))).numpy()
    crossings = [frame_dt * (i + anisotropy[i] / (anisotropy[i] - anisotropy[i + 1]))
                 for i in range(len(anisotropy) - 1) if anisotropy[i] * anisotropy[i + 1] < 0]
    omega2 = 8 * GAMMA / (1000.0 * RADIUS**3) - (5 * viscosity / 1000.0 / RADIUS**2) ** 2
    assert len(crossings) >= 3
    assert crossings[2] - crossings[0] == pytest.approx(2 * math.pi / math.sqrt(omega2), rel=0.05)


def test_optional_physics_at_their_null_values_change_nothing_and_thixotropy_is_not_differentiated():
    material = HerschelBulkley(tau_y=50.0, K=5.0, n=0.5, mu=2.0e3, lam=2.0e3)
    x0, vol = box((0.4, 0.2, 0.4), (0.6, 0.4, 0.6), 1.0 / 32)
    runs = []
    for physics in (OptionalPhysics(), OptionalPhysics(air_drag=1.0, thixotropy=1.0, wall_adhesion=100.0,
                                                            surface_tension=0.05, open_drag=(1.0, 0.0, 0.0, 0.0))):
        sim = Simulator(material, resolution=16, colliders=[Floor(height=0.19, contact="slip")], physics=physics)
        runs.append(sim.rollout(x0, torch.zeros(3), frames=2, frame_dt=0.05, particle_volume=vol).x)
    base = Simulator(material, resolution=16, colliders=[Floor(height=0.19, contact="slip")])
    assert torch.equal(runs[0], base.rollout(x0, torch.zeros(3), frames=2, frame_dt=0.05, particle_volume=vol).x)
    assert not torch.allclose(runs[0], runs[1])
    thixotropic = Simulator(material, resolution=16, physics=OptionalPhysics(thixotropy=1.0))
    with pytest.raises(SimulationError, match="thixotropic"):
        thixotropic.rollout(x0, torch.zeros(3, requires_grad=True), frames=1, frame_dt=0.05, particle_volume=vol)
    capillary = Simulator(material, resolution=16, physics=OptionalPhysics(surface_tension=0.05))
    with pytest.raises(SimulationError, match="surface tension"):
        capillary.rollout(x0, torch.zeros(3, requires_grad=True), frames=1, frame_dt=0.05, particle_volume=vol)
    with pytest.raises(ValueError, match="air_drag"):
        OptionalPhysics(air_drag=-1.0)
    with pytest.raises(ValueError, match="open_drag"):
        OptionalPhysics(open_drag=(1.0, 2.0, math.nan, 0.0))
    with pytest.raises(ValueError, match=r"thixotropy_floor = 1\.0 must be below 1"):
        OptionalPhysics(thixotropy=1.0, thixotropy_floor=1.0)
