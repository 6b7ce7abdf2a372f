"""Job specs of the suite's base fits and diagnoses (run in the run's checkout, PYTHONPATH=., with the scripts of
../../virheometry_20261127/run beside it): make_jobs.py DEVICE ITEM ..., an item CASE:fit the case's base fit,
CASE:CANDIDATE (CANDIDATE "*": all) its diagnosis split by candidate, one process each, after the fit where that is
in the same file; an item CASE the whole diagnosis under the tolerant replay (tolerant_diagnose.py) on all cores."""
import json
import sys

from job_specs import diagnosis_jobs, held_out_simulation, load_config

config = load_config(sys.argv[1], {"concealed": {"cases": "config/experiments/suite_20261126"}})
bingham = {**config["concealed"]["fit"], "flow_index": 1.0}
channels = range(1, len(config["concealed"]["scene"]["setups"]) + 1)
jobs = []
for item in sys.argv[2:]:
    case, _, which = item.partition(":")
    folder = f"results/concealed/{case}"
    recordings = {"setups": [f"{folder}/recording/{k}/setup.json" for k in channels],
                  "masks": [f"{folder}/recording/{k}/masks.npz" for k in channels]}
    if which == "fit":
        jobs.append({"name": f"{case}.fit", "script": "stages/virheometry_fit.py", "input": recordings,
                     "output": {"params": f"{folder}/fit/params.json", "history": f"{folder}/fit/history.csv",
                                "frames": f"{folder}/fit/frames.png"},
                     "log": [f"logs/concealed/{case}/fit.log"], "threads": 1,
                     "params": {"simulation": held_out_simulation(config), "settings": bingham}, "config": config})
    else:
        jobs += diagnosis_jobs(config, case, which, {"fit": f"{folder}/fit/params.json", **recordings}, None,
                               f"{folder}/diagnosis", f"logs/concealed/{case}", bingham,
                               f"concealed case {case}: what the Bingham model leaves out", after=f"{case}.fit")
json.dump(jobs, sys.stdout)
