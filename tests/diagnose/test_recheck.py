"""The diagnosis' recheck replays the searches the studies ran from a winner's law: three stored searches of the
null training case c7fa1a139, gone through point by point with no evaluation of its own."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rheo.diagnose.candidates import Law
from rheo.diagnose.dam_break import base_refit_from, law_steps, refit_point
from rheo.experiments.rheometer import PARAMETER_KEYS
from rheo.fit.search import EvaluationLog

STUDIES = Path(__file__).resolve().parents[2] / "studies"
CASE = STUDIES / "suite_20261204/results/concealed/c7fa1a139"
LAW = Law(n=1.0, fitted_modulus=True)
BOX = (np.log([0.5, 0.1, 30.0]), np.log([100.0, 50.0, 3000.0]))  # concealed.fit's tau_y, K and mu
LAW_STEP, EVALUATIONS = 0.3, 20  # diagnose.law_step and refit_evaluations, as the studies ran


@pytest.mark.parametrize(("diagnosis", "effect", "store", "phase", "result"), [
    (CASE / "diagnosis/diagnosis.json", "thixotropy", "recheck_20261205/c7fa1a139.evaluations.json", "recheck",
     "recheck_20261205/c7fa1a139.json"),
    *[(STUDIES / "diagnosis_ladder_20261205/results/concealed/c7fa1a139/diagnosis/diagnosis.json", effect,
       f"diagnosis_ladder_20261205/run/c7fa1a139_{effect}.evaluations.json", None,
       "diagnosis_ladder_20261205/rechecks.json") for effect in ("shear_thinning", "wall_adhesion")],
])
def test_the_recheck_replays_the_stored_search(tmp_path, diagnosis, effect, store, phase, result):
    fit = json.loads((CASE / "fit/params.json").read_text())
    candidate = next(c for c in json.loads(diagnosis.read_text())["candidates"] if c["effect"] == effect)
    x = refit_point(LAW, effect, candidate["values"])
    steps = law_steps(LAW.names, {n: tuple(fit[PARAMETER_KEYS[n]]["interval"]) for n in LAW.names}, LAW_STEP)
    shutil.copy(STUDIES / store, tmp_path / "store.json")
    log = EvaluationLog(tmp_path / "store.json", phase or f"recheck {effect}")

    def unstored(points):
        raise AssertionError(f"a point the study did not evaluate: {points}")

    found = base_refit_from(effect, x, LAW, fit["shear_rate_band_per_s"], BOX, steps,
                            lambda x, phase: log.evaluate_many(unstored, [x], phase)[0], log.best, EVALUATIONS,
                            phase)
    recorded = json.loads((STUDIES / result).read_text())
    recorded = next((r for r in recorded.get("rechecks", []) if r["effect"] == effect), recorded)
    assert len(log.requested) == EVALUATIONS == len(log.records)
    assert found.loss == recorded["recheck_loss_px"]
    assert np.exp(found.x) == pytest.approx(list(recorded["recheck_values"].values()), rel=1e-12)
