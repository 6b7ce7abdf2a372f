"""The recheck the full diagnosis of the null training case c7fa1a139 did not run (a decoy won, so nothing was to be
rechecked): the base model searched from the law of each effect whose refit passed the evidence, as
``rheo.diagnose.dam_break.diagnose`` searches it (``recheck_20261205/run/recheck.py``). Run from the repository root:
``PYTHONPATH=. python studies/diagnosis_ladder_20261205/run/rechecks.py``; the evaluations are stored in ``run/``, so
a second run replays them; writes ``rechecks.json`` beside this folder."""

import json
import sys
from pathlib import Path

STUDY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(STUDY.parent / "recheck_20261205" / "run"))
from recheck import recheck  # noqa: E402

CASE = "c7fa1a139"
diagnosis = json.loads((STUDY / "results/concealed" / CASE / "diagnosis/diagnosis.json").read_text())
results = []
for candidate in diagnosis["candidates"]:
    if candidate["decoy"] or candidate["delta_criterion"] >= -diagnosis["evidence"]:
        continue
    name = candidate["effect"]
    found = recheck(STUDY.parent / "suite_20261204" / "results" / "concealed" / CASE, diagnosis, candidate,
                    STUDY / "run" / f"{CASE}_{name}.evaluations.json", f"recheck {name}", 2)
    results.append({"effect": name, "delta_criterion": candidate["delta_criterion"], "loss_px": candidate["loss_px"],
                    **found})
    print(json.dumps(results[-1]), flush=True)
(STUDY / "rechecks.json").write_text(json.dumps({"case": CASE, "base_loss_px": diagnosis["base"]["loss_px"],
                                                 "rechecks": results}, indent=1) + "\n")
