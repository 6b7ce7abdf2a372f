"""Reverse-mode gradients of rollouts against central finite differences (float64, 20-step rollouts)."""

import pytest
import torch

from rheo.geometry.sampling import cylinder
from rheo.physics import (
    Floor,
    HerschelBulkley,
    NeoHookean,
    NewtonianFluid,
    Plasticine,
    Simulator,
    dam_break_gate,
    lifted_cup,
)

RES = 16
FLOOR = 3.3 / RES  # off the grid nodes, so that tiny moves of a collider do not switch nodes in or out
TOL = 1e-4


def _scene(material, colliders, center=(0.47, 0.52)):
    sim = Simulator(material, resolution=RES, colliders=colliders, dtype=torch.float64)
    gen = torch.Generator().manual_seed(3)
    x0, vol = cylinder(center, FLOOR + 0.013, 0.11, 0.2, sim.dx / 2)
    x0 = x0 + 0.003 * torch.randn(x0.shape, generator=gen, dtype=torch.float64)
    weights = [torch.randn(x0.shape, generator=gen, dtype=torch.float64) for _ in range(2)]
    weights.append(torch.randn((len(x0), 3, 3), generator=gen, dtype=torch.float64))

    def loss(x0, v0, mat, bnd):
        tr = sim.rollout(x0, v0, frames=2, frame_dt=0.01, particle_volume=vol, material_params=mat,
                         boundary_params=bnd, dt=1e-3)
        wx, wv, wF = weights
        return (tr.x[-1] * wx).sum() + (tr.x[1] ** 2).sum() + (tr.v[-1] * wv).sum() + (tr.F[-1] * wF).sum()

    return sim, x0, loss


def _central_difference(f, t: torch.Tensor, index, rel_step=1e-6) -> float:
    h = rel_step * max(abs(float(t[index])), 1.0)
    plus, minus = t.clone(), t.clone()
    plus[index] += h
    minus[index] -= h
    return (float(f(plus)) - float(f(minus))) / (2 * h)


def _check(ad: torch.Tensor, f, t: torch.Tensor, indices) -> None:
    scale = ad.abs().max()
    for index in indices:
        fd = _central_difference(f, t, index)
        assert abs(float(ad[index]) - fd) <= TOL * max(abs(fd), 1e-3 * float(scale)), (index, float(ad[index]), fd)


def _gradients(sim, x0, loss, v0):
    mat = sim.material_parameters().requires_grad_()
    bnd = sim.boundary_parameters().requires_grad_()
    x = x0.clone().requires_grad_()
    v = v0.clone().requires_grad_()
    loss(x, v, mat, bnd).backward()
    return x.grad, v.grad, mat.grad, bnd.grad, mat.detach(), bnd.detach()


HB = HerschelBulkley(tau_y=40.0, K=3.0, n=0.6, mu=2.0e3, lam=3.0e3)
V0 = torch.tensor([0.4, -0.6, -0.3], dtype=torch.float64)


@pytest.mark.parametrize("material", [HB, Plasticine(tau_y=60.0, mu=2.0e3, lam=2.0e3),
                                      NewtonianFluid(viscosity=2.0, bulk_modulus=4.0e3),
                                      NeoHookean(mu=1.5e3, lam=2.5e3)], ids=lambda m: type(m).__name__)
def test_material_parameter_gradients(material):
    sim, x0, loss = _scene(material, [Floor(height=FLOOR, contact="friction", friction=0.4)])
    _, _, g_mat, _, mat, bnd = _gradients(sim, x0, loss, V0)
    _check(g_mat, lambda m: loss(x0, V0, m, bnd), mat, range(len(mat)))


