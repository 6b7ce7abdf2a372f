"""Which rungs a rule that stops climbing would have skipped on the stored profiles: this study's two diagnoses (a
finished one's profiles from its diagnosis.json, an unfinished one's from its stored evaluations) and
``profile_ladder_20261205``'s three floor-friction profiles. The rule stops a ladder's branch once ``K`` rungs in a
row each lose more than ``R`` times the base fit's loss and ``R`` times the branch's best so far (the base loss of a
profile stored without the base fit: the effect's weak end). Run from the repository root: ``PYTHONPATH=. python
studies/diagnosis_ladder_20261205/run/stop_rules.py``."""

import json
import math
from collections import defaultdict
from pathlib import Path

from rheo.diagnose.candidates import CANDIDATES

STUDIES = Path(__file__).resolve().parents[2]
DIAGNOSES = [STUDIES / f"diagnosis_ladder_20261205/results/concealed/{case}/diagnosis" for case in ("ce1838040",
                                                                                            "c7fa1a139")]
STORES = [d / "diagnosis.evaluations.json" for d in DIAGNOSES if not (d / "diagnosis.json").is_file()]
STORES += [STUDIES / f"profile_ladder_20261205/{label}_floor_friction.evaluations.json"
           for label in ("ce1838040", "c54c71111", "Lotion")]


def rung_losses(path: Path) -> tuple[float | None, dict[str, dict[float, float]]]:
    """The base fit's loss (None if not stored) and each candidate's lowest loss by rung coordinate."""
    records = json.loads(path.read_text())["records"]
    base = next((r["loss"] for r in records if r["phase"] == "base"), None)
    losses: dict[str, dict[float, float]] = defaultdict(lambda: defaultdict(lambda: math.inf))
    for r in records:
        if r["phase"].startswith("refit "):
            rung = round(r["x"][-1], 6)
            losses[r["phase"][6:]][rung] = min(losses[r["phase"][6:]][rung], r["loss"])
    return base, losses


def profile_losses(path: Path) -> tuple[float, dict[str, dict[float, float]]]:
    """A finished diagnosis' base loss and each candidate's profile (loss by rung coordinate)."""
    record = json.loads(path.read_text())
    return record["base"]["loss_px"], {c["effect"]: {round(CANDIDATES[c["effect"]].coordinate(v), 6): loss
                                                     for v, loss in c["profile"]} for c in record["candidates"]}


def branches(name: str, losses: dict[float, float]) -> list[list[tuple[float, float]]]:
    """Each branch's climbed rungs in order, as (value, loss)."""
    candidate = CANDIDATES[name]
    return [[(v, losses[round(candidate.coordinate(v), 6)]) for v in branch
             if round(candidate.coordinate(v), 6) in losses] for branch in candidate.rungs]


profiles = []
sources = [(path, rung_losses(path)) for path in STORES]
sources += [(d / "diagnosis.json", profile_losses(d / "diagnosis.json")) for d in DIAGNOSES
            if (d / "diagnosis.json").is_file()]
for path, (base, losses) in sources:
    for name, by_rung in losses.items():
        reference = base if base is not None else by_rung[round(CANDIDATES[name].nearest_null, 6)]
        profiles += [(f"{path.parent.name}/{path.name}:{name}", reference, b) for b in branches(name, by_rung) if b]
for ratio in (1.5, 2.0, 3.0):
    for in_a_row in (1, 2):
        skipped, missed = 0, []
        for label, base, branch in profiles:
            best, run, stop = math.inf, 0, len(branch)
            for i, (_, loss) in enumerate(branch):
                best = min(best, loss)
                run = run + 1 if loss > ratio * base and loss > ratio * best else 0
                if run >= in_a_row:
                    stop = i + 1
                    break
            skipped += len(branch) - stop
            if min(range(len(branch)), key=lambda i: branch[i][1]) >= stop:
                missed.append(label)
        print(f"R {ratio}, K {in_a_row}: {skipped} of {sum(len(b) for *_, b in profiles)} rungs skipped; "
              f"branches whose best rung is skipped: {missed or 'none'}")
