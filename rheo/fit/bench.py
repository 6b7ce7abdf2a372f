"""Benchmark of the ViRheometry fits: the wall time of one joint evaluation of each material (its setups simulated
side by side on two worker processes, as ``virheometry_fit`` does), at the material's fitted law, and what that
makes of a whole fit (the evaluations its history holds); beside it the measured wall time of the fit itself where
Snakemake's benchmark file has one (a fit that resumed from stored evaluations or shared its cores says so there).

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
from functools import partial
from pathlib import Path

import numpy as np

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.diagnose.candidates import Law
from rheo.experiments.virheometry import setup_folders
from rheo.fit.dam_break import RESULT_KEYS, comparisons, setup_files
from rheo.fit.parallel import Evaluator
from rheo.io import write_json_atomic
from rheo.physics.simulator import DEVICES, device_name, set_default_device


def measure_material(material: str, results: Path, benchmarks: Path, simulation: dict, workers: int) -> dict:
    folders = setup_folders(results / "setups", material)
    setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
    fit = results / material / "fit"
    params = json.loads((fit / "params.json").read_text())
    x = np.log([params[key]["value"] for key in RESULT_KEYS.values()])
    with Evaluator(partial(comparisons, setups, simulation, Law()), workers=workers) as evaluator:
        evaluator.map([(name, x) for name in setups])  # compile, warm up
        start = time.perf_counter()
        evaluator.map([(name, x) for name in setups])
        seconds = time.perf_counter() - start
    with open(fit / "history.csv") as f:
        evaluations = sum(1 for _ in csv.DictReader(f))
    record = {"setups": list(setups), "seconds_per_evaluation": round(seconds, 1), "fit_evaluations": evaluations,
              "projected_fit_min": round(seconds * evaluations / 60, 1)}
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
