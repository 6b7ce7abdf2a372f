"""virheometry_fit: tau_y, K and n (or tau_y and K at a fixed flow index) of one material from its dam breaks (all
its setups jointly, or one), with the first frame's time after the release found for each setup. The survey's
points and the profile's run on every core; the searches from the survey's best points run side by side, each
evaluation simulating the setups side by side; a walk along the valley the equally good materials spread in widens
the intervals where the parameters trade against each other. Every evaluation is stored, so an interrupted fit
resumes."""

import csv
import dataclasses
import time
from functools import partial
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from rheo.diagnose.candidates import Law
from rheo.fit.dam_break import MOVING_RATE, RESULT_KEYS, comparisons, setup_files, shear_rate_band
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, multistart_search, start_step, survey_points
from rheo.fit.uncertainty import Tolerated, profile_intervals, profile_points, ridge_walk, tolerated
from rheo.io import write_atomic, write_json_atomic
from rheo.report.figures import save_figure
from rheo.report.virheometry import frames_figure
from rheo.stage import inputs_key, setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
RIDGE_STEP = 1.5  # the walk along the valley's steps, in profile steps
log = setup_logging(smk.log[0])
started = time.time()
settings, simulation = smk.params.settings, smk.params.simulation
setups = setup_files(smk.input.setups, smk.input.masks)
law = Law(n=settings.get("flow_index"))
names = law.names
low = np.log([settings[n][0] for n in names])
high = np.log([settings[n][1] for n in names])
output = Path(smk.output.params)
evaluations = EvaluationLog(output.with_suffix(".evaluations.json"),
                            inputs_key([settings, simulation], [*smk.input.setups, *smk.input.masks]),
                            one_objective=True)
bar = tqdm(desc=f"{output.parent.parent.name} {output.parent.name}", unit="evaluation")


def equally_good() -> Tolerated:
    """The materials evaluated so far within the tolerance of the best."""
    return tolerated([r["x"] for r in evaluations.records], [r["loss"] for r in evaluations.records],
                     settings["tolerance"])


def describe(x: np.ndarray) -> str:
    return ", ".join(f"{n} {v:.4g}" for n, v in zip(names, np.exp(x), strict=True))


with Evaluator(partial(comparisons, setups, simulation, law), workers=smk.threads) as evaluator:

    def joint(points: list[np.ndarray]) -> list[float]:
        """The mean over the setups of each point's loss; all (setup, point) simulations side by side, one setup's
        after the other's, so that the workers end together where the setups take unequal times."""
        results = evaluator.map([(name, x) for name in setups for x in points])
        losses = [float(np.mean([results[k * len(points) + i].loss for k in range(len(setups))]))
                  for i in range(len(points))]
        for x, loss in zip(points, losses, strict=True):
            bar.update()
            log.info("evaluation %d: loss %.5g px, %s", bar.n, loss, describe(x))
        return losses

    def evaluate(x: np.ndarray, phase: str) -> float:
        return evaluations.evaluate_many(joint, [x], phase)[0]

    points = survey_points(0.5 * (low + high), 0.5 * (high - low), settings["samples"])
    # in chunks that keep every worker busy, each stored as it ends
    chunk = max(smk.threads, 1)
    losses = np.concatenate([evaluations.evaluate_many(joint, list(points[i:i + chunk]), "survey")
                             for i in range(0, len(points), chunk)])
    starts = points[np.argsort(losses, kind="stable")[:settings["starts"]]]
    x, loss = multistart_search(evaluate, list(starts), start_step((high - low).min(), settings["samples"], len(names)),
                                settings["step"], settings["evaluations"], (low, high), side_by_side=True)
    evaluations.evaluate_many(joint, profile_points(x, range(len(names)), settings["profile_step"]), "profile")
    x, loss, intervals, evidence = profile_intervals(evaluate, x, range(len(names)), names, settings["profile_step"],
                                                     settings["tolerance"], (low, high))
    direction = equally_good().direction
    if direction is not None:  # along the valley the equally good materials spread in
        ridge_walk(lambda points: evaluations.evaluate_many(joint, points, "ridge"), x, direction,
                   RIDGE_STEP * settings["profile_step"], (1.0 + settings["tolerance"]) * loss, (low, high))
        best = min(evaluations.records, key=lambda r: r["loss"])
        if best["loss"] < loss:
            log.info("the walk along the valley found a better material: loss %.5g px, %s", best["loss"],
                     describe(np.array(best["x"])))
            # its interval bounds come from the materials within the tolerance, this one among them
            x, loss = np.array(best["x"]), best["loss"]
            intervals = {n: dataclasses.replace(i, value=float(np.exp(v)))
                         for (n, i), v in zip(intervals.items(), x, strict=True)}
    details = dict(zip(setups, evaluator.map([(name, x) for name in setups]), strict=True))
