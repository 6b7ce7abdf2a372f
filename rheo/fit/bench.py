"""Benchmark of the ViRheometry fits: for each material, at its fitted law, the wall time of one joint evaluation
(its setups simulated side by side on the worker processes, as ``virheometry_fit`` does) and of each setup's
simulation alone, and what they make of a whole fit of the evaluations its history holds: between its simulations'
time shared evenly by the workers (the flow index's searches run side by side and keep every worker busy) and one
joint evaluation at a time. Beside it the measured wall time of the fit itself where Snakemake's benchmark file has
one (a fit that resumed from stored evaluations or shared its cores says so there).

    python -m rheo.fit.bench --out results/bench/virheometry.json

Needs the imported setups (results/virheometry/setups) and, for the law and the evaluation count, the fits
(results/virheometry/<material>/fit); run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import csv
import json
import platform
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.diagnose.candidates import Law
from rheo.experiments.rheometer import fitted_law
from rheo.experiments.virheometry import setup_folders
from rheo.fit.dam_break import comparisons, setup_files
from rheo.fit.parallel import Evaluator
from rheo.io import write_json_atomic
from rheo.physics.device import DEVICES, device_name, set_default_device


def timed(run: Callable[[list], object], tasks: list) -> float:
    """Wall seconds of ``run(tasks)``."""
    start = time.perf_counter()
    run(tasks)
    return time.perf_counter() - start


def projected_minutes(joint_s: float, alone_s: list[float], evaluations: int, workers: int) -> dict[str, float]:
    """A fit's wall time in minutes: with its simulations shared evenly by ``workers`` processes, and one joint
    evaluation at a time (the longest setup's simulation sets the pace, the other workers wait)."""
    side_by_side = evaluations * sum(alone_s) / workers
    return {"side_by_side": round(side_by_side / 60, 1), "one_at_a_time": round(joint_s * evaluations / 60, 1)}


def measure_material(material: str, results: Path, benchmarks: Path, simulation: dict, workers: int) -> dict:
    folders = setup_folders(results / "setups", material)
    setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
    fit = results / material / "fit"
    params = json.loads((fit / "params.json").read_text())
    x = np.log(fitted_law(params))
    with Evaluator(partial(comparisons, setups, simulation, Law()), workers=workers) as evaluator:
        evaluator.map([(name, x) for name in setups])  # compile, warm up
        joint = timed(evaluator.map, [(name, x) for name in setups])
        alone = {name: timed(evaluator.map, [(name, x)]) for name in setups}
    with open(fit / "history.csv") as f:
        evaluations = sum(1 for _ in csv.DictReader(f))
    record = {"setups": list(setups), "seconds_per_evaluation": round(joint, 1),
              "seconds_per_setup": {name: round(t, 1) for name, t in alone.items()}, "fit_evaluations": evaluations,
              "projected_fit_min": projected_minutes(joint, list(alone.values()), evaluations, workers)}
    measured = benchmarks / material / "fit.tsv"
    if measured.is_file():
        with open(measured) as f:
            row = list(csv.DictReader(f, delimiter="\t"))[-1]
        record.update(measured_fit_min=round(float(row["s"]) / 60, 1), measured_max_rss_mb=float(row["max_rss"]),
                      measured_mean_load=float(row["mean_load"]))
    return record


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--config", type=Path, default=WORKFLOW_CONFIG)
    parser.add_argument("--results", type=Path, default=Path("results/virheometry"))
    parser.add_argument("--benchmarks", type=Path, default=Path("benchmarks/virheometry"))
    parser.add_argument("--materials", nargs="*", help="default: every fitted material")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--device", choices=DEVICES, default="cpu", help="cuda: one simulation at a time on the GPU")
    args = parser.parse_args(argv)
    set_default_device(args.device)
    simulation = workflow_settings(args.config)["virheometry"]["simulation"]
    materials = args.materials or sorted(p.parent.parent.name for p in args.results.glob("*/fit/params.json"))
    if not materials:
        parser.error(f"{args.results}: no fitted material (<material>/fit/params.json)")
    report = {"materials": {}, "workers": args.workers, "machine": platform.processor() or platform.machine(),
              "device": device_name(args.device), "simulation": simulation}
    for material in materials:
        report["materials"][material] = measure_material(material, args.results, args.benchmarks, simulation,
                                                         args.workers)
        print(material, json.dumps(report["materials"][material]), flush=True)
    write_json_atomic(args.out, report)


if __name__ == "__main__":
    main()
