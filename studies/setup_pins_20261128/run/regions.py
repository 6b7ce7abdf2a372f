"""Where in the image each setup's shape prefers one flow index: the laws of ``pins.py`` (n 0.55, 1.4), each at the
scale that fits the setup best (replayed from ``pins.py``'s store), simulated once more and their mismatch located
by the diagnosis' regions (``rheo.diagnose.residuals.locate``), pixels of extra and missing material summed over the
frames.

    PYTHONPATH=. python studies/setup_pins_20261128/run/regions.py --store studies/setup_pins_20261128/mustard.json \
        --material Mustard --fit studies/virheometry_20261127/results/virheometry/Mustard/fit/params.json
"""

import argparse
from pathlib import Path

from pins import SHAPES, best_scale, profile_shapes

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.diagnose.residuals import REGIONS, locate
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--store", type=Path, required=True, help="pins.py's store for the material")
    parser.add_argument("--material", default="Lotion")
    parser.add_argument("--fit", type=Path, help="the material's joint fit (params.json); Lotion's laws by default")
    args = parser.parse_args()
    if args.material != "Lotion" and args.fit is None:
        parser.error(f"--fit is needed for {args.material}: the laws shipped are Lotion's")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    records = StudyRecords(args.store)
    shapes = profile_shapes(args.fit) if args.fit else SHAPES
    print("setup, law: loss (px); extra / missing px per region:", ", ".join(REGIONS))
    for folder in setup_folders(config["data"], args.material):
        compared = target(read_setup(folder, config["scale"]), config["simulation"])
        for name in ("n 0.55", "n 1.4"):
            tau_y, K, n = shapes[name]
            scale, _ = best_scale(compared, f"{folder.name} {name}", shapes[name], records)
            comparison = compared.compare(scale * tau_y, scale * K, n)
            where = locate(compared.setup, list(comparison.silhouettes), list(compared.masks),
                           [str(f + 1) for f in range(len(compared.masks))])
            regions = "; ".join(f"{e:.0f} / {m:.0f}" for e, m in zip(where.extra.sum(axis=0),
                                                                     where.missing.sum(axis=0), strict=True))
            print(f"{folder.name} {name} (scale {scale:.3f}): {comparison.loss:.5f} px; {regions}", flush=True)


if __name__ == "__main__":
    main()
