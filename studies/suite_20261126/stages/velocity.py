"""velocity: the initial velocity (one vector for the whole material) from the first frames, with the material held
at its initial guess."""

from pathlib import Path

import numpy as np
import torch

from rheo.fit.inverse import Phase, build_problem, initial_guess, log_values, run_phase
from rheo.fit.observations import load
from rheo.io import write_json_atomic
from rheo.stage import inputs_key, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
exp = smk.params.experiment
settings = exp["fit"]["velocity"]
obs = load(smk.input.recordings, smk.input.matte, smk.input.cameras, frames=settings["frames"] + 1)
problem = build_problem(exp, obs, smk.input.seed)
material = log_values(initial_guess(exp), problem.names)
checkpoint = Path(smk.output.velocity).with_suffix(".checkpoint")
phase = Phase("velocity", settings["frames"], settings["iterations"], settings["learning_rate"])


def loss(v0: torch.Tensor, frames: int, rng: np.random.Generator) -> torch.Tensor:
    return problem.loss(material, v0, frames, exp["fit"]["rays_per_view"], rng)


v0, history = run_phase(phase, torch.tensor(exp["simulation"]["initial_velocity"], dtype=torch.float64), loss,
                        lambda v: dict(zip(("vx", "vy", "vz"), v.tolist(), strict=True)),
                        checkpoint, key=inputs_key(exp, [smk.input.seed, smk.input.cameras]))
log.info("initial velocity %s m/s", np.round(v0.numpy(), 4).tolist())
write_json_atomic(smk.output.velocity, {"v0": v0.tolist(), "frames": settings["frames"], "history": history})
checkpoint.unlink(missing_ok=True)
