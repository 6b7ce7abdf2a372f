"""Constitutive updates against closed forms computed independently in NumPy/SciPy."""

import math

import numpy as np
import pytest
import torch
import warp as wp
from scipy.optimize import brentq

from rheo.physics import HerschelBulkley, MaterialError, Plasticine, make_material
from rheo.physics import kernels as kn


def _return_mapping(material, F, C, dt):
    k = kn.build(wp.float64)
    n = len(F)
    F_out = wp.zeros(n, dtype=k.mat33)
    tau_out = wp.zeros(n, dtype=k.mat33)
    mat = wp.array(material.kernel_vector(material.parameters()).numpy(), dtype=wp.float64)
    wp.launch(k.return_mapping, n, inputs=[wp.array(F, dtype=k.mat33), wp.array(C, dtype=k.mat33), mat,
                                          material.model, wp.float64(dt), wp.zeros(n, dtype=wp.float64),
                                          wp.float64(0.0), wp.float64(0.0), F_out, tau_out])
    return F_out.numpy(), tau_out.numpy()


def _bingham_closed_form(Ft, tau_y, eta, mu, lam, dt):
    """Hencky strain, von Mises on |s|/sqrt(2), one backward-Euler Bingham step: the stress excess over yield
    relaxes by 1 / (1 + mu dt / eta)."""
    lam_b, Q = np.linalg.eigh(Ft @ Ft.T)
    eps = 0.5 * np.log(lam_b)
    dev = eps - eps.mean()
    t_trial = math.sqrt(2.0) * mu * np.linalg.norm(dev)
    alpha = 1.0
    if t_trial > tau_y:
        alpha = (tau_y + (t_trial - tau_y) / (1.0 + mu * dt / eta)) / t_trial
    eps_new = alpha * dev + eps.mean()
    tau = Q @ np.diag(2 * mu * eps_new + lam * eps_new.sum()) @ Q.T
    F_new = Q @ np.diag(np.exp(eps_new - eps)) @ Q.T @ Ft
    return F_new, tau


def test_herschel_bulkley_with_n_1_equals_bingham_closed_form():
    rng = np.random.default_rng(1)
    material = HerschelBulkley(tau_y=300.0, K=8.0, n=1.0, mu=2.0e4, lam=5.0e4)
    dt = 2e-4
    F = np.eye(3) + 0.08 * rng.standard_normal((200, 3, 3))
    C = np.zeros((200, 3, 3))
    F_new, tau = _return_mapping(material, F, C, dt)
    yielded = 0
    for i in range(len(F)):
        F_ref, tau_ref = _bingham_closed_form(F[i], 300.0, 8.0, 2.0e4, 5.0e4, dt)
        yielded += not np.allclose(F_ref, F[i])
        assert np.abs(tau[i] - tau_ref).max() <= 1e-6 * np.abs(tau_ref).max()
        assert np.abs(F_new[i] - F_ref).max() <= 1e-6
    assert yielded > 150  # the check exercised the plastic branch


@pytest.mark.parametrize("n", [0.3, 0.6, 1.0, 1.7])
@pytest.mark.parametrize(("scalar", "rel"), [(wp.float64, 1e-12), (wp.float32, 2e-6)])
@pytest.mark.parametrize(("relax", "K"), [(3.0, 12.0), (0.04, 0.9)])
def test_herschel_bulkley_return_solves_the_flow_rule(n, scalar, rel, relax, K):
    """u + mu dt (u / K)^(1/n) = excess: the stress excess after one step, against a bracketing root finder, where
    the iteration starts from either upper bound (relax 3: the excess, or K (excess / relax)^n for large excesses)
    and where the root lies just below the excess (relax 0.04: a dam break's mu dt)."""
    k = kn.build(scalar)
    trial = np.geomspace(1e-3, 1e5, 40)
    out = wp.zeros(len(trial), dtype=scalar)
    wp.launch(k.hb_excess, len(trial), inputs=[wp.array(trial, dtype=scalar), scalar(relax), scalar(K), scalar(n),
                                               out])
    for u, x in zip(out.numpy(), wp.array(trial, dtype=scalar).numpy().astype(float), strict=True):
        ref = brentq(lambda v, x=x: v + relax * (v / K) ** (1 / n) - x, 0.0, x, xtol=1e-300, rtol=1e-15)
        assert u == pytest.approx(ref, rel=rel)


