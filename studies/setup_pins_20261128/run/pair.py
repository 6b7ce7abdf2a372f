"""Whether two heights together bound n: Lotion's 7 cm channel filled to two heights, each recording simulated from
the n 1 law as in ``design.py``; then each of the other two laws (n 0.55, n 1.4) scaled to fit both recordings at
once (the mean of their losses), and what that costs it over fitting each alone. The recordings share the fit's
simulator, so the n 1 law fits them exactly: a cost well above the real recordings' tolerance says the pair would
tell these flow indices apart, given a model error that does not itself favour one. Losses go to ``--out`` under
the engine's fingerprint, labelled as ``design.py``'s (the two share a store).

    PYTHONPATH=. python studies/setup_pins_20261128/run/pair.py --out studies/setup_pins_20261128/design.json \
        --heights 0.02 0.035
"""

import argparse
import logging
from pathlib import Path

import numpy as np
from design import CHANNEL, TRUTH, filled_recording
from pins import LOG_SCALE, SCALE_TOLERANCE, SHAPES, best_scale, scaled_loss
from scipy.optimize import minimize_scalar

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.virheometry import read_setup
from rheo.fit.convergence import StudyRecords


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--heights", type=float, nargs=2, required=True, help="the two material heights (m)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    records = StudyRecords(args.out)
    channel = read_setup(Path(config["data"]) / CHANNEL, config["scale"])
    compared = {f"{h:g} m": filled_recording(channel, h, config["simulation"])[0] for h in args.heights}
    for name in (n for n in SHAPES if n != TRUTH):
        alone = {label: best_scale(target, f"{label} {name}", SHAPES[name], records)[1]["loss_px"]
                 for label, target in compared.items()}

        def pair_loss(log_scale: float, name: str = name) -> float:
            return float(np.mean([scaled_loss(target, f"{label} {name}", SHAPES[name], log_scale, records)
                                  for label, target in compared.items()]))

        found = minimize_scalar(pair_loss, bounds=(-LOG_SCALE, LOG_SCALE), method="bounded",
                                options={"xatol": SCALE_TOLERANCE})
        print(f"{name}: alone {', '.join(f'{label} {loss:.5f}' for label, loss in alone.items())} px; together, "
              f"scale {np.exp(found.x):.3f}, {found.fun:.5f} px, {found.fun - np.mean(list(alone.values())):.5f} px "
              "more than alone")


if __name__ == "__main__":
    main()
