"""The first suite's floor-friction case (c54c71111): its truth's law and its base fit's law, each on a floor of
Coulomb coefficient 0.5, 0.3 and 0.175 (the truth's), in the fit's own simulation (the fit's elastic constants):
how narrow the valley the candidate's profile had to follow is. Run from a checkout of the suite's code (03e7232);
writes ``--out`` (JSON).

    cd <checkout of 03e7232> && PYTHONPATH=. python <repo>/studies/elastic_mismatch_20261129/run/friction.py \
        --out <repo>/studies/elastic_mismatch_20261129/c54c71111_friction.json
"""

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from case import case_files, fit_simulation

from rheo.fit.dam_break import targets
from rheo.io import write_json_atomic

CASE = "c54c71111"
FRICTIONS = (0.5, 0.3, 0.175)

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--out", required=True, type=Path)
args = parser.parse_args()

simulation = fit_simulation()
truth, fit, setups = case_files(CASE)
laws = {"truth": (truth["tau_y_Pa"], truth["K_Pa_s_n"]), "fit": (fit["tau_y_Pa"]["value"], fit["K_Pa_s_n"]["value"])}
built = targets(setups, simulation)
rows = []
for name, (tau_y, K) in laws.items():
    for friction in FRICTIONS:
        found = [t.compare(tau_y, K, 1.0, dataclasses.replace(t.effects, floor_friction=friction))
                 for t in built.values()]
        rows.append({"law": name, "tau_y_Pa": tau_y, "K_Pa_s_n": K, "floor_friction": friction,
                     "loss_px": float(np.mean([c.loss for c in found]))})
        print(rows[-1], flush=True)
write_json_atomic(args.out, {"case": CASE, "elastic_constants_Pa": {"mu": simulation["mu"], "lam": simulation["lam"]},
                             "rows": rows})
