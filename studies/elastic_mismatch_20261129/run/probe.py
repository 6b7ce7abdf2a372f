"""A first-suite case's concealed truth (its law and effects) and its base fit's law, each simulated in the fit's own
simulation with the lab's elastic constants and with the fit's (mu 300 Pa, lam 1e4 Pa): how much of the base fit's
distance from the truth the elastic constants the fit holds account for. Run from a checkout of the suite's code
(03e7232), whose engine and settings the suite's fits used; writes ``--out`` (JSON).

    cd <checkout of 03e7232> && PYTHONPATH=. python <repo>/studies/elastic_mismatch_20261129/run/probe.py \
        --case c55ea49b9 --out <repo>/studies/elastic_mismatch_20261129/c55ea49b9.json
"""

import argparse
import json
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.experiments.concealed import concealed_truth
from rheo.fit.dam_break import setup_files, targets
from rheo.io import write_json_atomic

SUITE = Path(__file__).resolve().parents[2] / "suite_20261126" / "results" / "concealed"

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--case", required=True, help="a case of the first suite, e.g. c55ea49b9")
parser.add_argument("--laws", default="truth,fit", help="which laws: truth (with its effects), fit (the base fit's)")
parser.add_argument("--out", required=True, type=Path)
args = parser.parse_args()

root = SUITE / args.case
config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
simulation = {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
              "forecast_share": config["diagnose"]["forecast_share"]}
truth = json.loads((root / "truth.json").read_text())
fit = json.loads((root / "fit/params.json").read_text())
filmed = concealed_truth({"effects": truth["effects"]}, {"tau_y": truth["tau_y_Pa"], "K": truth["K_Pa_s_n"]})
laws = {"truth": (filmed.law, filmed.effects),
        "fit": ({"tau_y": fit["tau_y_Pa"]["value"], "K": fit["K_Pa_s_n"]["value"], "n": fit["n"]["value"]}, None)}
elastic = {"lab": {"mu": truth["mu_Pa"], "lam": truth["lam_Pa"]}, "fit": fit["elastic_constants_Pa"]}
folders = sorted(p for p in (root / "recording").iterdir() if p.is_dir())
setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
rows = []
for law_name in args.laws.split(","):
    law, effects = laws[law_name]
    for elastic_name, constants in elastic.items():
        found = {name: target.compare(law["tau_y"], law["K"], law["n"], effects)
                 for name, target in targets(setups, {**simulation, **constants}).items()}
        rows.append({"law": law_name, "elastic": elastic_name, **constants,
                     "loss_px": float(np.mean([c.loss for c in found.values()])),
                     "setups_loss_px": {name: c.loss for name, c in found.items()}})
        print(rows[-1], flush=True)
write_json_atomic(args.out, {"case": args.case, "effects": truth["effects"], "base_fit_loss_px": fit["loss_px"],
                             "law": {k: {p: float(v[0][p]) for p in ("tau_y", "K", "n")} for k, v in laws.items()},
                             "rows": rows})
