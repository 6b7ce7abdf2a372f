"""The recheck the full diagnosis of the null training case c7fa1a139 did not run (a decoy won, so nothing was to be
rechecked): the base model searched from the law of each effect whose refit passed the evidence, as
``rheo.diagnose.dam_break.diagnose`` searches it. Run from the repository root: ``PYTHONPATH=. python
studies/diagnosis_ladder_20261205/run/rechecks.py``; the evaluations are stored in ``run/``, so a second run replays
them; writes ``rechecks.json`` beside this folder."""

import json
from functools import partial
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.diagnose.candidates import CANDIDATES, Law
from rheo.diagnose.dam_break import law_steps, objectives, recheck_start, summary
from rheo.diagnose.selection import Refit
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.fit.dam_break import setup_files
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog, simplex_search

STUDY = Path(__file__).resolve().parents[1]
CASE = "c7fa1a139"
SUITE = STUDY.parent / "suite_20261204" / "results" / "concealed" / CASE

config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
settings = config["diagnose"]
simulation = {**config["virheometry"]["simulation"], "held_out_every": settings["held_out_every"],
              "forecast_share": settings["forecast_share"]}
fit_settings = {**config["concealed"]["fit"], "flow_index": 1.0}
folders = sorted(p for p in (SUITE / "recording").iterdir() if p.is_dir())
setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
fit = json.loads((SUITE / "fit/params.json").read_text())
diagnosis = json.loads((STUDY / "results/concealed" / CASE / "diagnosis/diagnosis.json").read_text())
law = Law(n=1.0, fitted_modulus=fit_settings.get("mu") is not None)
steps = law_steps(law.names, {n: tuple(fit[PARAMETER_KEYS[n]]["interval"]) for n in law.names}, settings["law_step"])
box = tuple(np.log([fit_settings[n][i] for n in law.names]) for i in (0, 1))
base_criterion = diagnosis["base"]["criterion"]
passed = [c for c in diagnosis["candidates"] if not c["decoy"] and c["delta_criterion"] < -settings["evidence"]]
results = []
with Evaluator(partial(objectives, setups, simulation, {"base": law}), len(setups)) as evaluator:

    def joint(points: list[np.ndarray]) -> list[dict]:
        return [summary(evaluator.map([(f"base|{s}", x) for s in setups])) for x in points]

    for candidate in passed:
        effect = CANDIDATES[candidate["effect"]]
        x = np.r_[np.log([candidate["values"][PARAMETER_KEYS[n]] for n in law.names]),
                  effect.coordinate(candidate["values"][effect.name])]
        phase = f"recheck {effect.name}"
        log = EvaluationLog(STUDY / "run" / f"{CASE}_{effect.name}.evaluations.json", phase)
        simplex_search(lambda x, phase=phase, log=log: log.evaluate_many(joint, [x], phase)[0],
                       recheck_start(effect, x, law, fit["shear_rate_band_per_s"], box), 0.5 * steps,
                       settings["refit_evaluations"], phase, box=box)
        recheck = Refit.of("base", log.best(phase))
        delta = recheck.criterion - base_criterion
        results.append({"effect": effect.name, "delta_criterion": candidate["delta_criterion"],
                        "loss_px": candidate["loss_px"], "recheck_loss_px": recheck.loss,
                        "recheck_delta_criterion": delta,
                        "recheck_values": dict(zip((PARAMETER_KEYS[n] for n in law.names),
                                                   np.exp(recheck.x).tolist(), strict=True)),
                        "still_named": candidate["delta_criterion"] < min(0.0, delta) - settings["evidence"]})
        print(json.dumps(results[-1]), flush=True)
(STUDY / "rechecks.json").write_text(json.dumps({"case": CASE, "base_loss_px": diagnosis["base"]["loss_px"],
                                                 "rechecks": results}, indent=1) + "\n")
