"""Job specs of the suite's base fits and diagnoses (run in the run's checkout, with the scripts of
../../virheometry_20261127/run beside it): make_jobs.py DEVICE ITEM ..., an item CASE:fit the case's base fit,
CASE:CANDIDATE (CANDIDATE "*": all) its diagnosis split by candidate, one process each, after the fit where that is
in the same file; an item CASE the whole diagnosis under the tolerant replay (tolerant_diagnose.py) on all cores."""
import json
import os
import sys
from pathlib import Path

from rheo.config import load_schema, load_yaml, validated

config = load_yaml("config/config.yaml")
config["concealed"] = {**config.get("concealed", {}), "cases": "config/experiments/suite_20261126"}
validated(config, load_schema(Path("workflow/schemas/config.schema.yaml")), "config")
config["simulation"]["device"] = sys.argv[1]
held_out = {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}
bingham = {**config["concealed"]["fit"], "flow_index": 1.0}
channels = range(1, len(config["concealed"]["scene"]["setups"]) + 1)
jobs = []
for item in sys.argv[2:]:
    case, _, which = item.partition(":")
    folder = f"results/concealed/{case}"
    recordings = {"setups": [f"{folder}/recording/{k}/setup.json" for k in channels],
                  "masks": [f"{folder}/recording/{k}/masks.npz" for k in channels]}
    diagnosis = {"fit": f"{folder}/fit/params.json", **recordings}
    params = {"settings": config["diagnose"], "fit_settings": bingham, "simulation": held_out}
    if which == "fit":
        jobs.append({"name": f"{case}.fit", "script": "stages/virheometry_fit.py", "input": recordings,
                     "output": {"params": f"{folder}/fit/params.json", "history": f"{folder}/fit/history.csv",
                                "frames": f"{folder}/fit/frames.png"},
                     "log": [f"logs/concealed/{case}/fit.log"], "threads": 1,
                     "params": {"simulation": held_out, "settings": bingham}, "config": config})
    elif not which:
        jobs.append({"name": case, "script": "tolerant_diagnose.py", "input": diagnosis,
                     "output": {"diagnosis": f"{folder}/diagnosis/diagnosis.json",
                                "maps": f"{folder}/diagnosis/maps.png", "report": f"{folder}/diagnosis/report.html"},
                     "log": [f"logs/concealed/{case}/diagnose.log"], "threads": os.cpu_count(),
                     "params": {**params, "title": f"concealed case {case}: what the Bingham model leaves out"},
                     "config": config})
    else:
        for c in config["diagnose"]["candidates"] if which == "*" else which.split(","):
            jobs.append({"name": f"{case}.{c}", "script": "candidate.py", "after": f"{case}.fit",
                         "input": {**diagnosis, "evaluations": f"{folder}/diagnosis/diagnosis.evaluations.json"},
                         "output": {"done": f"{folder}/diagnosis/{c}.done"},
                         "log": [f"logs/concealed/{case}/diagnose.{c}.log"], "threads": 1,
                         "params": {**params, "candidate": c}, "config": config})
json.dump(jobs, sys.stdout)