bar.close()

spread = equally_good()
ranges = ", ".join(f"{n} {np.exp(lo):.3g}-{np.exp(hi):.3g}" for n, (lo, hi) in zip(names, spread.ranges, strict=True))
if spread.ridge:
    log.warning("the recordings leave the law on a ridge: %d evaluated materials within the tolerance span %s%s",
                spread.count, ranges, " (one setup only)" if len(setups) == 1 else "")
else:
    log.info("%d evaluated materials within the tolerance span %s", spread.count, ranges)
intervals = spread.widen(intervals, names)
band = shear_rate_band(list(details.values()))
params = {RESULT_KEYS[n]: {"value": i.value, "ci95": [i.low, i.high], "determined": i.determined}
          for n, i in intervals.items()}
if law.n is not None:
    params[RESULT_KEYS["n"]] = {"value": law.n, "ci95": [law.n, law.n], "determined": True, "fixed": True}
for n, i in intervals.items():
    log.info("%s = %.4g, 95%% interval [%.4g, %.4g]%s", n, i.value, i.low, i.high,
             "" if i.determined else " (not determined by the recordings)")
if band is not None:
    log.info("shear rates reached (5th-95th percentile of moving particles): %.3g-%.3g 1/s", *band)
else:
    log.warning("no particle moved faster than %g 1/s: no shear-rate band", MOVING_RATE)
write_json_atomic(output, {
    **params, "setups": {name: {"loss_px": d.loss, "held_out_loss_px": None if np.isnan(d.held_out_loss)
                                else d.held_out_loss, "first_frame_after_release_s": d.offset,
                                "boundary_distance_px": d.distances.tolist(), "silhouette_iou": d.iou.tolist(),
                                "outflow_iou": d.outflow_iou.tolist()} for name, d in details.items()},
    "within_tolerance": {"evaluations": spread.count, "ridge": spread.ridge, "laws": np.exp(spread.points).tolist(),
                         **{RESULT_KEYS[n]: np.exp(r).tolist() for n, r in zip(names, spread.ranges, strict=True)},
                         "spread_direction_log": None if spread.direction is None
                         else dict(zip(names, spread.direction.tolist(), strict=True))},
    "shear_rate_band_per_s": band, "loss_px": loss, "evidence": evidence, "tolerance": settings["tolerance"],
    "elastic_constants_Pa": {"mu": simulation["mu"], "lam": simulation["lam"]},
    "runtime_s": evaluations.earlier_seconds + time.time() - started})


def write_history(path: Path) -> None:
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["phase", "evaluation", "loss_px", *names])
        for i, record in enumerate(evaluations.records):
            writer.writerow([record["phase"], i, record["loss"], *np.exp(record["x"]).tolist()])


write_atomic(smk.output.history, write_history)
masks = {name: np.load(files[1])["masks"] for name, files in setups.items()}
save_figure(frames_figure({name: (masks[name], d.silhouettes, d.iou) for name, d in details.items()}),
            smk.output.frames)
evaluations.path.unlink(missing_ok=True)
