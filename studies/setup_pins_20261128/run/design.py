"""Which shear rate a dam break of another height reads: Lotion's 7 cm channel filled to other heights, its
recording made by simulating Lotion's joint fit (n 1) at the default settings, its first frame 0.05 s after the
release; then, as ``pins.py`` does on the real recordings, the laws of n 0.55 and 1.4 each scaled to fit it best,
and where their flow curves and the n 1 law's agree best. The recording shares the fit's simulator: this measures
where a geometry pins the stress, not how well a fit would recover a law. Each simulation's loss and shear-rate band
are written to ``--out`` under the engine's fingerprint (the recordings are simulated again on each run).

    PYTHONPATH=. python studies/setup_pins_20261128/run/design.py --out studies/setup_pins_20261128/design.json \
        --heights 0.07 0.035 0.02
"""

import argparse
import dataclasses
import logging
from pathlib import Path

from pins import SHAPES, read_rate

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.virheometry import Setup, read_setup
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import Comparison, DamBreakTarget, shear_rate_band, target

CHANNEL = "ref_Lotion_7.0_7.0_2"
TRUTH = "n 1"  # the shape the recording is made with, at its own scale
FIRST_FRAME_S = 0.05


def filled_recording(channel: Setup, height: float, simulation: dict) -> tuple[DamBreakTarget, Comparison]:
    """``channel`` filled to ``height`` (m) with its recording simulated from the truth's law, as a target, and that
    simulation."""
    filled = dataclasses.replace(channel, height=height)
    truth = target(filled, simulation | {"min_offset": FIRST_FRAME_S, "max_offset": FIRST_FRAME_S})
    recording = truth.compare(*SHAPES[TRUTH])
    return target(dataclasses.replace(filled, masks=list(recording.silhouettes)), simulation), recording


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--heights", type=float, nargs="+", required=True, help="material heights (m)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    simulation = config["simulation"]
    records = StudyRecords(args.out)
    channel = read_setup(Path(config["data"]) / CHANNEL, config["scale"])
    for height in args.heights:
        compared, recording = filled_recording(channel, height, simulation)
        read_rate(compared, f"{height:g} m", records, {name: law for name, law in SHAPES.items() if name != TRUTH},
                  [(list(SHAPES[TRUTH]), shear_rate_band([recording]))])

if __name__ == "__main__":
    main()
