"""concealed_summary: every concealed case's named effect against the concealed one (a confusion table), the gain
on held-out frames, the core parameters' bias before and after the refit, whether the recording shows the effect at
the fit's resolution at all (the base fit's loss against the truth's in the fit's simulation), and each diagnosis'
runtime; the scores against the targets a blind suite is held to (rheo.diagnose.scores), also as JSON (summary.json)
with the code version and, for a drawn suite, its seed."""

import numpy as np

from rheo.diagnose.candidates import CANDIDATES
from rheo.diagnose.scores import loss_change, modelled, suite_scores, target_records, targets, truth_label
from rheo.io import read_json, write_json_atomic, write_text_atomic
from rheo.report.diagnosis import confusion_section
from rheo.report.html import page, table_tag
from rheo.stage import code_version, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
candidates = smk.params.candidates
CORE = {"tau_y_Pa": "tau_y", "K_Pa_s_n": "K"}


def bias(values: dict, truth: dict) -> float:
    """Mean absolute relative error (%) of the core parameters."""
    return float(np.mean([abs(values[k] / truth[k] - 1) for k in CORE]) * 100)


def before_after(losses: list[float | None]) -> str:
    """Held-out losses before and after the refit (px) and their change, or "-" where no frame was held out."""
    return "-" if not losses[0] else f"{losses[0]:.3g} / {losses[1]:.3g} ({loss_change(*losses):+.0f} %)"


def open_drag(diagnosis: dict) -> str:
    """The open drag's answer where it was fitted: its change of the criterion, and where and when it acts if it
    explains part of the mismatch."""
    fitted = diagnosis["open"]
    if fitted is None:
        return "-"
    return f"{fitted['delta_criterion']:+.1f}" + (f": {fitted['words']}" if fitted["explains"] else "")


rows, records = [], []
for case, d_path, t_path, f_path, o_path in zip(smk.params.cases, smk.input.diagnoses, smk.input.truths,
                                                smk.input.fits, smk.input.oracles, strict=True):
    diagnosis, truth, fit, oracle = read_json(d_path), read_json(t_path), read_json(f_path), read_json(o_path)
    chosen = diagnosis["chosen"] or "none"
    base = {k: fit[k]["value"] for k in CORE}
    after = diagnosis["refit"]["values"] if diagnosis["refit"] else base
    held, last = (diagnosis["loss_before_after_px"][k] for k in ("held_out", "forecast"))
    best = diagnosis["candidates"][0] if diagnosis["candidates"] else None
    concealed = ", ".join(f"{e['effect']} {e['magnitude']:g}" for e in truth["effects"]) or "none"
    record = {"case": case, "concealed": truth["effects"], "named": chosen, "named_magnitude": diagnosis["magnitude"],
              "held_out_change_pct": loss_change(*held), "forecast_change_pct": loss_change(*last),
              "core_bias_pct": [bias(base, truth), bias(after, truth)],
              "open_drag": diagnosis["open"] and {k: diagnosis["open"][k]
                                                      for k in ("explains", "delta_criterion", "words")},
              "runtime_min": diagnosis["runtime_s"] / 60,
              "shear_modulus_Pa": [fit["elastic_constants_Pa"]["mu"], truth["mu_Pa"]]}  # the fit's, the lab's
    # the effect shows where the base fit cannot come as close to the recording as the truth itself does
    record["shown"] = bool(fit["loss_px"] > oracle["loss_px"]) if modelled(record, candidates) else None
    records.append(record)
    rows.append([case, concealed, chosen,
                 "-" if diagnosis["magnitude"] is None else f"{diagnosis['magnitude']:.3g}",
                 "-" if best is None else f"{best['effect']} {best['delta_criterion']:+.1f}",
                 before_after(held), before_after(last),
                 f"{bias(base, truth):.1f} / {bias(after, truth):.1f}",
                 open_drag(diagnosis), f"{fit['loss_px']:.3g} / {oracle['loss_px']:.3g}",
                 "{:.3g} / {:.3g}".format(*record["shear_modulus_Pa"]),
                 f"{diagnosis['runtime_s'] / 60:.1f}"])
    log.info("%s: concealed %s, named %s; held out between fitted frames %s, last frames %s; core bias %.1f -> %.1f "
             "%%", case, concealed, chosen, before_after(held), before_after(last), bias(base, truth),
             bias(after, truth))
scores = suite_scores(records, candidates)
checked = targets(scores)
truths, named = [truth_label(r, candidates) for r in records], [r["named"] for r in records]
labels = ["none", *[c for c in CANDIDATES if not CANDIDATES[c].decoy], *[c for c in CANDIDATES if CANDIDATES[c].decoy],
          "outside"]
labels = [label for label in labels if label in truths or label in named or label == "none"]
score = (f"<p>Top-1 correct: {scores['top1']} of {scores['with_effect']} cases with an effect; "
         f"{scores['shown_named']} of the {scores['shown']} whose recording shows the effect at the fit's resolution "
         f"(the base fit's loss above the truth's in the fit's own simulation). Wrong names: {scores['wrong_names']} "
         f"on cases with an effect, {scores['false_alarms']} on the {scores['null']} null cases and the "
         f"{scores['outside']} whose effect no candidate models. Where nothing was named, the open drag explained part "
         f"of the mismatch in {scores['open_drag_explains']} of {scores['open_drag_fitted']} cases.</p>"
         + table_tag(["target", "measured", "met"],
                     [[a, f, "-" if h is None else "yes" if h else "no"] for a, f, h in checked]))
for asked, figure, holds in checked:
    log.info("%s: %s (%s)", asked, figure, "-" if holds is None else "met" if holds else "not met")
table = table_tag(["case", "concealed effects", "named", "fitted magnitude", "best candidate (criterion)",
                   "held out between fitted frames, before / after (px)",
                   "last frames (a prediction), before / after (px)", "core bias before / after (%)",
                   "open drag (criterion): where and when it acts",
                   "base fit / truth in the fit's simulation (px)", "shear modulus, fit / lab (Pa)",
                   "diagnosis (min)"], rows)
body = (f"<h2>Confusion table</h2>{score}{confusion_section(truths, named, labels)}"
        f"<h2>Cases</h2>{table}<p>Each case's page: results/concealed/&lt;case&gt;/diagnosis/report.html.</p>")
write_text_atomic(smk.output.html, page("Concealed effects: what the diagnosis names", body))
write_json_atomic(smk.output.scores, {"code_version": code_version(), "suite": smk.params.suite,
                                     "candidates": candidates, **scores, "targets": target_records(checked),
                                     "by_case": records})
