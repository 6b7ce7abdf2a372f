"""virheometry_report: one material's page: the recovered law with its intervals, the recorded and simulated
frames, the flow curve (against the rheometer's curves where there are some, with the RMS of log10 of their ratio
over the shear rates the flow reached), the intervals of each setup alone beside the joint fit's, the camera checks."""

from pathlib import Path

import numpy as np

from rheo.experiments.rheometer import PARAMETER_KEYS, RESULT_KEYS, read_flow_curve
from rheo.fit.uncertainty import Interval, log_draws, tolerance_level
from rheo.io import read_json, write_text_atomic
from rheo.report.fit import headline, interval_text
from rheo.report.html import figure_tag, image_tag, page, table_tag
from rheo.report.virheometry import determined_stress_text, flow_figure, flow_index_profile_figure, rheometer_comparison
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
material = smk.wildcards.material
params = read_json(smk.input.params)
KEYS = dict(zip(RESULT_KEYS.values(), ("tau_y (Pa)", "K (Pa s^n)", "n"), strict=True))
# the law's rows, and the shear modulus' where the fit searched it
FITTED = KEYS | ({PARAMETER_KEYS["mu"]: "shear modulus mu (Pa)"} if PARAMETER_KEYS["mu"] in params else {})


def law_rows(fit: dict) -> list[list[str]]:
    return [[label, f"{fit[key]['value']:.4g}", interval_text(fit[key]),
             "yes" if fit[key]["determined"] else "no"] for key, label in FITTED.items()]


def spread_text(fit: dict) -> str:
    spread = fit["within_tolerance"]
    ranges = ", ".join(f"{label} {spread[key][0]:.3g}-{spread[key][1]:.3g}" for key, label in FITTED.items())
    verdict = ("the recordings leave the law on a ridge: materials far apart fit them equally well"
               if spread["ridge"] else "no ridge")
    alone = "; one setup only" if len(fit["setups"]) == 1 else ""
    if spread["evaluations"] == 1:
        return f"Of the evaluated materials only the best lies within the tolerance ({verdict}{alone})"
    return f"{spread['evaluations']} evaluated materials within the tolerance: {ranges} ({verdict}{alone})"


band = params["shear_rate_band_per_s"]
reached = "none: nothing moved" if band is None else f"{band[0]:.3g}-{band[1]:.3g} 1/s"
curves = [read_flow_curve(p) for p in smk.input.rheometer]
law = tuple(params[k]["value"] for k in KEYS)
# the band: curves of materials drawn within the tolerance intervals, as on an experiment's report
draws = np.exp(log_draws([Interval(params[k]["value"], *params[k]["interval"]) for k in KEYS]))
comparison = ""
if curves and band is not None:
    comparison, errors = rheometer_comparison({"recovered": law}, curves, band)
    for name, error in errors.items():
        log.info("%s: RMS log10 error %.3f over %.3g-%.3g 1/s", name, error["recovered"], *band)
flow = flow_figure(law, draws, band, curves)
flow.savefig(smk.output.flow_curve, dpi=110, bbox_inches="tight")
pinned = determined_stress_text(params, curves)
pinned = "" if pinned is None else f" Where their flow curves agree best over the shear rates reached: {pinned}."
headline_text = headline({name: params[key] for name, key in RESULT_KEYS.items()}, subject="recordings")
sections = [("Flow curve", figure_tag(flow, "recovered law, shear stress (Pa) against shear rate (1/s); band: the "
                                            "middle 95 % of the curves of materials drawn within the tolerance "
                                            "intervals (coverage not calibrated)"
                                            + ("; the rheometer's curves where there are some" if curves else ""))
             + comparison),
            ("Recovered law", table_tag(["parameter", "value", "tolerance interval", "determined"], law_rows(params))
             + f"<p>Each interval spans the region where a quadratic surface fitted to the losses around the "
             f"estimate stays within the tolerance ({params['tolerance']:.0%}) of its lowest, the parameters' "
             f"trade-offs included, and the evaluated materials within the tolerance of the best (n's also where "
             f"its profile stays within it, below); an end marked &lt; or &gt; is open (the region goes on past the "
             f"evaluations' reach). {spread_text(params)}.{pinned}</p>"
             + f"<p>Shear rates reached (5th-95th percentile of the moving particles): {reached}. "
             f"Elastic constants: mu {params['elastic_constants_Pa']['mu']:.3g} Pa "
             f"({'fitted' if PARAMETER_KEYS['mu'] in params else 'held'}), lam "
             f"{params['elastic_constants_Pa']['lam']:.3g} Pa (held). Runtime {params['runtime_s'] / 60:.1f} min.</p>"),
            ("Setups", table_tag(["setup", "first frame after release (s)", "loss (px)", "mean IoU",
                                  "mean IoU outside the container"],
                                 [[name, f"{s['first_frame_after_release_s']:.4f}", f"{s['loss_px']:.3g}",
                                   f"{np.mean(s['silhouette_iou']):.3f}", f"{np.mean(s['outflow_iou']):.3f}"]
                                  for name, s in params["setups"].items()])
             + image_tag(Path(smk.input.frames).read_bytes(), "png", "recorded and simulated silhouettes"))]
profile = params.get("flow_index_profile")
if profile and len(profile["n"]) > 1:
    level = tolerance_level(params["loss_px"], params["tolerance"])
    seen = [f"{n:.2g}" for n, loss in zip(profile["n"], profile["loss_px"], strict=True) if loss <= level]
    figure = flow_index_profile_figure(profile, level, params["n"]["interval"], band, curves)
    against_rheometer = ""
    if curves and band is not None:  # how far each of the laws the profile found lies from the rheometer's curves
        laws = {f"n {n:.2g}": (tau_y, K, n) for tau_y, K, n in zip(profile["tau_y_Pa"], profile["K_Pa_s_n"],
                                                                   profile["n"], strict=True)}
        against_rheometer = rheometer_comparison(laws, curves, band)[0]
    sections.insert(2, ("Flow index", figure_tag(figure, "left: the lowest loss found at each searched flow index, "
                                                         "tau_y and K searched at each; right: those laws' flow curves "
                                                         "(dotted: beyond the tolerance)")
                        + f"<p>Within the tolerance of the best: {'n ' + ', '.join(seen) if seen else 'none'} of the "
                        f"{len(profile['n'])} searched. n's interval reaches over where the profile, taken linear in "
                        f"log n between them, stays within it.</p>" + against_rheometer))
if smk.input.single:
    header = ["fit", *[f"{label} tolerance interval (width, factor)" for label in KEYS.values()],
              "evaluated materials within the tolerance"]
    rows = []
    for path in [*smk.input.single, smk.input.params]:
        fit = read_json(path)
        widths = [f"{interval_text(fit[k])} ({fit[k]['interval'][1] / fit[k]['interval'][0]:.2f})" for k in KEYS]
        rows.append([Path(path).parent.name, *widths, spread_text(fit)])
    sections.append(("One setup against both", table_tag(header, rows)))
sections.append(("Camera checks", "".join(image_tag(Path(p).read_bytes(), "png", Path(p).parent.name)
                                          for p in smk.input.camera_checks)))
body = headline_text + "".join(f"<h2>{title}</h2>{content}" for title, content in sections)
write_text_atomic(smk.output.report, page(f"{material}: Herschel-Bulkley law from dam breaks", body))
