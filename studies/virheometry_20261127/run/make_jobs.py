"""Job specs of the real materials' diagnoses (run in the run's checkout, PYTHONPATH=.): make_jobs.py DEVICE ITEM ...,
an item MATERIAL:CANDIDATE split by candidate (CANDIDATE "*": all), one process each; an item MATERIAL the whole
diagnosis under the tolerant replay (tolerant_diagnose.py) on all cores."""
import json
import sys

from job_specs import diagnosis_jobs, load_config

from rheo.experiments.virheometry import setup_folders

config = load_config(sys.argv[1], {"virheometry": {"single_setup_fits": []}})
bingham = {**config["virheometry"]["fit"], "flow_index": 1.0}
jobs = []
for item in sys.argv[2:]:
    m, _, which = item.partition(":")
    setups = [p.name for p in setup_folders(config["virheometry"]["data"], m)]
    inputs = {"fit": f"results/virheometry/{m}/fit_bingham/params.json",
              "setups": [f"results/virheometry/setups/{s}/setup.json" for s in setups],
              "masks": [f"results/virheometry/setups/{s}/masks.npz" for s in setups]}
    jobs += diagnosis_jobs(config, m, which, inputs, config["virheometry"]["rheometer"].get(m, []),
                           f"results/virheometry/{m}/diagnosis", f"logs/virheometry/{m}",
                           bingham, f"{m}: what the Bingham model leaves out")
json.dump(jobs, sys.stdout)
