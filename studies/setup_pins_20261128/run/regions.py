"""Where in the image each setup's shape prefers one flow index: the laws of ``pins.py`` (n 0.55, 1.4), each at the
scale that fits the setup best (replayed from ``pins.py``'s store), simulated once more and their mismatch located
by the diagnosis' regions (``rheo.diagnose.residuals.locate``), pixels of extra and missing material summed over the
frames.

    PYTHONPATH=. python studies/setup_pins_20261128/run/regions.py --store studies/setup_pins_20261128/mustard.json \
        --material Mustard --fit studies/virheometry_20261127/results/virheometry/Mustard/fit/params.json
"""

import argparse
from pathlib import Path

from pins import best_scale, material_shapes, setup_targets

from rheo.diagnose.residuals import REGIONS, locate
from rheo.fit.convergence import StudyRecords
from studies.lotion import add_material_arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--store", type=Path, required=True, help="pins.py's store for the material")
    add_material_arguments(parser)
    args = parser.parse_args()
    shapes = material_shapes(parser, args)
    records = StudyRecords(args.store)
    print("setup, law: loss (px); extra / missing px per region:", ", ".join(REGIONS))
    for setup, compared in setup_targets(args.material):
        for name in ("n 0.55", "n 1.4"):
            tau_y, K, n = shapes[name]
            scale, _ = best_scale(compared, f"{setup} {name}", shapes[name], records)
            comparison = compared.compare(scale * tau_y, scale * K, n)
            where = locate(compared.setup, list(comparison.silhouettes), list(compared.masks))
            regions = "; ".join(f"{e:.0f} / {m:.0f}" for e, m in zip(where.extra.sum(axis=0),
                                                                     where.missing.sum(axis=0), strict=True))
            print(f"{setup} {name} (scale {scale:.3f}): {comparison.loss:.5f} px; {regions}", flush=True)


if __name__ == "__main__":
    main()
