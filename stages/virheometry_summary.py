"""virheometry_summary: every material's recovered law in one table (values, intervals, IoU, shear-rate band, error
against its rheometer's curves where there are some, the stress its laws within the tolerance agree on best,
runtime), what its diagnosis found the Bingham model leaves out and what each candidate effect did to the law (where
the rule gives the diagnoses), and one plot of all flow curves, with a link to each material's page."""

from pathlib import Path

import numpy as np

from rheo.experiments.rheometer import RESULT_KEYS, fitted_law, read_flow_curve
from rheo.io import read_json, write_text_atomic
from rheo.report.fit import interval_text
from rheo.report.html import figure_tag, link_tag, page, table_tag
from rheo.report.virheometry import candidates_table, determined_stress_text, rheometer_comparison, summary_figure
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
KEYS = tuple(RESULT_KEYS.values())
output = Path(smk.output[0])


def diagnosis_cells(diagnosis: dict) -> list[str]:
    """The verdict; the held-out losses (between fitted frames; the last frames) of the base fit and the refit; the
    refit's error against the rheometer's curves; the diagnosis' runtime."""
    losses = diagnosis["loss_before_after_px"]
    held = "; ".join("-" if before is None else f"{before:.3g}" if after == before else f"{before:.3g} / {after:.3g}"
                     for before, after in (losses["held_out"], losses["forecast"]))
    by_curve = diagnosis.get("flow_curve_rms_log10", {}).get("by_curve", {})
    refit = ", ".join(f"{e[diagnosis['chosen']]:.3f}" for e in by_curve.values() if diagnosis["chosen"] in e) or "-"
    return [diagnosis["verdict"], held, refit, f"{diagnosis['runtime_s'] / 60:.0f}"]


diagnoses = list(getattr(smk.input, "diagnoses", []))
rows, laws, links, diagnosis_links, records, rheometer = [], {}, [], [], {}, {}
for material, path, report, diagnosis in zip(smk.params.materials, smk.input.params, smk.input.reports,
                                             diagnoses or [None] * len(smk.params.materials), strict=True):
    fit = read_json(path)
    cells = [material]
    for key in KEYS:
        p = fit[key]
        cells.append(f"{p['value']:.3g} {interval_text(p)}" + ("" if p["determined"] else " *"))
    cells.append(", ".join(f"{np.mean(s['silhouette_iou']):.3f}" for s in fit["setups"].values()))
    band = fit["shear_rate_band_per_s"]
    law = fitted_law(fit)
    curves = rheometer[material] = [read_flow_curve(p) for p in smk.params.rheometer[material]]
    errors = rheometer_comparison({"fit": law}, curves, band)[1] if curves and band is not None else {}
    for name, error in errors.items():
        log.info("%s against %s: RMS log10 error %.3f", material, name, error["fit"])
    cells += ["none" if band is None else f"{band[0]:.2g}-{band[1]:.2g}",
              ", ".join(f"{e['fit']:.3f}" for e in errors.values()) or "-",
              determined_stress_text(fit, curves) or "-",
              "yes" if fit["within_tolerance"]["ridge"] else "no", f"{fit['runtime_s'] / 60:.1f}"]
    if diagnosis is not None:
        records[material] = read_json(diagnosis)
        cells += diagnosis_cells(records[material])
        diagnosis_links.append(link_tag(str((Path(diagnosis).parent / "report.html").relative_to(output.parent)),
                                        material))
    rows.append(cells)
    laws[material] = (law, None if band is None else tuple(band))
    links.append(link_tag(str(Path(report).relative_to(output.parent)), material))
header = ["material", "tau_y (Pa) [tolerance]", "K (Pa s^n) [tolerance]", "n [tolerance]", "mean IoU per setup",
          "shear rates reached (1/s)", "RMS log10(stress / rheometer's) over them, per curve",
          "the stress the laws within the tolerance agree on best", "ridge",
          "runtime (min, on the machines that ran its evaluations)"]
if diagnoses:
    header += ["diagnosis: what the Bingham model leaves out",
               "held-out loss (px) between fitted frames; last frames, base fit / refit",
               "the refit's RMS log10 against the rheometer, per curve",
               "diagnosis (min, on the machines that ran its evaluations)"]
candidates_section = "" if not records else (
    "<h2>What each candidate effect did</h2><p>Each cell: the change of the information criterion from the base fit "
    f"(an effect is named where it falls by more than {next(iter(records.values()))['evidence']:g}), the change "
    "of the held-out losses (frames between the fitted ones; the last frames, predicted), the refit's flow index "
    "and, where there are rheometer curves, its largest RMS log10 error against them. The last row counts the "
    "materials whose last frames each refit predicts 1 % better than the base fit or more.</p>"
    + candidates_table(records, rheometer))
body = (table_tag(header, rows)
        + "<p>* not determined by the recordings (tolerance interval wider than a factor 4, for n 1.5, or open: < or "
          ">, the materials within the tolerance go on past the fit's reach). Ridge: the evaluated "
          "materials within the tolerance spread over a factor 4 or more in some parameter.</p>"
        + figure_tag(summary_figure(laws), "recovered flow curves")
        + candidates_section
        + f"<p>Each material's page (frames side by side, flow curve, camera checks): {', '.join(links)}"
        + (f"; its diagnosis: {', '.join(diagnosis_links)}" if diagnoses else "") + ".</p>")
write_text_atomic(output, page("Real dam breaks: twelve materials", body))
