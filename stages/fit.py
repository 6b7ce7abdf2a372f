"""fit: the constitutive parameters on whole-frame silhouettes (rheo.fit.search), in two phases: a warm-up that surveys
a wide box of log-parameters on the first frames, each material with the velocity stage's initial velocity and at
rest, and then refines the initial velocity at the survey's best material and velocity;
then simplex searches on every frame from the survey's best few points, rounds of a composite design around the best
point found, each followed by a quadratic fitted to the squared losses (rheo.fit.surface): its lowest point, or the
best material evaluated where that loses less, is the estimate, and the region where it stays within the tolerance
gives the intervals. Parameters the recording does not determine are held at their initial guess and the others
searched again (a simplex, then their surface). Evaluations run on the stage's threads side by side, and every one
is stored, so an interrupted fit replays them and goes on. The full phase writes params.json and history.csv."""

import csv
from functools import partial
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from rheo.experiments.scene import material
from rheo.fit.inverse import PARAMETERS, initial_guess, log_values, silhouette_objectives, survey_velocities
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, estimate, simplex_search, start_step, survey_points
from rheo.io import evaluations_path, read_json, write_atomic, write_json_atomic
from rheo.stage import inputs_key, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
exp, phase_name = smk.params.experiment, smk.params.phase
settings = exp["fit"]
warmup = phase_name == "warmup"
names = PARAMETERS[exp["material"]["convention"]]
count = len(names)
VELOCITY_STEP = 0.05  # m/s, the initial simplex of the velocity refinement

initial = initial_guess(exp)
guess = log_values(initial, names).numpy()
half_width = np.log(settings["warmup"]["box"])
box = (guess - half_width, guess + half_width)
output = Path(smk.output[0])
evaluations = EvaluationLog(evaluations_path(output),
                            inputs_key([exp, phase_name], [smk.input.seed, smk.input.cameras, smk.input.velocity,
                                                           *([] if warmup else [smk.input.warmup])]),
                            one_objective=True)
bar = tqdm(desc=phase_name, unit="evaluation", total=settings["warmup"]["samples"] if warmup else None)


def describe(z: np.ndarray) -> dict[str, float]:
    """The variables z = (log-parameters, initial velocity) by name."""
    return {**dict(zip(names, np.exp(z[:count]).tolist(), strict=True)),
            **dict(zip(("vx", "vy", "vz"), z[count:].tolist(), strict=True))}


def history_rows(records: list[dict]) -> list[dict]:
    best = np.inf
    rows = []
    for i, record in enumerate(records):
        best = min(best, record["loss"])
        rows.append({"phase": record["phase"], "evaluation": i, "loss": record["loss"], "best_loss": best,
                     **describe(np.asarray(record["x"]))})
    return rows


frames = settings["warmup"]["frames"] + 1 if warmup else None
objectives = partial(silhouette_objectives, exp, smk.input.recordings, smk.input.matte, smk.input.cameras,
                     smk.input.seed, frames)
