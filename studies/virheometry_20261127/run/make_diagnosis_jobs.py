"""Job specs of whole real diagnoses under the tolerant replay (tolerant_diagnose.py), for run_fits.py --one; run in
the run's checkout: make_diagnosis_jobs.py THREADS MATERIAL ..."""
import json
import sys
from pathlib import Path

from rheo.config import load_schema, load_yaml, validated
from rheo.experiments.virheometry import setup_folders

config = load_yaml("config/config.yaml")
config["virheometry"]["single_setup_fits"] = []
validated(config, load_schema(Path("workflow/schemas/config.schema.yaml")), "config")
held_out = {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}
bingham = {**config["virheometry"]["fit"], "flow_index": 1.0}
jobs = []
for m in sys.argv[2:]:
    setups = [p.name for p in setup_folders(config["virheometry"]["data"], m)]
    folder = f"results/virheometry/{m}/diagnosis"
    jobs.append({"name": m, "script": "tolerant_diagnose.py",
                 "input": {"fit": f"results/virheometry/{m}/fit_bingham/params.json",
                           "setups": [f"results/virheometry/setups/{s}/setup.json" for s in setups],
                           "masks": [f"results/virheometry/setups/{s}/masks.npz" for s in setups],
                           "rheometer": config["virheometry"]["rheometer"].get(m, [])},
                 "output": {"diagnosis": f"{folder}/diagnosis.json", "maps": f"{folder}/maps.png",
                            "report": f"{folder}/report.html"},
                 "log": [f"logs/virheometry/{m}/diagnose.log"], "threads": int(sys.argv[1]),
                 "params": {"settings": config["diagnose"], "fit_settings": bingham, "simulation": held_out,
                            "title": f"{m}: what the Bingham model leaves out"}, "config": config})
json.dump(jobs, sys.stdout)
