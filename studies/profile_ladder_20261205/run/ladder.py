"""One candidate's profile (``rheo.diagnose.selection.profile_refit``, as the diagnosis runs it, with the default
settings) from a stored base fit: a concealed case's (``concealed/<case>``) or a real material's Bingham fit
(``virheometry/<material>``), its shear modulus fitted where the fit did so, else held at the simulation's. Run from
the repository root: ``PYTHONPATH=. python studies/profile_ladder_20261205/run/ladder.py <study> <target>
<candidate>``, the target's results read from the study; the evaluations are stored in this study's folder, so a
second run replays them."""

import json
import sys
from functools import partial
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.diagnose.candidates import CANDIDATES, Law
from rheo.diagnose.dam_break import objectives, summary
from rheo.diagnose.selection import Refit, profile_refit
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.fit.dam_break import setup_files
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog

STUDY = Path(__file__).resolve().parents[1]
study, target, name = sys.argv[1:4]
results = STUDY.parent / study / "results"
kind, label = target.split("/")

config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
settings = config["diagnose"]
simulation = {**config["virheometry"]["simulation"], "held_out_every": settings["held_out_every"],
              "forecast_share": settings["forecast_share"]}
fit_settings = {**config[kind]["fit"], "flow_index": 1.0}
if kind == "concealed":
    folders = sorted(p for p in (results / target / "recording").iterdir() if p.is_dir())
    fit = json.loads((results / target / "fit/params.json").read_text())
else:
    folders = sorted((results / "virheometry/setups").glob(f"ref_{label}_*"))
    fit = json.loads((results / target / "fit_bingham/params.json").read_text())
setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
base = Law(n=1.0, fitted_modulus="mu_Pa" in fit)
candidate = CANDIDATES[name]
base_x = np.log([fit[PARAMETER_KEYS[n]]["value"] for n in base.names])
box = tuple(np.log([fit_settings[n][i] for n in base.names]) for i in (0, 1))
log = EvaluationLog(STUDY / f"{label}_{name}.evaluations.json", "profile")
laws = {name: Law(n=1.0, fitted_modulus=base.fitted_modulus, candidate=candidate)}
with Evaluator(partial(objectives, setups, simulation, laws), len(setups)) as evaluator:

    def joint(points: list[np.ndarray]) -> list[dict]:
        out = [summary(evaluator.map([(f"{name}|{s}", x) for s in setups])) for x in points]
        for x, value in zip(points, out, strict=True):
            print(f"{len(log.seen()[1])}: {np.round(x, 4).tolist()} loss {value['loss']:.5f} px", flush=True)
        return out

    refit = profile_refit(candidate, lambda x, phase: log.evaluate_many(joint, [x], phase)[0], log.best, base_x, box,
                          (settings["stress_step"], settings["share_step"]), settings["rung_evaluations"],
                          tuple(fit["shear_rate_band_per_s"]), 1.0)
best = Refit.of(name, log.best(f"refit {name}"))
values = dict(zip((PARAMETER_KEYS[n] for n in base.names), np.exp(best.x[:-1]).tolist(), strict=True))
result = {"target": target, "candidate": name, "evaluations": len(log.seen()[1]), "loss_px": best.loss,
          "values": {**values, name: candidate.value(float(best.x[-1]))},
          "profile": [list(p) for p in refit.profile]}
if kind == "concealed":
    result |= {"truth": json.loads((results / target / "truth.json").read_text()),
               "oracle_loss_px": json.loads((results / target / "oracle.json").read_text())["loss_px"]}
(STUDY / f"{label}_{name}.json").write_text(json.dumps(result, indent=1) + "\n")
print(json.dumps(result, indent=1))
