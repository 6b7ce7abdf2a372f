"""The concealed-effect benchmark's scores, from its cases' records (``summary.json``'s ``by_case``), and the targets
a blind suite is held to. As a command it scores a stored summary.json, one written by another version of the code
(a suite run from a frozen commit) included:

    python -m rheo.diagnose.scores results/concealed/summary.json
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rheo.config import workflow_settings
from rheo.io import write_json_atomic

HELD_OUT_GAIN = -30.0  # %: a held-out loss that falls at least this far counts as predicted better
LAST_FRAMES_GAIN = -1.0  # %: the real dam breaks' summary counts a refit this much better on the last frames
TOP1_SHOWN = 0.8  # the share of the cases whose recording shows the effect that must be named correctly


def modelled(record: dict, candidates: Sequence[str]) -> list[str]:
    """The case's concealed effects that one of ``candidates`` models, the dominant one first."""
    return [e["effect"] for e in record["concealed"] if e["effect"] in candidates]


def truth_label(record: dict, candidates: Sequence[str]) -> str:
    """The case's row of the confusion table: its dominant modelled effect, "outside" where it conceals only effects
    that no candidate models, "none" where it conceals nothing."""
    names = modelled(record, candidates)
    return names[0] if names else "outside" if record["concealed"] else "none"


def loss_change(before: float | None, after: float | None) -> float | None:
    """A refit's change (%) of a held-out loss (px), None where no frame was held out."""
    return None if not before or after is None else 100 * (after / before - 1)


def down(change_pct: float | None, gain: float = HELD_OUT_GAIN) -> bool:
    """Whether a loss' change (%) is a fall of at least ``gain`` (a negative %)."""
    return change_pct is not None and change_pct <= gain


def suite_scores(records: list[dict], candidates: Sequence[str]) -> dict:
    """Counts over the cases: with a modelled effect, null, outside; named correctly (top-1, also among the cases
    whose recording shows the effect: the base fit above the truth in the fit's simulation); wrong names (on a case
    with an effect, and false alarms on null and outside cases); of the cases where an effect is named, those whose
    held-out losses fell by at least 30 %; the core parameters' mean bias (%) before and after the refit and the
    cases it fell on; the open drag's fits; the diagnoses' runtime."""
    effect = [r for r in records if modelled(r, candidates)]
    others = [r for r in records if not modelled(r, candidates)]
    named = [r for r in records if r["named"] != "none"]
    bias = np.array([r["core_bias_pct"] for r in effect]).reshape(-1, 2)
    return {
        "cases": len(records), "with_effect": len(effect), "null": sum(not r["concealed"] for r in others),
        "outside": sum(bool(r["concealed"]) for r in others),
        "top1": sum(r["named"] in modelled(r, candidates) for r in effect),
        "shown": sum(bool(r["shown"]) for r in effect),
        "shown_named": sum(bool(r["shown"]) and r["named"] in modelled(r, candidates) for r in effect),
        "wrong_names": sum(r["named"] not in ("none", *modelled(r, candidates)) for r in effect),
        "false_alarms": sum(r["named"] != "none" for r in others),
        "named": len(named), "held_out_down_30pct": sum(down(r["held_out_change_pct"]) for r in named),
        "forecast_down_30pct": sum(down(r["forecast_change_pct"]) for r in named),
        "core_bias_mean_pct": bias.mean(axis=0).tolist() if len(bias) else None,
        "core_bias_reduced": int((bias[:, 1] < bias[:, 0]).sum()),
        "open_drag_fitted": sum(r["open_drag"] is not None for r in records),
        "open_drag_explains": sum(bool(r["open_drag"] and r["open_drag"]["explains"]) for r in records),
        "runtime_min": sum(r["runtime_min"] for r in records),
    }