@pytest.mark.parametrize(("tau_y", "K", "n"), [(4.53, 6.95, 0.47), (14.5, 0.978, 1.0), (2.0, 0.3, 1.6)])
def test_steady_simple_shear_follows_the_flow_curve(tau_y, K, n):
    """Sheared at constant rates for five strain units at the slowest (thousands of updates of a finite strain that
    rotates), the material's shear stress settles on tau_y + K gamma_dot^n; stiff enough that the elastic strain stays
    small, as the flow curve assumes."""
    k = kn.build(wp.float64)
    material = HerschelBulkley(tau_y=tau_y, K=K, n=n, mu=3.0e3, lam=1.0e4)
    rates = np.array([0.3, 1.0, 3.0, 10.0, 30.0])
    C = np.zeros((len(rates), 3, 3))
    C[:, 0, 1] = rates  # v_x = gamma_dot y
    F, F_next = (wp.array(np.tile(np.eye(3), (len(rates), 1, 1)), dtype=k.mat33) for _ in range(2))
    tau = wp.zeros(len(rates), dtype=k.mat33)
    mat = wp.array(material.kernel_vector(material.parameters()).numpy(), dtype=wp.float64)
    velocity_gradient, structure, dt = wp.array(C, dtype=k.mat33), wp.zeros(len(rates), dtype=wp.float64), 1e-3
    for _ in range(round(5.0 / rates[0] / dt)):
        wp.launch(k.return_mapping, len(rates), inputs=[F, velocity_gradient, mat, material.model, wp.float64(dt),
                                                        structure, wp.float64(0.0), wp.float64(0.0), F_next, tau])
        F, F_next = F_next, F
    np.testing.assert_allclose(tau.numpy()[:, 0, 1], tau_y + K * rates**n, rtol=2e-3)


def test_plasticine_projects_onto_the_yield_surface():
    material = Plasticine(tau_y=500.0, mu=1.0e4, lam=1.0e4)
    F = np.diag([1.3, 0.9, 1.0 / (1.3 * 0.9)])[None]
    _, tau = _return_mapping(material, F, np.zeros((1, 3, 3)), 1e-3)
    s = tau[0] - np.trace(tau[0]) / 3 * np.eye(3)
    assert np.linalg.norm(s) / math.sqrt(2) == pytest.approx(500.0, rel=1e-9)


def test_neo_hookean_stress_closed_form():
    material = make_material("neo_hookean", mu=3.0e3, lam=7.0e3)
    F = np.array([[1.1, 0.2, 0.0], [0.0, 0.95, 0.1], [0.05, 0.0, 1.02]])
    _, tau = _return_mapping(material, F[None], np.zeros((1, 3, 3)), 1e-3)
    J = np.linalg.det(F)
    assert np.allclose(tau[0], 3.0e3 * (F @ F.T - np.eye(3)) + 7.0e3 * math.log(J) * np.eye(3), rtol=1e-12)


