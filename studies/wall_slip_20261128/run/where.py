"""Lotion's two laws (the Bingham fit at the default settings and the rheometer's law) simulated at the default
settings with Navier slip (traction beta times the slip velocity) on the floor alone, on the standing walls alone
(back and side walls) or on both, the rest sticky, and compared with the recordings: whether slip on one kind of
surface turns which law comes closer. Each simulation's comparison is written to ``--out`` as it finishes, under
the engine's fingerprint, so a stopped run goes on and a finished one replays.

    PYTHONPATH=. python studies/wall_slip_20261128/run/where.py --out studies/wall_slip_20261128/losses.json \
        --cases floor:3000 walls:3000 ...
"""

import argparse
import dataclasses
import logging
from pathlib import Path

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.dam_break import DamBreakScene
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import target
from studies.lotion import lotion_laws

SURFACES = ("floor", "walls", "all")


def slipping(surface: str, beta: float):
    """``DamBreakScene.colliders`` with a Navier law of ``beta`` on ``surface`` (the first collider is the floor,
    the others the standing walls), the rest as the setup gives them."""
    colliders = DamBreakScene.colliders

    def patched(scene: DamBreakScene, effects=None) -> list:
        return [dataclasses.replace(c, contact="navier", friction=beta)
                if surface == "all" or (i == 0) == (surface == "floor") else c
                for i, c in enumerate(colliders(scene, effects))]
    return patched


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--cases", nargs="+", required=True, help="SURFACE:BETA, SURFACE one of " + ", ".join(SURFACES))
    parser.add_argument("--setups", nargs="+", help="setup folder names (default: both of Lotion's)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    simulation = config["simulation"]
    laws = lotion_laws(config)
    records = StudyRecords(args.out)
    folders = [f for f in setup_folders(config["data"], "Lotion") if not args.setups or f.name in args.setups]
    original = DamBreakScene.colliders
    for case in args.cases:
        surface, beta = case.split(":")
        if surface not in SURFACES:
            parser.error(f"--cases {case}: the surface must be one of {', '.join(SURFACES)}")
        DamBreakScene.colliders = slipping(surface, float(beta))
        try:
            for folder in folders:
                compared = target(read_setup(folder, config["scale"]), simulation)
                for name, law in laws.items():
                    label = f"{folder.name} {name} {surface}:{float(beta):g}"
                    if label in records:
                        continue
                    comparison = compared.compare(*law)
                    records[label] = {"law": list(law), "loss_px": comparison.loss, "offset_s": comparison.offset,
                                      "per_frame_px": comparison.distances.tolist()}
                    logging.info("%s: %.5f px", label, comparison.loss)
                    records.save()
        finally:
            DamBreakScene.colliders = original
    for label, record in records.items():
        print(label, round(record["loss_px"], 5))


if __name__ == "__main__":
    main()