with Evaluator(objectives, workers=smk.threads) as evaluator:

    def evaluate_many(points: list[np.ndarray], phase: str) -> list[float]:
        """The losses of ``points`` (log-parameters and initial velocity), new ones side by side on the workers."""

        def losses(todo: list[np.ndarray]) -> list[float]:
            values = evaluator.map([("loss", z) for z in todo])
            for z, value in zip(todo, values, strict=True):
                bar.update()
                log.info("%s %d: loss %.5g px, %s", phase, bar.n, value,
                         ", ".join(f"{n} {v:.4g}" for n, v in describe(z).items()))
            return values

        return evaluations.evaluate_many(losses, points, phase)

    if warmup:
        points = survey_points(guess, half_width, settings["warmup"]["samples"])
        chunk = max(smk.threads, 1)  # chunks that keep every worker busy, each stored as it ends
        found = []
        for phase, v0 in survey_velocities(np.asarray(read_json(smk.input.velocity)["v0"], dtype=float)):
            losses = np.concatenate([evaluate_many([np.r_[x, v0] for x in points[i:i + chunk]], phase)
                                     for i in range(0, len(points), chunk)])
            found.append((float(losses.min()), phase, points[int(np.argmin(losses))], v0))
        _, survey, x, v0 = min(found, key=lambda f: f[0])
        v0, value = simplex_search(lambda v, phase: evaluate_many([np.r_[x, v]], phase)[0], v0, VELOCITY_STEP,
                                   settings["warmup"]["velocity_evaluations"], "velocity",
                                   tolerance=0.1 * VELOCITY_STEP)
        values = describe(np.r_[x, v0])
        log.info("warm-up: best of %d survey points, loss %.5g px: %s", len(points), value,
                 ", ".join(f"{n} {v:.4g}" for n, v in values.items()))
        write_json_atomic(smk.output.warmup, {"values": values, "log_values": x.tolist(), "v0": v0.tolist(),
                                              "loss": value, "survey": survey,
                                              "history": history_rows(evaluations.records)})
    else:
        warm = read_json(smk.input.warmup)
        v0 = np.asarray(warm["v0"])
        chosen = warm.get("survey", "survey")  # (a warm-up before the survey from rest had one survey)
        surveyed = sorted((row for row in warm["history"] if row["phase"] == chosen),
                          key=lambda row: row["loss"])
        starts = [np.log([row[n] for n in names]) for row in surveyed[:settings["full"]["starts"]]]

        def seen() -> tuple[np.ndarray, np.ndarray]:
            """The material of every point evaluated so far (the initial velocity is fixed) and its loss."""
            points, losses = evaluations.seen()
            return (points[:, :count] if len(points) else points), losses

        result = estimate(lambda points, phase: evaluate_many([np.r_[x, v0] for x in points], phase), starts, names,
                          seen=seen, evaluations=settings["full"]["evaluations"],
                          start_step=start_step(2 * half_width, settings["warmup"]["samples"], count),
                          half_width=settings["full"]["half_width"], rounds=settings["full"]["rounds"],
                          tolerance=settings["tolerance"], box=box, guess=guess, side_by_side=smk.threads > 1)
bar.close()

if not warmup:
    truth = read_json(smk.input.truth)["material"]["as_configured"] if hasattr(smk.input, "truth") else {}
    params = {}
    for name, interval in result.intervals.items():
        # a held parameter is its configured guess exactly (not the guess through log and exp)
        value = initial[name] if name in result.held else interval.value
        entry = {"value": value, "interval": [min(interval.low, value), max(interval.high, value)],
                 "interval_open": list(interval.open),
                 "determined": interval.determined, "held_at_initial_guess": name in result.held,
                 "initial": initial[name]}
        if name in truth:  # no error where the parameter was held at its guess: it was not recovered
            entry.update(truth=truth[name], error=None if name in result.held else interval.value / truth[name] - 1.0)
        params[name] = entry
        log.info("%s = %.4g, tolerance interval [%.4g, %.4g]%s%s", name, interval.value, interval.low, interval.high,
                 "" if interval.determined else " (not determined by the recording"
                 + (": held at the initial guess)" if name in result.held else ")"),
                 "" if entry.get("error") is None else f", truth {truth[name]:.4g} ({entry['error']:+.1%})")
    hb = material({**exp["material"], **{n: p["value"] for n, p in params.items()}})
    write_json_atomic(smk.output.params, {
        "convention": exp["material"]["convention"], "parameters": params, "evidence": result.evidence,
        "tolerance": settings["tolerance"], "herschel_bulkley": {"tau_y": hb.tau_y, "K": hb.K, "n": hb.n,
                                                                 "mu": hb.mu, "lam": hb.lam, "density": hb.density},
        "initial_velocity": v0.tolist(), "final_loss": result.loss, "loss_units": "px"})
    rows = warm["history"] + history_rows(evaluations.records)

    def write_history(path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    write_atomic(smk.output.history, write_history)
evaluations.path.unlink(missing_ok=True)
