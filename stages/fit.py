"""fit: the constitutive parameters on whole-frame silhouettes (rheo.fit.search), in two phases: a warm-up that surveys
a wide box of log-parameters on the first frames and then refines the initial velocity (the velocity stage's estimate
was made with the material at its guess, whose different collapse it partly absorbs) at the survey's best material;
then simplex searches on every frame from the survey's best few points, continued from the best of them, intervals
from profiles of the loss, and parameters the recording does not determine held at their initial guess. Every
evaluation is stored, so an interrupted fit replays them and goes on. The full phase writes params.json and
history.csv."""

import csv
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

from rheo.experiments.scene import material
from rheo.fit.inverse import build_problem, initial_guess, log_values
from rheo.fit.observations import load
from rheo.fit.search import EvaluationLog, SilhouetteTarget, estimate, simplex_search, start_step, survey
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
names = problem.names
target = SilhouetteTarget(obs, obs.frames - 1)
VELOCITY_STEP = 0.05  # m/s, the initial simplex of the velocity refinement
initial = initial_guess(exp)
guess = log_values(initial, names).numpy()
half_width = np.log(settings["warmup"]["box"])
box = (guess - half_width, guess + half_width)
output = Path(smk.output[0])
evaluations = EvaluationLog(output.with_suffix(".evaluations.json"),
                            inputs_key([exp, phase_name], [smk.input.seed, smk.input.cameras, smk.input.velocity,
                                                           *([] if warmup else [smk.input.warmup])]))
bar = tqdm(desc=phase_name, unit="evaluation", total=settings["warmup"]["samples"] if warmup else None)


count = len(names)


def describe(z: np.ndarray) -> dict[str, float]:
    """The variables z = (log-parameters, initial velocity) by name."""
    return {**dict(zip(names, np.exp(z[:count]).tolist(), strict=True)),
            **dict(zip(("vx", "vy", "vz"), z[count:].tolist(), strict=True))}


def loss(z: np.ndarray) -> float:
    with torch.no_grad():
        trajectory = problem.simulate(torch.as_tensor(z[:count]), torch.as_tensor(z[count:]), target.frames)
    return float(target.distances(trajectory.x.numpy(), problem.spacing).mean())


def evaluate(z: np.ndarray, phase: str) -> float:
    value = evaluations.evaluate(loss, z, phase)
    bar.update()
    log.info("%s %d: loss %.5g px, %s", phase, bar.n, value,
             ", ".join(f"{n} {v:.4g}" for n, v in describe(z).items()))
    return value


def history_rows(records: list[dict]) -> list[dict]:
    best = np.inf
    rows = []
    for i, record in enumerate(records):
        best = min(best, record["loss"])
        rows.append({"phase": record["phase"], "evaluation": i, "loss": record["loss"], "best_loss": best,
                     **describe(np.asarray(record["x"]))})
    return rows


if warmup:
    v0 = np.asarray(read_json(smk.input.velocity)["v0"], dtype=float)
    points, losses = survey(lambda x, phase: evaluate(np.r_[x, v0], phase), guess, half_width,
                            settings["warmup"]["samples"])
    x, value = points[0], losses[0]
    v0, value = simplex_search(lambda v, phase: evaluate(np.r_[x, v], phase), v0, VELOCITY_STEP,
                               settings["warmup"]["velocity_evaluations"], "velocity", tolerance=0.1 * VELOCITY_STEP)
    values = describe(np.r_[x, v0])
    log.info("warm-up: best of %d survey points, loss %.5g px: %s", settings["warmup"]["samples"], value,
             ", ".join(f"{n} {v:.4g}" for n, v in values.items()))
    write_json_atomic(smk.output.warmup, {"values": values, "log_values": x.tolist(), "v0": v0.tolist(),
                                          "loss": value, "history": history_rows(evaluations.records)})
else:
    warm = read_json(smk.input.warmup)
    v0 = np.asarray(warm["v0"])
    surveyed = sorted((row for row in warm["history"] if row["phase"] == "survey"), key=lambda row: row["loss"])
    starts = [np.log([row[n] for n in names]) for row in surveyed[:settings["full"]["starts"]]]
    result = estimate(lambda x, phase: evaluate(np.r_[x, v0], phase), starts, guess, names,
                      evaluations=settings["full"]["evaluations"],
                      start_step=start_step(2 * half_width, settings["warmup"]["samples"], count),
                      step=settings["full"]["step"], profile_step=settings["profile_step"],
                      tolerance=settings["tolerance"], box=box)
    truth = read_json(smk.input.truth)["material"]["as_configured"] if hasattr(smk.input, "truth") else {}
    params = {}
    for name, interval in result.intervals.items():
        entry = {"value": interval.value, "ci95": [interval.low, interval.high], "determined": interval.determined,
                 "held_at_initial_guess": name in result.held, "initial": initial[name]}
        if name in truth:
            entry.update(truth=truth[name], error=interval.value / truth[name] - 1.0)
        params[name] = entry
        log.info("%s = %.4g, 95%% interval [%.4g, %.4g]%s%s", name, interval.value, interval.low, interval.high,
                 "" if interval.determined else " (not determined by the recording"
                 + (": held at the initial guess)" if name in result.held else ")"),
                 f", truth {truth[name]:.4g} ({entry['error']:+.1%})" if name in truth else "")
    hb = material({**exp["material"], **{n: p["value"] for n, p in params.items()}})
    write_json_atomic(smk.output.params, {
        "convention": exp["material"]["convention"], "parameters": params, "evidence": result.evidence,
        "tolerance": settings["tolerance"], "herschel_bulkley": {"tau_y": hb.tau_y, "K": hb.K, "n": hb.n,
                                                                 "mu": hb.mu, "lam": hb.lam, "density": hb.density},
        "initial_velocity": v0.tolist(), "final_loss": result.loss, "loss_units": "px"})
    rows = read_json(smk.input.warmup)["history"] + history_rows(evaluations.records)

    def write_history(path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    write_atomic(smk.output.history, write_history)
bar.close()
evaluations.path.unlink(missing_ok=True)
