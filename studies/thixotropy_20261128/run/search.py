"""Lotion's rheometer law (K and n from its four curves) with a yield stress that breaks down while the material
yields, tau_y(t) = tau_r + (tau_y0 - tau_r) exp(-lam t_yielding), tau_r the rheometer's yield stress: tau_y0 and lam
searched (Nelder-Mead in log units) against both dam-break setups at the default settings, beside the Bingham fit's
law and the rheometer's law as they are. Every evaluation is stored in ``--store`` under the engine's fingerprint and
the settings, so a stopped search goes on and a changed engine evaluates anew.

    PYTHONPATH=. python studies/thixotropy_20261128/run/search.py --store studies/thixotropy_20261128/evaluations.json

On finer cells (cells over each setup's height and across its channel, as the convergence study gives them), on a GPU:

    PYTHONPATH=. python studies/thixotropy_20261128/run/search.py --cells 24 3 --device cuda --store fine.json

At a stiffer shear modulus, beside the Bingham law of Lotion's fit at that modulus (its flow-index profile at n 1):

    PYTHONPATH=. python studies/thixotropy_20261128/run/search.py --mu 3000 --bingham 13.24 0.939 --evaluations 40 \
        --store studies/thixotropy_20261128/mu_3000.json

The search's best point alone on the next finer cells (1.54 and 2.0 mm):

    PYTHONPATH=. python studies/thixotropy_20261128/run/search.py --mu 3000 --bingham 13.24 0.939 --cells 16 20 \
        --at 41.09 31.29 --store studies/thixotropy_20261128/mu_3000_finer.json
"""

import argparse
import json
import logging
from functools import cache, partial
from pathlib import Path

import numpy as np

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.effects import Effects
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import engine_fingerprint, material_rheometer_law
from rheo.fit.dam_break import DamBreakTarget, target
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, simplex_search
from rheo.physics.device import DEVICES, set_default_device
from rheo.physics.optional import OptionalPhysics
from studies.lotion import BINGHAM

START = np.log([15.0, 10.0])  # tau_y0 (Pa), lam (1/s): the best of the grid at the former interval
BOX = (np.log([5.0, 0.5]), np.log([80.0, 300.0]))


@cache
def _target(folder: str, scale: float, simulation: str) -> DamBreakTarget:
    return target(read_setup(folder, scale), json.loads(simulation))


def _losses(folder: str, scale: float, simulation: str, task: np.ndarray) -> float:
    """The loss on one setup of the law tau_y, K, n whose yield stress breaks down at lam (none at 0) to floor."""
    tau_y, K, n, lam, floor = task
    physics = OptionalPhysics(thixotropy=lam, thixotropy_floor=floor, thixotropy_exponent=0.0)
    return _target(folder, scale, simulation).compare(tau_y, K, n, Effects(physics=physics)).loss


def _objectives(folders: list[str], scale: float, simulation: str) -> dict:
    return {folder: partial(_losses, folder, scale, simulation) for folder in folders}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--store", type=Path, required=True)
    parser.add_argument("--evaluations", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cells", type=int, nargs=2, metavar=("HEIGHT", "ACROSS"),
                        help="cells over the height and across the channel (default: the fit's grid)")
    parser.add_argument("--device", choices=DEVICES, default="cpu")
    parser.add_argument("--at", type=float, nargs=2, metavar=("TAU_Y0", "LAM"),
                        help="evaluate this point (Pa, 1/s) instead of searching")
    parser.add_argument("--mu", type=float, help="the shear modulus, Pa (default: the fit's)")
    parser.add_argument("--bingham", type=float, nargs=2, metavar=("TAU_Y", "K"), default=BINGHAM[:2],
                        help="the Bingham law to compare with, Pa and Pa s (default: the default fit's)")
    args = parser.parse_args()
    set_default_device(args.device)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    simulation, scale = config["simulation"], config["scale"]
    if args.cells:
        simulation = {**simulation, "cells_per_height": args.cells[0], "cells_across": args.cells[1]}
    if args.mu is not None:
        simulation = {**simulation, "mu": args.mu}
    rheometer = material_rheometer_law(config, "Lotion")
    folders = setup_folders(config["data"], "Lotion")
    log = EvaluationLog(args.store, json.dumps({"engine": engine_fingerprint(), "simulation": simulation,
                                                "rheometer": list(rheometer)}))
    paths = [str(f) for f in folders]
    with Evaluator(partial(_objectives, paths, scale, json.dumps(simulation)), args.workers) as evaluator:

        def losses(law: tuple, lam: float = 0.0, floor: float = 0.0) -> dict:
            per_setup = evaluator.map([(path, np.array([*law, lam, floor])) for path in paths])
            return {"loss": float(np.mean(per_setup)),
                    "setups": {f.name: loss for f, loss in zip(folders, per_setup, strict=True)}}

        def thixotropic(x: np.ndarray, phase: str) -> float:
            tau_y0, lam = np.exp(x)
            loss = log.evaluate_many(lambda points: [losses((tau_y0, *rheometer[1:]), lam, rheometer[0] / tau_y0)],
                                     [x], phase)[0]
            logging.info("tau_y0 %.2f Pa, lam %.3g 1/s: %.5f px", tau_y0, lam, loss)
            return loss

        for name, law in (("bingham", (*args.bingham, 1.0)), ("rheometer", rheometer)):
            log.evaluate_many(lambda points, law=law: [losses(law)], [np.log(law)], name)
        if args.at:
            best = np.log(args.at)
            loss = thixotropic(best, "point")
        else:
            best, loss = simplex_search(thixotropic, START, 0.5, args.evaluations, "search", box=BOX)
    for record in log.records:
        print(record["phase"], np.round(np.exp(record["x"]), 3).tolist(), round(record["loss"], 5),
              [round(v, 5) for v in record["setups"].values()])
    tau_y0, lam = np.exp(best)
    print(f"{'point' if args.at else 'best'}: tau_y0 {tau_y0:.2f} Pa, lam {lam:.3g} 1/s, {loss:.5f} px")


if __name__ == "__main__":
    main()
