"""Job specs of the real materials' diagnoses (run in the run's checkout): make_jobs.py DEVICE ITEM ..., an item
MATERIAL:CANDIDATE split by candidate (CANDIDATE "*": all), one process each; an item MATERIAL the whole diagnosis
under the tolerant replay (tolerant_diagnose.py) on all cores."""
import json
import os
import sys
from pathlib import Path

from rheo.config import load_schema, load_yaml, validated
from rheo.experiments.virheometry import setup_folders

config = load_yaml("config/config.yaml")
config["virheometry"]["single_setup_fits"] = []
validated(config, load_schema(Path("workflow/schemas/config.schema.yaml")), "config")
config["simulation"]["device"] = sys.argv[1]
held_out = {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}
bingham = {**config["virheometry"]["fit"], "flow_index": 1.0}
jobs = []
for item in sys.argv[2:]:
    m, _, which = item.partition(":")
    setups = [p.name for p in setup_folders(config["virheometry"]["data"], m)]
    folder = f"results/virheometry/{m}/diagnosis"
    if not which:
        jobs.append({"name": m, "script": "tolerant_diagnose.py",
                     "input": {"fit": f"results/virheometry/{m}/fit_bingham/params.json",
                               "setups": [f"results/virheometry/setups/{s}/setup.json" for s in setups],
                               "masks": [f"results/virheometry/setups/{s}/masks.npz" for s in setups],
                               "rheometer": config["virheometry"]["rheometer"].get(m, [])},
                     "output": {"diagnosis": f"{folder}/diagnosis.json", "maps": f"{folder}/maps.png",
                                "report": f"{folder}/report.html"},
                     "log": [f"logs/virheometry/{m}/diagnose.log"], "threads": os.cpu_count(),
                     "params": {"settings": config["diagnose"], "fit_settings": bingham, "simulation": held_out,
                                "title": f"{m}: what the Bingham model leaves out"}, "config": config})
        continue
    for c in config["diagnose"]["candidates"] if which == "*" else which.split(","):
        jobs.append({"name": f"{m}.{c}", "script": "candidate.py",
                     "input": {"fit": f"results/virheometry/{m}/fit_bingham/params.json",
                               "setups": [f"results/virheometry/setups/{s}/setup.json" for s in setups],
                               "masks": [f"results/virheometry/setups/{s}/masks.npz" for s in setups],
                               "evaluations": f"{folder}/diagnosis.evaluations.json"},
                     "output": {"done": f"{folder}/{c}.done"}, "log": [f"logs/virheometry/{m}/diagnose.{c}.log"],
                     "threads": 1, "params": {"settings": config["diagnose"], "fit_settings": bingham,
                                              "simulation": held_out, "candidate": c}, "config": config})
json.dump(jobs, sys.stdout)
