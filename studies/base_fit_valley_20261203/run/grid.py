"""A third-suite case's loss over the yield stress' share of the stress and the shear modulus, at the stress its
base fit found at 10 1/s (Bingham laws, lam held at the fit's): whether a survey along that valley finds the basin
the base fit's box survey missed. Writes ``--out`` (JSON).

    PYTHONPATH=. python studies/base_fit_valley_20261203/run/grid.py --case cbbcbb79b \
        --out studies/base_fit_valley_20261203/grid_cbbcbb79b.json
"""

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

from rheo.io import write_json_atomic

STUDIES = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(STUDIES / "elastic_mismatch_20261129" / "run"))
from case import case_files, fit_simulation, simulated_losses  # noqa: E402

RATE = 10.0
SHARES = (0.1, 0.3, 0.5, 0.7, 0.9)
MODULI = (100.0, 300.0, 1000.0)

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--case", required=True)
parser.add_argument("--out", required=True, type=Path)
args = parser.parse_args()

simulation = fit_simulation()
truth, fit, setups = case_files(args.case, STUDIES / "suite_20261130" / "results" / "concealed")
stress = fit["tau_y_Pa"]["value"] + fit["K_Pa_s_n"]["value"] * RATE
lam = fit["elastic_constants_Pa"]["lam"]
rows = []
for share, mu in itertools.product(SHARES, MODULI):
    law = {"tau_y": share * stress, "K": (1 - share) * stress / RATE, "n": 1.0}
    rows.append({"share": share, **law, **simulated_losses(setups, simulation, {"mu": mu, "lam": lam}, law, None)})
    print(rows[-1], flush=True)
write_json_atomic(args.out, {"case": args.case, "stress_Pa": stress, "rate_per_s": RATE,
                             "base_fit_loss_px": fit["loss_px"], "rows": rows,
                             "best": min(rows, key=lambda r: r["loss_px"])})
print(np.round([r["loss_px"] for r in rows], 4).reshape(len(SHARES), len(MODULI)))
