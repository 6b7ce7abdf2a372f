"""The diagnosis' recheck on the fifth suite's null case c7fa1a139 (a training case): the base model searched from
the law of the effect that won (thixotropy) by the diagnosis' own recheck (``base_refit_from``), with the suite's
settings. Run from the repository root: ``PYTHONPATH=. python studies/recheck_20261205/run/recheck.py``; the
evaluations are stored in the study's folder, so a second run replays them. ``recheck`` serves other studies too."""

import json
from functools import partial
from pathlib import Path

import numpy as np

from rheo.config import load_schema, load_yaml, validated
from rheo.diagnose.candidates import Law
from rheo.diagnose.dam_break import base_refit_from, law_steps, objectives, refit_point, summary
from rheo.diagnose.selection import named_below
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.fit.dam_break import setup_files
from rheo.fit.parallel import Evaluator
from rheo.fit.search import EvaluationLog

STUDY = Path(__file__).resolve().parents[1]
CASE = "c7fa1a139"


def recheck(case_root: Path, diagnosis: dict, candidate: dict, store: Path, phase: str, workers: int) -> dict:
    """The base model searched from ``candidate``'s refit (an entry of ``diagnosis["candidates"]``) of the case
    whose recording and base fit are under ``case_root``, its evaluations stored in ``store`` under ``phase``: its
    loss, criterion change against the base fit, law, and whether the candidate still pays against it."""
    config = validated(load_yaml("config/config.yaml"), load_schema("workflow/schemas/config.schema.yaml"), "config")
    settings = config["diagnose"]
    simulation = {**config["virheometry"]["simulation"], "held_out_every": settings["held_out_every"],
                  "forecast_share": settings["forecast_share"]}
    fit_settings = {**config["concealed"]["fit"], "flow_index": 1.0}
    folders = sorted(p for p in (case_root / "recording").iterdir() if p.is_dir())
    setups = setup_files([str(f / "setup.json") for f in folders], [str(f / "masks.npz") for f in folders])
    fit = json.loads((case_root / "fit/params.json").read_text())
    law = Law(n=1.0, fitted_modulus=fit_settings.get("mu") is not None)
    steps = law_steps(law.names, {n: tuple(fit[PARAMETER_KEYS[n]]["interval"]) for n in law.names},
                      settings["law_step"])
    box = tuple(np.log([fit_settings[n][i] for n in law.names]) for i in (0, 1))
    x = refit_point(law, candidate["effect"], candidate["values"])
    log = EvaluationLog(store, phase)
    with Evaluator(partial(objectives, setups, simulation, {"base": law}), workers) as evaluator:

        def joint(points: list[np.ndarray]) -> list[dict]:
            return [summary(evaluator.map([(f"base|{s}", x) for s in setups])) for x in points]

        found = base_refit_from(candidate["effect"], x, law, fit["shear_rate_band_per_s"], box, steps,
                                lambda x, phase: log.evaluate_many(joint, [x], phase)[0], log.best,
                                settings["refit_evaluations"], phase)
    delta = found.criterion - diagnosis["base"]["criterion"]
    return {"recheck_loss_px": found.loss, "recheck_delta_criterion": delta,
            "recheck_values": dict(zip((PARAMETER_KEYS[n] for n in law.names), np.exp(found.x).tolist(),
                                       strict=True)),
            "still_named": candidate["delta_criterion"] < named_below(diagnosis["evidence"], delta)}


if __name__ == "__main__":
    root = STUDY.parent / "suite_20261204" / "results" / "concealed" / CASE
    diagnosis = json.loads((root / "diagnosis/diagnosis.json").read_text())
    winner = min(diagnosis["candidates"], key=lambda c: c["delta_criterion"])
    found = recheck(root, diagnosis, winner, STUDY / f"{CASE}.evaluations.json", "recheck", 1)
    result = {"case": CASE, "winner": winner["effect"], "winner_delta_criterion": winner["delta_criterion"],
              "winner_values": winner["values"], "recheck_loss_px": found["recheck_loss_px"],
              "recheck_delta_criterion": found["recheck_delta_criterion"],
              "recheck_values": found["recheck_values"], "base_loss_px": diagnosis["base"]["loss_px"],
              "base_values": diagnosis["base"]["values"], "still_named": found["still_named"]}
    (STUDY / f"{CASE}.json").write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))
