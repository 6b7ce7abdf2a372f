"""Lotion's two laws (the Bingham fit at the default settings and the rheometer's law), or another material's joint
fit at the default settings (``--material``, ``--fit``), compared with the recordings as if their frames lay another
interval apart than the 1/24 s the data's README gives (``--intervals``, in offset steps of 1/240 s: 8 for 1/30 s, 12
for 1/20 s): whether a frame rate other than the stated one turns which law comes closer. Each simulation's comparison
is written to ``--out`` under the engine's fingerprint, so a stopped run goes on and a finished one replays.

    PYTHONPATH=. python studies/frame_rate_20261129/run/rates.py --out studies/frame_rate_20261129/losses.json \
        --intervals 10 8 12 9 11 7 6
    PYTHONPATH=. python studies/frame_rate_20261129/run/rates.py --out studies/frame_rate_20261129/mustard.json \
        --intervals 10 8 --material Mustard \
        --fit studies/virheometry_20261127/results/virheometry/Mustard/fit/params.json
"""

import argparse
import json
import logging
from pathlib import Path

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.rheometer import fitted_law
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import OFFSET_STEP, target
from studies.lotion import add_material_arguments, lotion_laws, require_fit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--intervals", nargs="+", type=int, required=True, help="frame intervals in 1/240 s")
    add_material_arguments(parser)
    args = parser.parse_args()
    require_fit(parser, args)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    laws = {"fit": fitted_law(json.loads(args.fit.read_text()))} if args.fit else lotion_laws(config)
    records = StudyRecords(args.out)
    for steps in args.intervals:
        for folder in setup_folders(config["data"], args.material):
            setup = read_setup(folder, config["scale"], fps=1.0 / (steps * OFFSET_STEP))
            compared = target(setup, config["simulation"])
            for name, law in laws.items():
                label = f"{folder.name} {name} {steps}"
                if label not in records:
                    comparison = compared.compare(*law)
                    records[label] = {"law": list(law), "loss_px": comparison.loss, "offset_s": comparison.offset,
                                      "per_frame_px": comparison.distances.tolist()}
                    logging.info("%s: %.5f px", label, comparison.loss)
                    records.save()
                print(label, round(records[label]["loss_px"], 5), flush=True)


if __name__ == "__main__":
    main()
