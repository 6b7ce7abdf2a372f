"""A first-suite case's concealed truth (its law and effects) and its base fit's law, each simulated in the fit's own
simulation with the lab's elastic constants and with the fit's (mu 300 Pa, lam 1e4 Pa): how much of the base fit's
distance from the truth the elastic constants the fit holds account for. Run from a checkout of the suite's code
(03e7232), whose engine and settings the suite's fits used; writes ``--out`` (JSON).

    cd <checkout of 03e7232> && PYTHONPATH=. python <repo>/studies/elastic_mismatch_20261129/run/probe.py \
        --case c55ea49b9 --out <repo>/studies/elastic_mismatch_20261129/c55ea49b9.json
"""

import argparse
from pathlib import Path

from case import case_files, fit_simulation, simulated_losses

from rheo.experiments.concealed import concealed_truth
from rheo.io import write_json_atomic

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--case", required=True, help="a case of the first suite, e.g. c55ea49b9")
parser.add_argument("--laws", default="truth,fit", help="which laws: truth (with its effects), fit (the base fit's)")
parser.add_argument("--out", required=True, type=Path)
args = parser.parse_args()

simulation = fit_simulation()
truth, fit, setups = case_files(args.case)
filmed = concealed_truth({"effects": truth["effects"]}, {"tau_y": truth["tau_y_Pa"], "K": truth["K_Pa_s_n"]})
laws = {"truth": (filmed.law, filmed.effects),
        "fit": ({"tau_y": fit["tau_y_Pa"]["value"], "K": fit["K_Pa_s_n"]["value"], "n": fit["n"]["value"]}, None)}
elastic = {"lab": {"mu": truth["mu_Pa"], "lam": truth["lam_Pa"]}, "fit": fit["elastic_constants_Pa"]}
rows = []
for law_name in args.laws.split(","):
    law, effects = laws[law_name]
    for elastic_name, constants in elastic.items():
        rows.append({"law": law_name, "elastic": elastic_name,
                     **simulated_losses(setups, simulation, constants, law, effects)})
        print(rows[-1], flush=True)
write_json_atomic(args.out, {"case": args.case, "effects": truth["effects"], "base_fit_loss_px": fit["loss_px"],
                             "law": {k: {p: float(v[0][p]) for p in ("tau_y", "K", "n")} for k, v in laws.items()},
                             "rows": rows})
