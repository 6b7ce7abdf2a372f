"""Which shear rate each of Lotion's setups reads: three laws of its joint fit's flow-index profile that fit both
setups within the tolerance (n 0.55, 1 and 1.4), each scaled by the factor (stress times a) that fits one setup
best, at the default settings; where over that setup's shear rates the three best-scaled flow curves agree best
(``best_determined_stress``) is where the setup pins the stress. Each simulation's loss and shear-rate band are
written to ``--out`` under the engine's fingerprint, so a stopped run goes on and a finished one replays.

    PYTHONPATH=. python studies/setup_pins_20261128/run/pins.py --out studies/setup_pins_20261128/losses.json
"""

import argparse
import json
import logging
import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.virheometry import read_setup, setup_folders
from rheo.fit.convergence import StudyRecords
from rheo.fit.dam_break import DamBreakTarget, shear_rate_band, target
from rheo.fit.uncertainty import DeterminedStress, best_determined_stress
from studies.lotion import SHAPES, add_material_arguments, require_fit

LOG_SCALE = 0.35  # the scales searched: exp(-0.35) to exp(0.35)
SCALE_TOLERANCE = 0.015  # in log


def scaled_loss(compared: DamBreakTarget, label: str, law: tuple[float, float, float], log_scale: float,
                records: StudyRecords) -> float:
    """The loss of ``law`` scaled by exp(``log_scale``) on ``compared``, from ``records`` or simulated into them."""
    name = f"{label} {log_scale:.6f}"
    if name not in records:
        tau_y, K, n = law
        scale = math.exp(log_scale)
        comparison = compared.compare(scale * tau_y, scale * K, n)
        records[name] = {"loss_px": comparison.loss, "band_per_s": shear_rate_band([comparison])}
        logging.info("%s: %.5f px", name, comparison.loss)
        records.save()
    return records[name]["loss_px"]


def best_scale(compared: DamBreakTarget, label: str, law: tuple[float, float, float],
               records: StudyRecords) -> tuple[float, dict]:
    """The scale of ``law`` that fits ``compared`` best, and its record (loss, shear-rate band)."""
    found = minimize_scalar(lambda s: scaled_loss(compared, label, law, s, records), bounds=(-LOG_SCALE, LOG_SCALE),
                            method="bounded", options={"xatol": SCALE_TOLERANCE})
    return math.exp(found.x), records[f"{label} {found.x:.6f}"]


def profile_shapes(fit: Path) -> dict[str, tuple[float, float, float]]:
    """The laws of ``fit``'s (a joint fit's params.json) flow-index profile at the flow indices of ``SHAPES``."""
    profile = json.loads(fit.read_text())["flow_index_profile"]
    laws = zip(profile["tau_y_Pa"], profile["K_Pa_s_n"], profile["n"], strict=True)
    by_index = {n: (tau_y, K, n) for tau_y, K, n in laws}
    return {name: by_index[n] for name, (_, _, n) in SHAPES.items()}


def material_shapes(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict[str, tuple[float, float, float]]:
    """The laws to read ``args.material`` with: its fit's profile, or Lotion's ``SHAPES``."""
    require_fit(parser, args)
    return profile_shapes(args.fit) if args.fit else SHAPES


def setup_targets(material: str) -> Iterator[tuple[str, DamBreakTarget]]:
    """Each of ``material``'s setups (folder name) with its target at the default settings."""
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    for folder in setup_folders(config["data"], material):
        yield folder.name, target(read_setup(folder, config["scale"]), config["simulation"])


def read_rate(compared: DamBreakTarget, label: str, records: StudyRecords,
              shapes: dict[str, tuple[float, float, float]] = SHAPES,
              known: Sequence[tuple[list[float], list[float]]] = ()) -> DeterminedStress:
    """Where the ``shapes``, each scaled to fit ``compared`` best, and the ``known`` laws (each with its shear-rate
    band) agree best over their shear rates; each step printed."""
    laws, bands = [law for law, _ in known], [band for _, band in known]
    for name, law in shapes.items():
        scale, record = best_scale(compared, f"{label} {name}", law, records)
        laws.append([scale * law[0], scale * law[1], law[2]])
        bands.append(record["band_per_s"])
        print(f"{label} {name}: scale {scale:.3f}, {record['loss_px']:.5f} px")
    band = (min(b[0] for b in bands), max(b[1] for b in bands))
    pinned = best_determined_stress(np.array(laws), band)
    print(f"{label}: over {band[0]:.2g}-{band[1]:.2g} 1/s the laws agree best at {pinned.rate:.2g} 1/s, "
          f"{pinned.low:.3g}-{pinned.high:.3g} Pa")
    return pinned


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    add_material_arguments(parser)
    args = parser.parse_args()
    shapes = material_shapes(parser, args)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    records = StudyRecords(args.out)
    for name, compared in setup_targets(args.material):
        read_rate(compared, name, records, shapes)

if __name__ == "__main__":
    main()
