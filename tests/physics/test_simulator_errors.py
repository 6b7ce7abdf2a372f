"""Bad input and instability: one clear error naming the value and the limit; logged retries at half the step."""

import logging
import math

import pytest
import torch

from rheo.geometry.sampling import box
from rheo.physics import Floor, HerschelBulkley, SimulationError, SimulationUnstable, Simulator
from rheo.physics.boundaries import BoundaryError


def _block(sim):
    return box((0.4, 0.3, 0.4), (0.6, 0.5, 0.6), sim.dx / 2, dtype=torch.float32)


def test_particles_outside_the_domain_are_refused():
    sim = Simulator(HerschelBulkley(), resolution=16)
    x0, vol = _block(sim)
    x0[5, 1] = 0.99
    with pytest.raises(SimulationError, match=r"1 particle\(s\) lie outside the simulation domain, e.g. particle 5"):
        sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=0.01, particle_volume=vol)


@pytest.mark.parametrize(("override", "message"), [
    (lambda m: m.index_fill(0, torch.tensor([2]), -5.0), "K = -5.0 is invalid"),
    (lambda m: m.index_fill(0, torch.tensor([1]), math.nan), "tau_y = nan is invalid"),
])
def test_bad_material_parameters_in_a_rollout(override, message):
    sim = Simulator(HerschelBulkley(), resolution=16)
    x0, vol = _block(sim)
    with pytest.raises(ValueError, match=message):
        sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=0.01, particle_volume=vol,
                    material_params=override(sim.material_parameters()))


def test_bad_colliders_and_settings():
    with pytest.raises(BoundaryError, match="unknown contact law 'glue'"):
        Floor(contact="glue")
    with pytest.raises(BoundaryError, match=r"friction coefficient -0\.1 must be finite and >= 0"):
        Floor(contact="friction", friction=-0.1)
    with pytest.raises(SimulationError, match="grid resolution 4 must be an integer >= 8"):
        Simulator(HerschelBulkley(), resolution=4)
    sim = Simulator(HerschelBulkley(), resolution=16)
    x0, vol = _block(sim)
    with pytest.raises(SimulationError, match="initial velocity must be finite"):
        sim.rollout(x0, torch.full((3,), math.inf), frames=1, frame_dt=0.01, particle_volume=vol)
    with pytest.raises(SimulationError, match=r"transfer interval -0\.01 s must be finite and > 0"):
        Simulator(HerschelBulkley(), resolution=16, transfer_dt=-0.01)
    with pytest.raises(SimulationError, match=r"transfers every few steps .* cannot be differentiated"):
        Simulator(HerschelBulkley(), resolution=16, transfer_dt=0.005).rollout(
            x0.requires_grad_(), torch.zeros(3), frames=1, frame_dt=0.01, particle_volume=vol)


def test_unstable_step_is_retried_at_half_the_step(caplog):
    stiff = HerschelBulkley(tau_y=1.0e5, K=1.0, n=1.0, mu=1.0e6, lam=1.0e6)
    sim = Simulator(stiff, resolution=16, colliders=[Floor(height=3 / 16)], max_halvings=6)
    x0, vol = _block(sim)
    v0 = torch.tensor([0.0, -2.0, 0.0])
    with caplog.at_level(logging.WARNING):
        tr = sim.rollout(x0, v0, frames=2, frame_dt=0.02, particle_volume=vol, dt=5e-3)
    assert "simulation unstable at step" in caplog.text and "retrying at dt" in caplog.text
    assert tr.dt < 5e-3 and torch.isfinite(tr.x).all()


def test_unstable_at_the_smallest_step_raises():
    stiff = HerschelBulkley(tau_y=1.0e5, K=1.0, n=1.0, mu=1.0e6, lam=1.0e6)
    sim = Simulator(stiff, resolution=16, colliders=[Floor(height=3 / 16)], max_halvings=1)
    x0, vol = _block(sim)
    with pytest.raises(SimulationUnstable, match=r"simulation unstable at step \d+ .* even at dt = 0.0025 s"):
        sim.rollout(x0, torch.tensor([0.0, -2.0, 0.0]), frames=2, frame_dt=0.02, particle_volume=vol, dt=5e-3)


def test_a_fixed_step_is_shared_by_every_material():
    soft, stiff = HerschelBulkley(mu=1.0e3, lam=1.0e3), HerschelBulkley(mu=1.0e4, lam=1.0e4)
    steps = {}
    for fixed in (None, 1.0e-3):
        for name, material in (("soft", soft), ("stiff", stiff)):
            sim = Simulator(material, resolution=16, colliders=[Floor(height=3 / 16)], dt=fixed)
            x0, vol = _block(sim)
            steps[fixed, name] = sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=0.01, particle_volume=vol)
    assert steps[None, "stiff"].dt < steps[None, "soft"].dt  # each material's own stability limit
    assert steps[1.0e-3, "soft"].dt == steps[1.0e-3, "stiff"].dt == pytest.approx(1.0e-3)
    explicit = Simulator(soft, resolution=16, colliders=[Floor(height=3 / 16)])
    x0, vol = _block(explicit)
    same = explicit.rollout(x0, torch.zeros(3), frames=1, frame_dt=0.01, particle_volume=vol, dt=1.0e-3)
    assert torch.equal(same.x, steps[1.0e-3, "soft"].x)
    with pytest.raises(SimulationError, match=r"time step -0\.001 s must be finite and > 0"):
        Simulator(soft, resolution=16, dt=-1.0e-3)