def targets(scores: dict) -> list[tuple[str, str, bool | None]]:
    """Each target a blind suite is held to: what it asks, the measured figure, and whether it holds (None where no
    case bears on it)."""

    def share(hits: int, of: int, floor: float) -> tuple[str, bool | None]:
        return f"{hits} of {of}", (hits >= floor * of) if of else None

    bias = scores["core_bias_mean_pct"]
    return [
        (f"top-1 >= {TOP1_SHOWN:.0%} on the cases whose recording shows the effect",
         *share(scores["shown_named"], scores["shown"], TOP1_SHOWN)),
        ("no name on a null or out-of-library case",
         f"{scores['false_alarms']} of {scores['null'] + scores['outside']} named", scores["false_alarms"] == 0),
        ("held-out loss (between fitted frames) down >= 30 % where an effect is named",
         *share(scores["held_out_down_30pct"], scores["named"], 1.0)),
        ("the same on the last frames (a prediction)", *share(scores["forecast_down_30pct"], scores["named"], 1.0)),
        ("core parameters' mean bias reduced by the refit",
         "-" if bias is None else f"{bias[0]:.1f} % -> {bias[1]:.1f} %", None if bias is None else bias[1] < bias[0]),
    ]


def case_table(records: list[dict]) -> str:
    """The cases as a Markdown table: what each concealed, whether its recording shows it, what was named, the named
    refit's change of the held-out losses, the core parameters' bias before and after it (and the shear modulus, the
    fit's and the lab's, where the summary gives it)."""
    modulus = any("shear_modulus_Pa" in r for r in records)
    header = ["case", "concealed", "shown", "named", "held out", "last frames", "core bias (%)"]
    lines = [header + (["shear modulus, fit / lab (Pa)"] if modulus else [])]
    for r in records:
        change = ["-" if c is None else f"{c:+.0f} %" for c in (r["held_out_change_pct"], r["forecast_change_pct"])]
        row = [r["case"], ", ".join(f"{e['effect']} {e['magnitude']:g}" for e in r["concealed"]) or "none",
               "-" if r["shown"] is None else "yes" if r["shown"] else "no", r["named"], *change,
               "{:.1f} -> {:.1f}".format(*r["core_bias_pct"])]
        if modulus:
            row.append("-" if "shear_modulus_Pa" not in r else "{:.3g} / {:.3g}".format(*r["shear_modulus_Pa"]))
        lines.append(row)
    rows = ["| " + " | ".join(map(str, line)) + " |" for line in lines]
    return "\n".join([rows[0], "|" + "---|" * len(lines[0]), *rows[1:]])


def target_records(checked: list[tuple[str, str, bool | None]]) -> list[dict]:
    return [{"target": asked, "measured": figure, "met": holds} for asked, figure, holds in checked]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("summary", type=Path, help="a concealed benchmark's summary.json")
    parser.add_argument("--candidates", nargs="+", help="the diagnosis' candidates (default: the configuration's)")
    parser.add_argument("--out", type=Path, help="also write the scores and targets to this JSON file")
    args = parser.parse_args(argv)
    try:
        stored = json.loads(args.summary.read_text())
        records = stored["by_case"]
    except (OSError, ValueError, KeyError) as error:
        parser.error(f"{args.summary}: not a concealed benchmark's summary.json ({error})")
    candidates = args.candidates or stored.get("candidates") or workflow_settings()["diagnose"]["candidates"]
    scores = suite_scores(records, candidates)
    checked = targets(scores)
    print(f"{args.summary}: suite {stored.get('suite')}, code {stored.get('code_version')}")
    for asked, figure, holds in checked:
        print(f"  {'-' if holds is None else 'met' if holds else 'NOT met':8} {asked}: {figure}")
    print(case_table(records))
    if args.out:
        write_json_atomic(args.out, {"summary": str(args.summary), "suite": stored.get("suite"),
                                     "code_version": stored.get("code_version"), "scores": scores,
                                     "targets": target_records(checked)})


if __name__ == "__main__":
    main()
