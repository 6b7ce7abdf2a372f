"""Where rollouts run: the device choice, checkpointed chunks, and a GPU's rollouts against the CPU's (run only where
Warp sees a CUDA GPU)."""

import multiprocessing
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import torch
import warp as wp

from rheo.fit.parallel import Evaluator
from rheo.geometry.sampling import cylinder
from rheo.physics import Floor, HerschelBulkley, OptionalPhysics, SimulationError, Simulator, simulator
from rheo.physics.device import resolve_device, set_default_device

wp.init()
HAS_CUDA = wp.get_cuda_device_count() > 0
needs_cuda = pytest.mark.skipif(not HAS_CUDA, reason="Warp sees no CUDA GPU")
MATERIAL = HerschelBulkley(tau_y=200.0, K=20.0, n=0.6, mu=2.0e4, lam=2.0e4)
BASE = OptionalPhysics()
# every optional term that a rollout can differentiate, on at once
OPTIONS = OptionalPhysics(air_drag=5.0, open_drag=(2.0, -1.0, 1.0, 0.5), open_layer=0.05, open_span=0.03)


def _rollout(device: str, checkpoint_mb: float = 1024.0, dtype=torch.float64,
             physics: OptionalPhysics = BASE):
    """A 30-step slump of a small cylinder and the gradient of a loss on its last frame w.r.t. the material."""
    sim = Simulator(MATERIAL, resolution=16, colliders=[Floor(height=3.3 / 16)], dtype=dtype, device=device,
                    checkpoint_mb=checkpoint_mb, physics=physics)
    x0, vol = cylinder((0.5, 0.5), 3.3 / 16, 0.12, 0.25, sim.dx / 2, dtype=dtype)
    mat = sim.material_parameters().requires_grad_()
    tr = sim.rollout(x0, torch.zeros(3), frames=3, frame_dt=0.01, particle_volume=vol, material_params=mat,
                     dt=1e-3)
    (tr.x[-1, :, 1].square().sum() + tr.v[2].square().sum()).backward()
    return tr.x.detach(), mat.grad


def test_device_names():
    assert resolve_device("cpu") == "cpu"
    assert resolve_device("auto") == ("cuda:0" if HAS_CUDA else "cpu")
    with pytest.raises(SimulationError, match="must be one of auto, cpu, cuda"):
        set_default_device("gpu")
    if not HAS_CUDA:
        with pytest.raises(SimulationError, match="Warp sees no CUDA GPU"):
            Simulator(MATERIAL, resolution=16, device="cuda")


def test_checkpointed_chunks_match_one_chunk():
    """A rollout cut into chunks (states saved and reloaded, each chunk recomputed for its backward pass) gives the
    single chunk's trajectory and gradient."""
    x_whole, grad_whole = _rollout("cpu")
    x_chunked, grad_chunked = _rollout("cpu", checkpoint_mb=0.5)
    torch.testing.assert_close(x_chunked, x_whole, rtol=0, atol=1e-12)
    torch.testing.assert_close(grad_chunked, grad_whole, rtol=1e-9, atol=0)


@needs_cuda
def test_gpu_matches_cpu():
    """Forward states and gradients on the GPU equal the CPU's within float tolerance (atomic sums run in another
    order there), for the base model and with the optional terms on."""
    for checkpoint_mb, physics in ((1024.0, BASE), (0.5, BASE), (1024.0, OPTIONS)):
        x_cpu, grad_cpu = _rollout("cpu", checkpoint_mb, physics=physics)
        x_gpu, grad_gpu = _rollout("cuda", checkpoint_mb, physics=physics)
        assert x_gpu.device.type == "cpu"
        torch.testing.assert_close(x_gpu, x_cpu, rtol=0, atol=1e-9)
        torch.testing.assert_close(grad_gpu, grad_cpu, rtol=1e-6, atol=1e-9 * float(grad_cpu.abs().max()))
    x32_cpu, _ = _rollout("cpu", dtype=torch.float32)
    x32_gpu, _ = _rollout("cuda", dtype=torch.float32)
    assert float((x32_gpu - x32_cpu).abs().max()) < 1e-4 * (1 / 16)


@pytest.mark.parametrize("device", [pytest.param("cuda", marks=needs_cuda), "cpu"])
def test_rollouts_in_threads_match_one_after_another(device):
    """Rollouts that threads of one process run at once (a fit's searches side by side) give the trajectories and
    gradients of the same rollouts one after another, on the GPU and on the CPU (where a GPU is present, Warp's
    default device is the GPU's)."""
    alone = [_rollout(device) for _ in range(4)]
    with ThreadPoolExecutor(4) as threads:
        together = list(threads.map(lambda _: _rollout(device), range(4)))
    for (x, grad), (x_alone, grad_alone) in zip(together, alone, strict=True):
        torch.testing.assert_close(x, x_alone, rtol=0, atol=1e-9)
        torch.testing.assert_close(grad, grad_alone, rtol=1e-6, atol=1e-9 * float(grad_alone.abs().max()))


def test_a_process_forked_while_a_thread_simulates_can_simulate():
    """A worker forked while another thread of its parent holds the simulator's device lock does not inherit it
    held: its rollout finishes."""
    held, release = threading.Event(), threading.Event()

    def simulate_until_released() -> None:
        with simulator._on_device("cpu"):
            held.set()
            release.wait()

    thread = threading.Thread(target=simulate_until_released)
    thread.start()
    held.wait()
    try:
        child = multiprocessing.get_context("fork").Process(target=_rollout, args=("cpu",))
        child.start()
        child.join(120)
        hung = child.is_alive()
        if hung:
            child.kill()
    finally:
        release.set()
        thread.join()
    assert not hung and child.exitcode == 0


def _objectives():
    return {"square": lambda x: float(np.sum(np.square(x)))}


@needs_cuda
def test_evaluator_runs_in_process_on_gpu():
    set_default_device("cuda")
    try:
        with Evaluator(_objectives, workers=4) as evaluator:
            assert evaluator.workers == 1
            assert evaluator.map([("square", np.array([3.0, 4.0]))]) == [25.0]
    finally:
        set_default_device("cpu")
