"""The loss of a fifth-suite case's base fit (``studies/suite_20261204``) without any effect and with each default
candidate at its nearest null (the weakest magnitude its box holds, where each profile starts), simulated with the
code as it stands. Run from the repository root: ``PYTHONPATH=. python
studies/diagnosis_ladder_20261205/run/nulls.py <case> ...``; writes ``nulls.json`` beside this folder, the loss
ratios to the base fit's per case and candidate."""

import json
import sys
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.diagnose.candidates import CANDIDATES, Law
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.fit.dam_break import compare_law, setup_files, targets

STUDY = Path(__file__).resolve().parents[1]
SUITE = STUDY.parent / "suite_20261204" / "results" / "concealed"

config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
settings = config["diagnose"]
simulation = {**config["virheometry"]["simulation"], "held_out_every": settings["held_out_every"],
              "forecast_share": settings["forecast_share"]}


def loss(built: dict, law: Law, point: np.ndarray) -> float:
    return float(np.mean([compare_law(t, law, point).loss for t in built.values()]))


out = {}
for case in sys.argv[1:]:
    folders = sorted(p for p in (SUITE / case / "recording").iterdir() if p.is_dir())
    built = targets(setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders]),
                    simulation)
    fit = json.loads((SUITE / case / "fit/params.json").read_text())
    base = Law(n=1.0, fitted_modulus="mu_Pa" in fit)
    x = np.log([fit[PARAMETER_KEYS[n]]["value"] for n in base.names])
    out[case] = {"base_px": loss(built, base, x)}
    for name in settings["candidates"]:
        candidate = CANDIDATES[name]
        law = Law(n=1.0, fitted_modulus=base.fitted_modulus, candidate=candidate)
        out[case][name] = {"at": candidate.value(candidate.nearest_null),
                           "ratio": loss(built, law, np.r_[x, candidate.nearest_null]) / out[case]["base_px"]}
        print(case, name, out[case][name], flush=True)
(STUDY / "nulls.json").write_text(json.dumps(out, indent=1) + "\n")
