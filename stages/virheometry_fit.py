"""virheometry_fit: tau_y, K and n (or tau_y and K at a fixed flow index) of one material from its dam breaks (all
its setups jointly, or one), with the first frame's time after the release found for each setup. First a line search
of the stress at a shear rate typical of the flow. With the flow index free, searches of tau_y and K at a row of
flow indices from that stress (each keeping it at first), whose best losses are the flow index's profile; with the
flow index fixed, a survey of the yield stress' share of that stress (and of the shear modulus, where fitted), then
searches from the survey's best points side by side. Then rounds of a composite design around the best, each
followed by a quadratic fitted to the squared losses (rheo.fit.surface): its lowest point, or the best law evaluated
where that loses less, is the estimate, and the region where it stays within the tolerance gives the intervals, n's
grown to where its profile stays within it.
Each evaluation simulates the setups side by side, the survey's and the designs' points two at a time.
Every evaluation is stored, so an interrupted fit resumes."""

import csv
from functools import partial
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from rheo.diagnose.candidates import Law
from rheo.experiments.rheometer import PARAMETER_KEYS, RESULT_KEYS
from rheo.fit.dam_break import (
    MOVING_RATE,
    clipped_law,
    comparisons,
    flow_index_profile,
    setup_files,
    shear_rate_band,
    stress_level,
    valley_points,
    valley_searches,
)
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, estimate
from rheo.fit.uncertainty import grown_to_profile, tolerance_level
from rheo.io import evaluations_path, json_number, write_atomic, write_json_atomic
from rheo.report.figures import save_figure
from rheo.report.virheometry import frames_figure
from rheo.stage import inputs_key, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
settings, simulation = smk.params.settings, smk.params.simulation
setups = setup_files(smk.input.setups, smk.input.masks)
law = Law(n=settings.get("flow_index"), fitted_modulus=settings.get("mu") is not None)
names = law.names
low = np.log([settings[n][0] for n in names])
high = np.log([settings[n][1] for n in names])
output = Path(smk.output.params)
evaluations = EvaluationLog(evaluations_path(output),
                            inputs_key([settings, simulation], [*smk.input.setups, *smk.input.masks]),
                            one_objective=True)
bar = tqdm(desc=f"{output.parent.parent.name} {output.parent.name}", unit="evaluation")


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

    evaluate_many = partial(evaluations.evaluate_many, joint)  # points, phase -> losses, stored
    rate = settings["stress_rate"]
    # the shear modulus, where fitted (the last coordinate), starts at the simulation's, within its box
    rest = np.clip(np.log([simulation["mu"]]), low[-1:], high[-1:]) if law.fitted_modulus else []
    log_stress = stress_level(evaluate_many, rate, (low, high), settings["stress_evaluations"],
                              1.0 if law.n is None else law.n, rest, free_n=law.n is None)
    if law.n is None:
        found = flow_index_profile(evaluate_many, log_stress, settings["flow_index_searches"], rate,
                                   settings["flow_index_evaluations"], (low, high), rest)
    else:
        rests = np.log(settings["moduli"])[:, None] if law.fitted_modulus else [[]]
        points = valley_points(log_stress, settings["shares"], rests)
        # in chunks that keep every worker busy, each stored as it ends
        chunk = max(smk.threads, 1)
        losses = np.concatenate([evaluate_many([clipped_law(z, law.n, rate, (low, high), free_n=False)
                                                for z in points[i:i + chunk]], "survey")
                                 for i in range(0, len(points), chunk)])
        ranked = [points[i] for i in np.argsort(losses, kind="stable")[:settings["starts"]]]
        found = valley_searches(evaluate_many, ranked, law.n, rate, settings["evaluations"], (low, high))
    best_law = min(found, key=lambda f: f[1])[0]  # the surface is centred on the searches' best law

    def simulate(x: np.ndarray) -> dict:
        """Each setup's comparison at ``x``, with its frames, IoU and shear rates."""
        return dict(zip(setups, evaluator.map([(name, x) for name in setups]), strict=True))

    simulated: dict[tuple, dict] = {}

    def evaluate_estimate(x: np.ndarray) -> float:
        """The estimate's loss, from a simulation whose details (frames, IoU, shear rates) the results keep."""
        simulated[tuple(x)] = simulate(x)
        return evaluations.evaluate_many(lambda _: [float(np.mean([d.loss for d in simulated[tuple(x)].values()]))],
                                         [x], "estimate")[0]

    result = estimate(evaluate_many, [best_law], names, seen=evaluations.seen,
                      evaluations=0, start_step=0.0, half_width=settings["half_width"],
                      rounds=settings["rounds"], tolerance=settings["tolerance"], box=(low, high), side_by_side=True,
                      evaluate_estimate=evaluate_estimate)
    x, loss, intervals = result.log_values, result.loss, result.intervals
    profile_record = None
    if law.n is None:
        by_index = sorted(found, key=lambda f: f[0][2])
        for law_x, value in by_index:
            log.info("flow-index profile: loss %.5g px at %s", value, describe(law_x))
        profile_record = {key: [float(np.exp(law_x[i])) for law_x, _ in by_index]
                          for i, key in enumerate(RESULT_KEYS.values())} | {"loss_px": [v for _, v in by_index]}
        intervals["n"] = grown_to_profile(intervals["n"], profile_record["n"], profile_record["loss_px"],
                                          tolerance_level(loss, settings["tolerance"]))
    log.info("estimate: loss %.5g px, %s", loss, describe(x))
    details = simulated.get(tuple(x)) or simulate(x)
