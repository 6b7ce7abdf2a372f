"""How the grid and the time step move a dam break: Herschel-Bulkley laws simulated against a material's recordings
on grids of several resolutions and at several time steps, and per setup the loss (px), the material past the gate
in the last frame (px, the recording's beside it) and the seconds the simulation took. A law that describes the
material should come closer to the recording as the grid is refined; where the loss still changes with the grid or
the step, so will the law a fit recovers.

    python -m rheo.fit.grid_study --material Lotion --grids 8x10 12x14 16x18 --cfl 0.4 0.8 \\
        --out results/bench/Lotion_grids.json

A grid ``CxA`` has at least C cells over the material's height and A across the channel
(``virheometry.simulation.cells_per_height``, ``cells_across``); ``--cfl`` the time steps
(``virheometry.simulation.cfl``, the configured one by default). The laws: each ``--law tau_y,K,n``; for a
material with rheometer curves (``virheometry.rheometer``), the Herschel-Bulkley law fitted to all of them (over the
shear-rate band of the material's fit where there is one); the fit's own estimate where
results/virheometry/<material>/fit/params.json exists.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from rheo.experiments.rheometer import fit_herschel_bulkley, pooled, read_flow_curve
from rheo.experiments.virheometry import Setup, read_setup, setup_folders
from rheo.fit.bench import ROOT, settings
from rheo.fit.dam_break import RESULT_KEYS, target
from rheo.io import write_json_atomic

Law = tuple[float, float, float]  # tau_y (Pa), K (Pa s^n), n


def outflow(silhouette: np.ndarray, container: np.ndarray) -> int:
    """Pixels of a silhouette outside the container: the material past the gate."""
    return int((silhouette & ~container).sum())


def study(setups: list[Setup], simulation: dict, laws: dict[str, Law], grids: list[tuple[int, int]],
          cfls: list[float]) -> list[dict]:
    """One row per grid, time step, setup and law: the loss (px), the last frame's outflow (px), simulated and
    recorded, and the seconds the comparison took."""
    rows = []
    with tqdm(total=len(grids) * len(cfls) * len(setups) * len(laws), desc="grid study", unit="simulation") as bar:
        for (cells, across), cfl in itertools.product(grids, cfls):
            for setup in setups:
                compared = target(setup, {**simulation, "cells_per_height": cells, "cells_across": across,
                                          "cfl": cfl})
                recorded = outflow(compared.masks[-1], compared.container)
                for label, law in laws.items():
                    start = time.perf_counter()
                    result = compared.compare(*law)
                    rows.append({"grid": f"{cells}x{across}", "cfl": cfl, "resolution": compared.scene.resolution,
                                 "particles": len(compared.scene.initial_positions), "setup": setup.folder.name,
                                 "law": label, "tau_y_Pa": law[0], "K_Pa_s_n": law[1], "n": law[2],
                                 "loss_px": result.loss,
                                 "last_outflow_px": outflow(result.silhouettes[-1], compared.container),
                                 "recorded_last_outflow_px": recorded,
                                 "seconds": round(time.perf_counter() - start, 1)})
                    bar.update()
    return rows


def rheometer_law(files: list[str], band: tuple[float, float] | None) -> Law:
    """The Herschel-Bulkley law fitted to all the rheometer's points (within ``band``, 1/s, if given)."""
    curve = pooled([read_flow_curve(f) for f in files])
    return fit_herschel_bulkley(curve.within(band) if band is not None else curve)


def grid(text: str) -> tuple[int, int]:
    try:
        cells, across = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"grid {text!r}: expected CxA, e.g. 12x14") from err
    return cells, across


def law(text: str) -> Law:
    try:
        tau_y, K, n = (float(v) for v in text.split(","))
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"law {text!r}: expected tau_y,K,n, e.g. 4.5,7,0.47") from err
    return tau_y, K, n


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--material", required=True)
    parser.add_argument("--grids", type=grid, nargs="+", required=True, help="CxA: cells per height x across")
    parser.add_argument("--cfl", type=float, nargs="+", help="time steps, as fractions of a cell's crossing time")
    parser.add_argument("--law", type=law, action="append", default=[], help="tau_y,K,n (repeatable)")
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--config", type=Path, default=ROOT / "config/config.yaml")
    parser.add_argument("--results", type=Path, default=Path("results/virheometry"))
    args = parser.parse_args(argv)
    config = settings(args.config)["virheometry"]
    laws = {f"given {i + 1}": given for i, given in enumerate(args.law)}
    fitted = args.results / args.material / "fit" / "params.json"
    band = None
    if fitted.is_file():
        params = json.loads(fitted.read_text())
        laws["fit"] = tuple(params[key]["value"] for key in RESULT_KEYS.values())
        band = params.get("shear_rate_band_per_s")
    if args.material in config["rheometer"]:
        laws["rheometer"] = rheometer_law(config["rheometer"][args.material], band)
    if not laws:
        parser.error(f"{args.material}: no law to simulate (give --law; no rheometer curves, no {fitted})")
    setups = [read_setup(folder, config["scale"]) for folder in setup_folders(config["data"], args.material)]
    rows = study(setups, config["simulation"], laws, args.grids, args.cfl or [config["simulation"]["cfl"]])
    for row in rows:
        print(json.dumps(row), flush=True)
    write_json_atomic(args.out, {"material": args.material, "laws": laws, "rheometer_band_per_s": band,
                                 "simulation": config["simulation"], "rows": rows})


if __name__ == "__main__":
    main()
