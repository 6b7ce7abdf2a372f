"""fit: the constitutive parameters, in two phases (thesis Appendix A): a warm-up on the first frames, then every frame
with the learning rate restarted. Adam on the log-parameters with cosine annealing; every iteration recorded and
checkpointed, so an interrupted fit resumes where it stopped. The full phase adds 95 % intervals (Laplace,
cluster-robust) and writes params.json and history.csv."""

import csv
import math
from pathlib import Path

import numpy as np
import torch

from rheo.experiments.scene import material
from rheo.fit.inverse import Phase, build_problem, initial_guess, log_values, run_phase
from rheo.fit.observations import load
from rheo.fit.uncertainty import laplace_intervals
from rheo.io import read_json, write_atomic, write_json_atomic
from rheo.stage import inputs_key, setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
exp, phase_name = smk.params.experiment, smk.params.phase
settings = exp["fit"]
warmup = phase_name == "warmup"
frames = settings["warmup"]["frames"] + 1 if warmup else None
obs = load(smk.input.recordings, smk.input.matte, smk.input.cameras, frames=frames)
problem = build_problem(exp, obs, smk.input.seed)
# the fitted variables: the log-parameters, then the initial velocity (refined jointly from the velocity stage's
# estimate) in units of VELOCITY_SCALE, so that one Adam step moves it by a fraction of that
VELOCITY_SCALE = 0.5  # m/s
count = len(problem.names)
if warmup:
    v0 = torch.tensor(read_json(smk.input.velocity)["v0"], dtype=torch.float64)
    start = torch.cat([log_values(initial_guess(exp), problem.names), v0 / VELOCITY_SCALE])
    phase = Phase("warm-up", obs.frames - 1, settings["warmup"]["iterations"], settings["warmup"]["learning_rate"])
else:
    start = torch.tensor(read_json(smk.input.warmup)["variables"], dtype=torch.float64)
    phase = Phase("full", obs.frames - 1, settings["full"]["iterations"], settings["full"]["learning_rate"])
output = Path(smk.output[0])
checkpoint = output.with_suffix(".checkpoint")
key = inputs_key([exp, phase_name], [smk.input.seed, smk.input.cameras, smk.input.velocity,
                                     *([] if warmup else [smk.input.warmup])])


def loss(variables: torch.Tensor, frame_count: int, rng: np.random.Generator) -> torch.Tensor:
    return problem.loss(variables[:count], VELOCITY_SCALE * variables[count:], frame_count,
                        settings["rays_per_view"], rng)


def describe(variables: torch.Tensor) -> dict[str, float]:
    velocity = (VELOCITY_SCALE * variables[count:]).tolist()
    return {**dict(zip(problem.names, torch.exp(variables[:count]).tolist(), strict=True)),
            **dict(zip(("vx", "vy", "vz"), velocity, strict=True))}


fitted, history = run_phase(phase, start, loss, describe, checkpoint, key)
values = describe(fitted)
log.info("%s: %s", phase.name, ", ".join(f"{k} = {v:.4g}" for k, v in values.items()))
if warmup:
    write_json_atomic(smk.output.warmup, {"values": values, "variables": fitted.tolist(), "history": history})
else:
    v0 = VELOCITY_SCALE * fitted[count:]
    intervals, evidence = laplace_intervals(problem, fitted[:count], v0, obs.frames - 1, settings["rays_per_view"])
    truth = read_json(smk.input.truth)["material"]["as_configured"] if hasattr(smk.input, "truth") else {}
    guess = initial_guess(exp)
    params = {}
    for name, interval in intervals.items():
        entry = {"value": interval.value, "ci95": [interval.low, interval.high], "determined": interval.determined,
                 "initial": guess[name]}
        if name in truth:
            entry.update(truth=truth[name], error=interval.value / truth[name] - 1.0)
        params[name] = entry
        log.info("%s = %.4g, 95%% interval [%.4g, %.4g]%s%s", name, interval.value, interval.low, interval.high,
                 "" if interval.determined else " (not determined by the recording)",
                 f", truth {truth[name]:.4g} ({entry['error']:+.1%})" if name in truth else "")
    hb = material({**exp["material"], **{k: values[k] for k in problem.names}})
    write_json_atomic(smk.output.params, {
        "convention": exp["material"]["convention"], "parameters": params, "evidence": evidence,
        "herschel_bulkley": {"tau_y": hb.tau_y, "K": hb.K, "n": hb.n, "mu": hb.mu, "lam": hb.lam,
                             "density": hb.density},
        "initial_velocity": v0.tolist(), "final_loss": history[-1]["loss"] if history else math.nan})
    rows = read_json(smk.input.warmup)["history"] + history

    def write_history(path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    write_atomic(smk.output.history, write_history)
checkpoint.unlink(missing_ok=True)