bar.close()

spread = result.within_tolerance
ranges = ", ".join(f"{n} {np.exp(lo):.3g}-{np.exp(hi):.3g}" for n, (lo, hi) in zip(names, spread.ranges, strict=True))
if spread.ridge:
    log.warning("the recordings leave the law on a ridge: %d evaluated materials within the tolerance span %s%s",
                spread.count, ranges, " (one setup only)" if len(setups) == 1 else "")
else:
    log.info("%d evaluated materials within the tolerance span %s", spread.count, ranges)
band = shear_rate_band(list(details.values()))
params = {PARAMETER_KEYS[n]: {"value": i.value, "interval": [i.low, i.high], "determined": i.determined,
                              "interval_open": list(i.open)} for n, i in intervals.items()}
if law.n is not None:
    params[RESULT_KEYS["n"]] = {"value": law.n, "interval": [law.n, law.n], "determined": True, "fixed": True}
for n, i in intervals.items():
    log.info("%s = %.4g, tolerance interval [%.4g, %.4g]%s", n, i.value, i.low, i.high,
             "" if i.determined else " (not determined by the recordings)")
if band is not None:
    log.info("shear rates reached (5th-95th percentile of moving particles): %.3g-%.3g 1/s", *band)
else:
    log.warning("no particle moved faster than %g 1/s: no shear-rate band", MOVING_RATE)
write_json_atomic(output, {
    **params, "setups": {name: {"loss_px": d.loss, "held_out_loss_px": json_number(d.held_out_loss),
                                "forecast_loss_px": json_number(d.forecast_loss),
                                "first_frame_after_release_s": d.offset,
                                "boundary_distance_px": d.distances.tolist(), "silhouette_iou": d.iou.tolist(),
                                "outflow_iou": d.outflow_iou.tolist()} for name, d in details.items()},
    "within_tolerance": {"evaluations": spread.count, "ridge": spread.ridge, "laws": np.exp(spread.points).tolist(),
                         **{PARAMETER_KEYS[n]: np.exp(r).tolist() for n, r in zip(names, spread.ranges, strict=True)},
                         "spread_direction_log": None if spread.direction is None
                         else dict(zip(names, spread.direction.tolist(), strict=True))},
    "flow_index_profile": profile_record,
    "shear_rate_band_per_s": band, "loss_px": loss, "evidence": result.evidence["all_free"],
    "tolerance": settings["tolerance"],
    "elastic_constants_Pa": {"mu": intervals["mu"].value if "mu" in intervals else simulation["mu"],
                             "lam": simulation["lam"]},
    **evaluations.times()})


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
