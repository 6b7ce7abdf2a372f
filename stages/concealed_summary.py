"""concealed_summary: every concealed case's named effect against the concealed one (a confusion table), the gain
on held-out frames, the core parameters' bias before and after the refit, whether the recording shows the effect at
the fit's resolution at all (the base fit's loss against the truth's in the fit's simulation), and each diagnosis'
runtime."""

import numpy as np

from rheo.diagnose.candidates import CANDIDATES
from rheo.io import read_json, write_text_atomic
from rheo.report.diagnosis import confusion_section
from rheo.report.html import page, table_tag
from rheo.stage import setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
CORE = {"tau_y_Pa": "tau_y", "K_Pa_s_n": "K"}


def bias(values: dict, truth: dict) -> float:
    """Mean absolute relative error (%) of the core parameters."""
    return float(np.mean([abs(values[k] / truth[k] - 1) for k in CORE]) * 100)


rows, truths, named = [], [], []
hits = effects = null_ok = nulls = held_ok = reduced = shown = shown_hits = 0
for case, d_path, t_path, f_path, o_path in zip(smk.params.cases, smk.input.diagnoses, smk.input.truths,
                                                smk.input.fits, smk.input.oracles, strict=True):
    diagnosis, truth, fit, oracle = read_json(d_path), read_json(t_path), read_json(f_path), read_json(o_path)
    true, chosen = truth["effect"], diagnosis["chosen"] or "none"
    truths.append(true)
    named.append(chosen)
    base = {k: fit[k]["value"] for k in CORE}
    after = diagnosis["refit"]["values"] if diagnosis["refit"] else base
    held_before, held_after = diagnosis["loss_before_after_px"]["held_out"]
    change = 100 * (held_after / held_before - 1) if held_before else float("nan")
    if true == "none":
        nulls += 1
        null_ok += chosen == "none"
    else:
        effects += 1
        hits += chosen == true
        # the effect shows where the base fit cannot come as close to the recording as the truth itself does
        visible = fit["loss_px"] > oracle["loss_px"]
        shown += visible
        shown_hits += visible and chosen == true
        held_ok += change <= -30
        reduced += bias(after, truth) < bias(base, truth)
    best = diagnosis["candidates"][0] if diagnosis["candidates"] else None
    rows.append([case, true, "-" if truth["magnitude"] is None else f"{truth['magnitude']:g}", chosen,
                 "-" if diagnosis["magnitude"] is None else f"{diagnosis['magnitude']:.3g}",
                 "-" if best is None else f"{best['effect']} {best['delta_criterion']:+.1f}",
                 f"{held_before:.3g} / {held_after:.3g} ({change:+.0f} %)",
                 f"{bias(base, truth):.1f} / {bias(after, truth):.1f}",
                 f"{fit['loss_px']:.3g} / {oracle['loss_px']:.3g}", f"{diagnosis['runtime_s'] / 60:.1f}"])
    log.info("%s: concealed %s, named %s; held-out %.3g -> %.3g px; core bias %.1f -> %.1f %%", case, true, chosen,
             held_before, held_after, bias(base, truth), bias(after, truth))
labels = ["none", *[c for c in CANDIDATES if not CANDIDATES[c].decoy], *[c for c in CANDIDATES if CANDIDATES[c].decoy]]
labels = [label for label in labels if label in truths or label in named or label == "none"]
score = (f"<p>Top-1 correct: {hits} of {effects} cases with an effect ({100 * hits / max(effects, 1):.0f} %); "
         f"nothing named: {null_ok} of {nulls} null cases; held-out loss down by at least 30 %: {held_ok} of "
         f"{effects}; core parameters' bias (tau_y, K) reduced by the refit: {reduced} of {effects}. "
         f"The recording shows the effect at the fit's resolution (the base fit's loss above the truth's in the "
         f"fit's own simulation) in {shown} of {effects} cases; of those, {shown_hits} named correctly.</p>")
log.info("top-1 %d/%d, nulls %d/%d, held-out >= 30 %% down %d/%d, bias reduced %d/%d", hits, effects, null_ok, nulls,
         held_ok, effects, reduced, effects)
table = table_tag(["case", "concealed effect", "magnitude", "named", "fitted magnitude", "best candidate (criterion)",
                   "held-out loss before / after (px)", "core bias before / after (%)",
                   "base fit / truth in the fit's simulation (px)", "diagnosis (min)"], rows)
body = (f"<h2>Confusion table</h2>{score}{confusion_section(truths, named, labels)}"
        f"<h2>Cases</h2>{table}<p>Each case's page: results/concealed/&lt;case&gt;/diagnosis/report.html.</p>")
write_text_atomic(smk.output[0], page("Concealed effects: what the diagnosis names", body))
