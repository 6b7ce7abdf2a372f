"""Lotion's two laws (the Bingham fit at the default settings and the rheometer's law) simulated once per setup at
the default settings and compared with the recording at several image scales (times the camera's window, whose
PNGs are at twice it): whether the silhouettes' resolution changes which law comes closer. Each simulation's
losses are written to ``--out`` as it finishes, so a stopped run goes on.

    PYTHONPATH=. python studies/image_scale_20261128/run/scales.py --out studies/image_scale_20261128/losses.json
"""

import argparse
import logging
from pathlib import Path

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import target
from studies.lotion import lotion_laws

SCALES = (0.5, 1.0, 2.0)  # 0.5: the fit's default; 2.0: the PNGs' own 1920 x 1080


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    simulation = config["simulation"]
    laws = lotion_laws(config)
    records = StudyRecords(args.out)
    for folder in setup_folders(config["data"], "Lotion"):
        compared = {scale: target(read_setup(folder, scale), simulation) for scale in SCALES}
        for name, law in laws.items():
            label = f"{folder.name} {name}"
            if label in records:
                continue
            trajectory = compared[SCALES[0]].simulate(*law)
            records[label] = {"law": list(law), "loss_px": {}, "offset_s": {}, "iou": {}}
            for scale, at_scale in compared.items():
                comparison = at_scale.score(trajectory)
                records[label]["loss_px"][str(scale)] = comparison.loss
                records[label]["offset_s"][str(scale)] = comparison.offset
                records[label]["iou"][str(scale)] = comparison.iou.tolist()
                logging.info("%s at scale %s: %.5f px", label, scale, comparison.loss)
            records.save()
    for label, record in records.items():
        print(label, {s: round(v, 5) for s, v in record["loss_px"].items()})


if __name__ == "__main__":
    main()
