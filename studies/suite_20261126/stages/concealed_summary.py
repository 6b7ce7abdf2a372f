"""concealed_summary: every concealed case's named effect against the concealed one (a confusion table), the gain
on held-out frames, the core parameters' bias before and after the refit, whether the recording shows the effect at
the fit's resolution at all (the base fit's loss against the truth's in the fit's simulation), and each diagnosis'
runtime; the scores also as JSON (summary.json) with the code version and, for a drawn suite, its seed."""

import numpy as np

from rheo.diagnose.candidates import CANDIDATES
from rheo.io import json_number, read_json, write_json_atomic, write_text_atomic
from rheo.report.diagnosis import confusion_section
from rheo.report.html import page, table_tag
from rheo.stage import code_version, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
CORE = {"tau_y_Pa": "tau_y", "K_Pa_s_n": "K"}


def bias(values: dict, truth: dict) -> float:
    """Mean absolute relative error (%) of the core parameters."""
    return float(np.mean([abs(values[k] / truth[k] - 1) for k in CORE]) * 100)


def change(losses: list[float | None]) -> float:
    """The refit's change (%) of a held-out loss (before, after; px), nan where no frame was held out."""
    before, after = losses
    return 100 * (after / before - 1) if before else float("nan")


def before_after(losses: list[float | None]) -> str:
    """Held-out losses before and after the refit (px) and their change, or "-" where no frame was held out."""
    return "-" if not losses[0] else f"{losses[0]:.3g} / {losses[1]:.3g} ({change(losses):+.0f} %)"


def open_drag(diagnosis: dict) -> str:
    """The open drag's answer where it was fitted: its change of the criterion, and where and when it acts if it
    explains part of the mismatch."""
    fitted = diagnosis["open"]
    if fitted is None:
        return "-"
    return f"{fitted['delta_criterion']:+.1f}" + (f": {fitted['words']}" if fitted["explains"] else "")


rows, truths, named, records = [], [], [], []
hits = effects = null_ok = nulls = outside = outside_ok = held_ok = last_ok = reduced = shown = shown_hits = 0
opened = open_explains = 0
for case, d_path, t_path, f_path, o_path in zip(smk.params.cases, smk.input.diagnoses, smk.input.truths,
                                                smk.input.fits, smk.input.oracles, strict=True):
    diagnosis, truth, fit, oracle = read_json(d_path), read_json(t_path), read_json(f_path), read_json(o_path)
    names, chosen = [e["effect"] for e in truth["effects"]], diagnosis["chosen"] or "none"
    modelled = [n for n in names if n in smk.params.candidates]
    # the confusion table's row: the first (dominant) effect a candidate of the diagnosis models; "outside" where
    # none does
    true = modelled[0] if modelled else "outside" if names else "none"
    truths.append(true)
    named.append(chosen)
    base = {k: fit[k]["value"] for k in CORE}
    after = diagnosis["refit"]["values"] if diagnosis["refit"] else base
    held, last = (diagnosis["loss_before_after_px"][k] for k in ("held_out", "forecast"))
    if not modelled:  # nothing to name: no effect, or one that no candidate models
        nulls += not names
        outside += bool(names)
        null_ok += chosen == "none" and not names
        outside_ok += chosen == "none" and bool(names)
    else:
        effects += 1
        hits += chosen in modelled
        # the effect shows where the base fit cannot come as close to the recording as the truth itself does
        visible = fit["loss_px"] > oracle["loss_px"]
        shown += visible
        shown_hits += visible and chosen in modelled
        held_ok += change(held) <= -30
        last_ok += change(last) <= -30
        reduced += bias(after, truth) < bias(base, truth)
    best = diagnosis["candidates"][0] if diagnosis["candidates"] else None
    opened += diagnosis["open"] is not None
    open_explains += bool(diagnosis["open"] and diagnosis["open"]["explains"])
    concealed = ", ".join(f"{e['effect']} {e['magnitude']:g}" for e in truth["effects"]) or "none"
    records.append({"case": case, "concealed": truth["effects"], "named": chosen,
                    "named_magnitude": diagnosis["magnitude"],
                    "held_out_change_pct": json_number(change(held)), "forecast_change_pct": json_number(change(last)),
                    "core_bias_pct": [bias(base, truth), bias(after, truth)],
                    "shown": bool(fit["loss_px"] > oracle["loss_px"]) if modelled else None,
                    "open_drag": diagnosis["open"] and {k: diagnosis["open"][k]
                                                            for k in ("explains", "delta_criterion", "words")},
                    "runtime_min": diagnosis["runtime_s"] / 60})
    rows.append([case, concealed, chosen,
                 "-" if diagnosis["magnitude"] is None else f"{diagnosis['magnitude']:.3g}",
                 "-" if best is None else f"{best['effect']} {best['delta_criterion']:+.1f}",
                 before_after(held), before_after(last),
                 f"{bias(base, truth):.1f} / {bias(after, truth):.1f}",
                 open_drag(diagnosis), f"{fit['loss_px']:.3g} / {oracle['loss_px']:.3g}",
                 f"{diagnosis['runtime_s'] / 60:.1f}"])
    log.info("%s: concealed %s, named %s; held out between fitted frames %s, last frames %s; core bias %.1f -> %.1f "
             "%%", case, concealed, chosen, before_after(held), before_after(last), bias(base, truth),
             bias(after, truth))