def test_initial_state_and_boundary_gradients():
    gate = dam_break_gate(0.8, center=(0.2437, 0.5, 0.5), half_extents=(0.0613, 0.3, 0.45), contact="friction",
                          friction=0.3)
    colliders = [Floor(height=FLOOR, contact="friction", friction=0.4), gate]
    sim, x0, loss = _scene(HB, colliders, center=(0.43, 0.52))
    v0 = torch.tensor([-0.5, -0.3, 0.1], dtype=torch.float64)  # towards the gate
    g_x, g_v, _, g_bnd, mat, bnd = _gradients(sim, x0, loss, v0)
    # initial velocity, one vector
    _check(g_v, lambda v: loss(x0, v, mat, bnd), v0, range(3))
    # every boundary parameter: friction and velocity of the floor and of the moving gate
    assert g_bnd[1].abs().max() > 0  # the gate is touched
    _check(g_bnd, lambda b: loss(x0, v0, mat, b), bnd, [(c, j) for c in range(2) for j in range(4)])
    # initial positions
    _check(g_x, lambda x: loss(x, v0, mat, bnd), x0, [(0, 0), (7, 2), (len(x0) // 2, 1), (len(x0) - 1, 0)])


def test_navier_wall_gradients():
    gate = dam_break_gate(0.8, center=(0.2437, 0.5, 0.5), half_extents=(0.0613, 0.3, 0.45), contact="navier",
                          friction=300.0)
    sim, x0, loss = _scene(HB, [Floor(height=FLOOR, contact="navier", friction=500.0), gate], center=(0.43, 0.52))
    v0 = torch.tensor([-0.5, -0.3, 0.1], dtype=torch.float64)
    _, _, _, g_bnd, mat, bnd = _gradients(sim, x0, loss, v0)
    assert g_bnd[:, 0].abs().min() > 0  # both walls' beta act
    _check(g_bnd, lambda b: loss(x0, v0, mat, b), bnd, [(0, 0), (1, 0), (1, 2)])


def test_per_particle_initial_velocity_gradients():
    sim, x0, loss = _scene(HB, [Floor(height=FLOOR, contact="sticky")])
    v0 = V0.expand_as(x0).clone()
    v0[:, 0] += torch.linspace(-0.2, 0.2, len(x0), dtype=torch.float64)
    _, g_v, _, _, mat, bnd = _gradients(sim, x0, loss, v0)
    _check(g_v, lambda v: loss(x0, v, mat, bnd), v0, [(0, 0), (3, 2), (len(x0) // 3, 1), (len(x0) - 2, 2)])


def test_lifted_cup_gradients():
    cup = lifted_cup(0.3, rim_height=FLOOR - 0.01, height=0.3, rim_radius=0.163, top_radius=0.141,
                     thickness=0.13, axis=(0.47, 0.52), contact="friction", friction=0.5)
    sim, x0, loss = _scene(HB, [Floor(height=FLOOR, contact="slip"), cup])
    _, _, _, g_bnd, mat, bnd = _gradients(sim, x0, loss, torch.zeros(3, dtype=torch.float64))
    assert g_bnd[1].abs().max() > 0  # the cup wall acts on the material
    _check(g_bnd, lambda b: loss(x0, torch.zeros(3, dtype=torch.float64), mat, b), bnd,
           [(1, 0), (1, 3), (0, 1)])


def test_float32_gradients_stay_finite_for_particles_on_the_grid_lattice():
    """Particles exactly on the lattice of half cells (as seeds are) leave nodes touched only by a weight's rounding
    error; their adjoint must not overflow. float32 agrees with float64."""
    soft = HerschelBulkley(tau_y=5.8, K=0.5, n=1.0, mu=100.0, lam=1.0e4)
    grads = {}
    for dtype in (torch.float32, torch.float64):
        sim = Simulator(soft, resolution=32, colliders=[Floor(height=0.0)], dtype=dtype,
                        domain_origin=(0.0, -3.0 / 32, 0.0))
        h = 1.0 / 64
        x0 = torch.cartesian_prod(*(torch.arange(n0, n0 + 10, dtype=dtype) * h for n0 in (26, 1, 26)))
        mat = torch.log(sim.material_parameters()).requires_grad_()
        tr = sim.rollout(x0, torch.zeros(3, dtype=dtype), frames=1, frame_dt=0.045, dt=0.045 / 28,
                         particle_volume=h**3, material_params=torch.exp(mat))
        tr.x[-1][:, 1].mean().backward()
        grads[dtype] = mat.grad
    assert torch.isfinite(grads[torch.float32]).all()
    assert torch.allclose(grads[torch.float32].double(), grads[torch.float64], rtol=0.02,
                          atol=1e-3 * float(grads[torch.float64].abs().max()))
