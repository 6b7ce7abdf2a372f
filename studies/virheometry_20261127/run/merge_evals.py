"""Merge a diagnosis' per-candidate evaluation logs into its shared log: merge_evals.py FOLDER ... (each a diagnosis
folder holding diagnosis.evaluations.json and <candidate>.evaluations.json files). Same key required; records are
united by phase and point (where two machines evaluated one point, the shared log's record stays and the loss
difference is printed); seconds: the shared log's plus each candidate log's own additional seconds."""
import json
import sys
from pathlib import Path


def point(r):
    return r["phase"] + ":" + ",".join(f"{v:.12g}" for v in r["x"])

for folder in map(Path, sys.argv[1:]):
    shared_path = folder / "diagnosis.evaluations.json"
    logs = sorted(f for f in folder.glob("*.evaluations.json") if f != shared_path)
    if shared_path.is_file():
        shared = json.loads(shared_path.read_text())
    else:  # a diagnosis begun split by candidate
        shared = {"key": json.loads(logs[0].read_text())["key"], "records": [], "seconds": 0.0}
    base_seconds = shared.get("base_seconds", shared["seconds"])
    index = {point(r): r for r in shared["records"]}
    records = list(shared["records"])
    extra = 0.0
    differences = []
    for f in logs:
        d = json.loads(f.read_text())
        assert d["key"] == shared["key"], f
        extra += max(d["seconds"] - d.get("base_seconds", base_seconds), 0.0)
        for r in d["records"]:
            k = point(r)
            if k in index:
                if index[k]["loss"] != r["loss"]:
                    differences.append(abs(index[k]["loss"] - r["loss"]) / abs(index[k]["loss"]))
            else:
                index[k] = r
                records.append(r)
    added = len(records) - len(shared["records"])
    out = {"key": shared["key"], "records": records, "seconds": base_seconds + extra, "base_seconds": base_seconds}
    tmp = shared_path.with_suffix(".tmp")
    tmp.write_text(json.dumps(out))
    tmp.replace(shared_path)
    print(folder, len(records), f"+{added}", f"{len(differences)} evaluated twice apart, losses up to"
          f" {max(differences, default=0.0):.1e} apart (relative)")