labels = ["none", *[c for c in CANDIDATES if not CANDIDATES[c].decoy], *[c for c in CANDIDATES if CANDIDATES[c].decoy],
          "outside"]
labels = [label for label in labels if label in truths or label in named or label == "none"]
score = (f"<p>Top-1 correct: {hits} of {effects} cases with an effect ({100 * hits / max(effects, 1):.0f} %); "
         f"nothing named: {null_ok} of {nulls} null cases and {outside_ok} of {outside} cases whose effect no "
         f"candidate models; loss down by at least 30 % on the frames held out between "
         f"fitted ones: {held_ok} of {effects}, on the last frames (a prediction): {last_ok} of {effects}; core "
         f"parameters' bias (tau_y, K) reduced by the refit: {reduced} of {effects}. "
         f"The recording shows the effect at the fit's resolution (the base fit's loss above the truth's in the "
         f"fit's own simulation) in {shown} of {effects} cases; of those, {shown_hits} named correctly. Where "
         f"nothing was named, the open drag explained part of the mismatch in {open_explains} of {opened} cases.</p>")
log.info("top-1 %d/%d, nulls %d/%d, outside %d/%d, held out >= 30 %% down %d/%d (last frames %d/%d), bias reduced "
         "%d/%d", hits, effects, null_ok, nulls, outside_ok, outside, held_ok, effects, last_ok, effects, reduced,
         effects)
table = table_tag(["case", "concealed effects", "named", "fitted magnitude", "best candidate (criterion)",
                   "held out between fitted frames, before / after (px)",
                   "last frames (a prediction), before / after (px)", "core bias before / after (%)",
                   "open drag (criterion): where and when it acts",
                   "base fit / truth in the fit's simulation (px)", "diagnosis (min)"], rows)
body = (f"<h2>Confusion table</h2>{score}{confusion_section(truths, named, labels)}"
        f"<h2>Cases</h2>{table}<p>Each case's page: results/concealed/&lt;case&gt;/diagnosis/report.html.</p>")
write_text_atomic(smk.output.html, page("Concealed effects: what the diagnosis names", body))
write_json_atomic(smk.output.scores, {
    "code_version": code_version(), "suite": smk.params.suite, "cases": len(records), "with_effect": effects,
    "null": nulls, "outside": outside, "top1": hits, "false_alarms": nulls - null_ok + outside - outside_ok,
    "held_out_down_30pct": held_ok, "forecast_down_30pct": last_ok,
    "core_bias_reduced": reduced, "shown": shown, "shown_named": shown_hits, "open_drag_fitted": opened,
    "open_drag_explains": open_explains,
    "runtime_min": sum(r["runtime_min"] for r in records), "by_case": records})
