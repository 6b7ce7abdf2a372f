"""Benchmark of the MPM engine: time per step (forward, forward+backward), memory kept per step, and the peak
resident memory of a long differentiable rollout.

    python -m rheo.physics.bench --out results/bench/physics.json
    python -m rheo.physics.bench --device cuda --grids 32 64 128 --out results/bench/physics_cuda.json

Cases: a cylinder (radius 0.2, height 0.4) of Herschel-Bulkley material in the unit box, 8 particles per cell, on
each grid (32^3 and 48^3 unless --grids says otherwise); then a 1,000-step forward+backward rollout with about 15k
particles on 32^3, run in a child process so that its peak resident memory is its own (host memory: on a GPU most
of the rollout's memory is the GPU's).
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import torch

from rheo.geometry.sampling import cylinder
from rheo.io import write_json_atomic
from rheo.physics import Floor, HerschelBulkley, Simulator
from rheo.physics.device import DEVICES, device_name, set_default_device

MATERIAL = HerschelBulkley.from_pacnerf(sigma_y=1000.0, eta=10.0, mu=1.0e4, lam=1.0e4)
DT = 1e-3


def _scene(resolution: int, height: float = 0.4) -> tuple[Simulator, torch.Tensor, float]:
    floor = 3 / resolution
    sim = Simulator(MATERIAL, resolution=resolution, colliders=[Floor(height=floor)])
    x0, vol = cylinder((0.5, 0.5), floor, 0.2, height, sim.dx / 2, dtype=torch.float32)
    return sim, x0, vol


def _rollout_and_backward(sim: Simulator, x0: torch.Tensor, vol: float, steps: int) -> None:
    params = sim.material_parameters().requires_grad_()
    tr = sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=steps * DT, particle_volume=vol,
                     material_params=params, dt=DT)
    (tr.x[-1, :, 1].mean() + tr.v[-1].square().mean()).backward()


def measure_case(resolution: int, steps: int) -> dict:
    sim, x0, vol = _scene(resolution)
    sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=2 * DT, particle_volume=vol, dt=DT)  # compile, warm up
    _rollout_and_backward(sim, x0, vol, steps)  # allocate the per-step buffers once
    start = time.perf_counter()
    sim.rollout(x0, torch.zeros(3), frames=1, frame_dt=steps * DT, particle_volume=vol, dt=DT)
    forward = (time.perf_counter() - start) / steps
    start = time.perf_counter()
    _rollout_and_backward(sim, x0, vol, steps)
    both = (time.perf_counter() - start) / steps
    return {"grid": resolution, "particles": len(x0), "steps": steps, "forward_ms": round(forward * 1e3, 2),
            "forward_backward_ms": round(both * 1e3, 2),
            "retained_mb_per_step": round(sim.bytes_per_step(len(x0)) / 2**20, 2)}


def measure_rollout(steps: int) -> dict:
    sim, x0, vol = _scene(32, height=0.45)
    start = time.perf_counter()
    _rollout_and_backward(sim, x0, vol, steps)
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {"steps": steps, "particles": len(x0), "grid": 32, "seconds": round(time.perf_counter() - start, 1),
            "peak_rss_mb": round(peak_kb / 1024, 1), "checkpoint_mb": sim.checkpoint_mb}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--steps", type=int, default=40, help="steps timed per case")
    parser.add_argument("--rollout-steps", type=int, default=1000)
    parser.add_argument("--grids", type=int, nargs="+", default=[32, 48], help="cells per axis of the timed cases")
    parser.add_argument("--device", choices=DEVICES, default="cpu")
    parser.add_argument("--only-rollout", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    torch.set_num_threads(2)
    set_default_device(args.device)
    if args.only_rollout:
        print(json.dumps(measure_rollout(args.rollout_steps)))
        return
    cases = [measure_case(res, args.steps) for res in args.grids]
    child = subprocess.run([sys.executable, "-m", "rheo.physics.bench", "--out", str(args.out), "--only-rollout",
                            "--rollout-steps", str(args.rollout_steps), "--device", args.device],
                           check=True, capture_output=True, text=True)
    rollout = json.loads(child.stdout.strip().splitlines()[-1])
    report = {"cases": cases, "rollout": rollout, "threads": 2, "machine": platform.processor() or platform.machine(),
              "device": device_name(args.device), "dtype": "float32", "dt": DT}
    write_json_atomic(args.out, report)
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