def test_newtonian_viscous_stress_from_velocity_gradient():
    material = make_material("newtonian", viscosity=2.5, bulk_modulus=1.0e4)
    C = np.array([[0.0, 3.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    F_new, tau = _return_mapping(material, np.eye(3)[None], C[None], 1e-4)
    J = np.linalg.det(np.eye(3) + 1e-4 * C)
    D = 0.5 * (C + C.T)
    expected = J * 2 * 2.5 * D + 1.0e4 * math.log(J) * np.eye(3)
    assert np.allclose(tau[0], expected, rtol=1e-10, atol=1e-10)
    assert np.allclose(F_new[0], J ** (1 / 3) * np.eye(3))


def test_bulk_modulus_is_converted_to_lame_lambda():
    m = make_material("herschel_bulkley", tau_y=10.0, K=1.0, n=0.5, mu=3.0e3, bulk_modulus=1.0e4)
    assert m.lam == pytest.approx(1.0e4 - 2.0e3)
    b = make_material("bingham", tau_y=10.0, eta=2.0, mu=1.0, lam=1.0)
    assert (b.n, b.K) == (1.0, 2.0)


@pytest.mark.parametrize(("name", "params", "message"), [
    ("ketchup", {}, "unknown material 'ketchup'"),
    ("herschel_bulkley", {"tau_y": -1.0}, "tau_y = -1.0 is invalid: it must be finite and >= 0"),
    ("herschel_bulkley", {"K": float("nan")}, "K = nan is invalid"),
    ("herschel_bulkley", {"n": 0.0}, "n = 0.0 is invalid: it must be finite and > 0"),
    ("neo_hookean", {"mu": float("inf")}, "mu = inf is invalid"),
    ("plasticine", {"yield": 3.0}, "unknown parameter(s) ['yield']"),
])
def test_bad_material_input_names_value_and_limit(name, params, message):
    with pytest.raises(MaterialError) as err:
        make_material(name, **params)
    assert message in str(err.value)


def test_parameters_round_trip_through_kernel_layout():
    m = HerschelBulkley(tau_y=1.0, K=2.0, n=0.5, mu=4.0, lam=5.0, density=900.0)
    vec = m.kernel_vector(m.parameters(torch.float64))
    assert vec[kn.P_TAU_Y] == 1.0 and vec[kn.P_K] == 2.0 and vec[kn.P_N] == 0.5
    assert vec[kn.P_MU] == 4.0 and vec[kn.P_LAM] == 5.0 and vec[kn.P_RHO] == 900.0


@pytest.mark.parametrize("dtype, tolerance", [(wp.float32, 2e-5), (wp.float64, 1e-12)])
def test_eigen_decomposition_matches_numpy_from_a_cold_or_a_warm_basis(dtype, tolerance):
    """The Jacobi eigen-decomposition of b = F F^T, from the identity or from a nearby matrix's basis (the last step's,
    in a rollout), against numpy; repeated eigenvalues (the undeformed material, a uniaxial strain) included."""
    k = kn.build(dtype)
    rng = np.random.default_rng(0)
    F = np.eye(3) + 0.05 * rng.standard_normal((500, 3, 3))
    rotation, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    uniaxial = rotation @ np.diag([1.0, 1.0, 1.1]) @ rotation.T
    F = np.concatenate([F, np.eye(3)[None], uniaxial[None]])
    b = F @ np.swapaxes(F, 1, 2)
    nearby = F + 0.003 * rng.standard_normal(F.shape)
    warm = np.linalg.eigh(nearby @ np.swapaxes(nearby, 1, 2))[1]
    for guess in (np.broadcast_to(np.eye(3), F.shape), warm):
        q, lam = wp.array(guess, dtype=k.mat33), wp.zeros(len(F), dtype=k.vec3)
        wp.launch(k.eigen, len(F), inputs=[wp.array(F, dtype=k.mat33), wp.zeros(len(F), dtype=k.mat33),
                                           dtype(0.0), q], outputs=[q, lam])
        Q, values = q.numpy().astype(np.float64), lam.numpy().astype(np.float64)
        np.testing.assert_allclose(np.swapaxes(Q, 1, 2) @ Q, np.broadcast_to(np.eye(3), Q.shape), atol=10 * tolerance)
        np.testing.assert_allclose(Q @ (values[:, :, None] * np.swapaxes(Q, 1, 2)), b, atol=tolerance * 10)
        np.testing.assert_allclose(np.sort(values, axis=1), np.linalg.eigvalsh(b), atol=tolerance * 10)
