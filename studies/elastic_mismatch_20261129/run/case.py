"""What the study's scripts share: the fit's simulation settings as the first suite's code configures them, and a
case's recorded setups."""

import json
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.fit.dam_break import setup_files, targets

SUITE = Path(__file__).resolve().parents[2] / "suite_20261126" / "results" / "concealed"


def fit_simulation() -> dict:
    """The simulation settings the suite's fits and diagnoses ran with (config/config.yaml of the checkout)."""
    config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
    return {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}


def case_files(case: str, suite: Path = SUITE) -> tuple[dict, dict, dict]:
    """A case's truth (truth.json), base fit (fit/params.json) and recorded setups (its setups and masks), from a
    suite's ``results/concealed``."""
    root = suite / case
    folders = sorted(p for p in (root / "recording").iterdir() if p.is_dir())
    setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
    return (json.loads((root / "truth.json").read_text()), json.loads((root / "fit/params.json").read_text()),
            setups)


def simulated_losses(setups: dict, simulation: dict, constants: dict, law: dict, effects) -> dict:
    """A law (with its effects) simulated with some elastic constants: the constants, its mean loss over the setups
    and each setup's."""
    found = {name: target.compare(law["tau_y"], law["K"], law["n"], effects)
             for name, target in targets(setups, {**simulation, **constants}).items()}
    return {**constants, "loss_px": float(np.mean([c.loss for c in found.values()])),
            "setups_loss_px": {name: c.loss for name, c in found.items()}}
