"""A third-suite case's concealed truth (its law and effects) and its base fit's law, simulated in the fit's own
simulation with the lab's elastic constants, with the lab's shear modulus and the lam the fit holds, and with the base
fit's constants: whether the base fit stopped short of a law the fit's simulation could reach. Run from a checkout of
the suite's code (57e6223); writes ``--out`` (JSON).

    cd <checkout of 57e6223> && PYTHONPATH=. python <repo>/studies/base_fit_reach_20261203/run/probe.py \
        --case cbbcbb79b --out <repo>/studies/base_fit_reach_20261203/cbbcbb79b.json
"""

import argparse
import sys
from pathlib import Path

from rheo.experiments.concealed import concealed_truth
from rheo.io import write_json_atomic

STUDIES = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(STUDIES / "elastic_mismatch_20261129" / "run"))
from case import case_files, fit_simulation, simulated_losses  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--case", required=True, help="a case of the third suite, e.g. cbbcbb79b")
parser.add_argument("--out", required=True, type=Path)
args = parser.parse_args()

simulation = fit_simulation()
truth, fit, setups = case_files(args.case, STUDIES / "suite_20261130" / "results" / "concealed")
filmed = concealed_truth({"effects": truth["effects"]}, {"tau_y": truth["tau_y_Pa"], "K": truth["K_Pa_s_n"]})
base_law = {"tau_y": fit["tau_y_Pa"]["value"], "K": fit["K_Pa_s_n"]["value"], "n": fit["n"]["value"]}
held, lab = fit["elastic_constants_Pa"], {"mu": truth["mu_Pa"], "lam": truth["lam_Pa"]}
laws = {"truth": (filmed.law, filmed.effects), "fit": (base_law, None)}
runs = [("truth", "lab", lab), ("truth", "lab mu, fit's lam", {**lab, "lam": held["lam"]}), ("truth", "fit", held),
        ("fit", "lab", lab)]
rows = []
for law_name, elastic_name, constants in runs:
    law, effects = laws[law_name]
    rows.append({"law": law_name, "elastic": elastic_name,
                 **simulated_losses(setups, simulation, constants, law, effects)})
    print(rows[-1], flush=True)
write_json_atomic(args.out, {"case": args.case, "effects": truth["effects"], "base_fit_loss_px": fit["loss_px"],
                             "law": {"truth": {p: float(filmed.law[p]) for p in ("tau_y", "K", "n")},
                                     "fit": base_law}, "rows": rows})
