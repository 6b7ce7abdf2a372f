"""Whether Lotion's early and late frames read different shear rates: the three laws of its joint fit's flow-index
profile (n 0.55, 1 and 1.4; ../../setup_pins_20261128/run/pins.py) simulated on each setup at a grid of scales
(stress times a), each frame's boundary distance and moving particles' shear rates (5th, 50th, 95th percentile)
stored. For a window of frames, each law's best scale is the vertex of the parabola through its three lowest
window losses; where the best-scaled flow curves agree best over the window's shear rates is the rate the window
pins. Records go to ``--out`` under the engine's fingerprint, so a stopped run goes on and a finished one replays.

    PYTHONPATH=. python studies/frame_windows_20261129/run/windows.py --out studies/frame_windows_20261129/frames.json \
        [--gate-lift-time 0.1]
"""

import argparse
import json
import logging
import math
from pathlib import Path

import numpy as np

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.effects import Effects
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import MOVING_RATE, OFFSET_STEP, DamBreakTarget, shear_rates, target
from rheo.fit.uncertainty import best_determined_stress
from studies.lotion import SHAPES

LOG_SCALES = np.round(np.arange(-0.12, 0.241, 0.04), 2)  # the scales simulated: exp(-0.12) to exp(0.24)


def simulate(compared: DamBreakTarget, law: tuple[float, float, float], log_scale: float, effects: Effects) -> dict:
    """One scaled law on one setup with ``effects``: per frame the boundary distance (px) and the moving particles'
    shear rates' 5th, 50th and 95th percentiles (1/s), at the offset that fits the setup's frames best."""
    scale = math.exp(log_scale)
    trajectory = compared.simulate(scale * law[0], scale * law[1], law[2], effects)
    comparison = compared.score(trajectory)
    first = round(comparison.offset / OFFSET_STEP)
    rates = shear_rates(trajectory.C.numpy()[first + compared.frame_steps * np.arange(len(compared.masks))])
    percentiles = [np.percentile(r[r > MOVING_RATE], [5, 50, 95]).tolist() if (r > MOVING_RATE).any() else None
                   for r in rates]
    return {"distances_px": comparison.distances.tolist(), "rates_per_s": percentiles, "offset_s": comparison.offset}


def best_log_scale(records: dict[float, dict], frames: slice) -> float:
    """The vertex of the parabola through the three lowest mean distances over ``frames``, within the grid (at
    its end where the lowest lies there)."""
    grid = np.array(sorted(records))
    losses = np.array([np.mean(records[s]["distances_px"][frames]) for s in grid])
    low = int(np.clip(np.argmin(losses), 1, len(grid) - 2))
    a, b, _ = np.polyfit(grid[low - 1:low + 2], losses[low - 1:low + 2], 2)
    return float(np.clip(-b / (2 * a), grid[0], grid[-1])) if a > 0 else float(grid[np.argmin(losses)])


def window_pin(by_shape: dict[str, dict[float, dict]], frames: slice) -> dict:
    """The laws' best scales over ``frames`` and the rate (1/s) and stresses (Pa) where they then agree best, from
    the lowest 5th to the highest 95th percentile shear rate of those frames in any simulation."""
    laws, scales, at_end, band = [], {}, [], [math.inf, 0.0]
    for name, records in by_shape.items():
        log_scale = best_log_scale(records, frames)
        scales[name] = round(math.exp(log_scale), 4)
        if log_scale in (min(records), max(records)):
            at_end.append(name)
        laws.append([math.exp(log_scale) * SHAPES[name][0], math.exp(log_scale) * SHAPES[name][1], SHAPES[name][2]])
        for record in records.values():
            for p in record["rates_per_s"][frames]:
                if p is not None:
                    band = [min(band[0], p[0]), max(band[1], p[2])]
    window = {"scales": scales, "scales_at_grid_end": at_end, "band_per_s": [round(b, 3) for b in band]}
    pinned = best_determined_stress(np.array(laws), band)
    if pinned is not None:
        window |= {"rate_per_s": round(pinned.rate, 3), "stress_pa": [round(pinned.low, 3), round(pinned.high, 3)]}
    return window


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--gate-lift-time", type=float, default=0.0,
                        help="s: a gate slides up and clears the material in this time (default: released at once)")
    parser.add_argument("--setups", nargs="+", help="setup folder names (default: both of Lotion's)")
    parser.add_argument("--shapes", nargs="+", choices=SHAPES, default=list(SHAPES),
                        help="the laws (default: all three; the pinned rate needs all three)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    records = StudyRecords(args.out)
    pins = {}
    effects = Effects(gate_lift_time=args.gate_lift_time)
    gate = f" gate {args.gate_lift_time:g} s" if args.gate_lift_time else ""
    for folder in (f for f in setup_folders(config["data"], "Lotion") if not args.setups or f.name in args.setups):
        compared = target(read_setup(folder, config["scale"]), config["simulation"])
        by_shape = {}
        for name in args.shapes:
            by_shape[name] = {}
            for log_scale in LOG_SCALES:
                label = f"{folder.name} {name} {log_scale:+.2f}{gate}"
                if label not in records:
                    records[label] = simulate(compared, SHAPES[name], float(log_scale), effects)
                    records.save()
                    logging.info("%s: %.5f px", label, np.mean(records[label]["distances_px"]))
                by_shape[name][float(log_scale)] = records[label]
        half = len(compared.masks) // 2
        pins[folder.name] = {window: window_pin(by_shape, frames) for window, frames in
                             {"all": slice(None), "early": slice(0, half), "late": slice(half, None)}.items()}
    print(json.dumps(pins, indent=1))


if __name__ == "__main__":
    main()
