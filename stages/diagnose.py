"""diagnose: what a dam-break fit leaves out. The base fit's mismatch located in time and space, every candidate
effect tried in a short refit and ranked by the information criterion, the winner refitted, the gain measured on
the frames held out of every fit; with rheometer curves, the flow-curve error of the base fit and of every refit."""

from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from rheo.diagnose.dam_break import diagnose
from rheo.experiments.rheometer import PARAMETER_KEYS, RESULT_KEYS, read_flow_curve
from rheo.fit.dam_break import setup_files
from rheo.fit.search import EvaluationLog
from rheo.io import evaluations_path, read_json, write_json_atomic, write_text_atomic
from rheo.report.diagnosis import maps_figure, section
from rheo.report.figures import save_figure
from rheo.report.html import page
from rheo.report.virheometry import rheometer_comparison
from rheo.stage import inputs_key, start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
setups = setup_files(smk.input.setups, smk.input.masks)
fit = read_json(smk.input.fit)
fitted = {name: fit[key] for name, key in PARAMETER_KEYS.items() if key in fit}  # the law, and mu where fitted
base_values = {name: p["value"] for name, p in fitted.items()}
base_intervals = {name: tuple(p["interval"]) for name, p in fitted.items()}
output = Path(smk.output.diagnosis)
settings = smk.params.settings
evaluations = EvaluationLog(evaluations_path(output),
                            inputs_key([settings, smk.params.fit_settings, smk.params.simulation],
                                       [smk.input.fit, *smk.input.setups, *smk.input.masks]))
bar = tqdm(desc=f"diagnose {output.parent.parent.name}", unit="evaluation")


def progress(law: str, x: np.ndarray, loss: float) -> None:
    bar.update()
    log.info("evaluation %d (%s): loss %.5g px at %s", bar.n, law, loss, np.round(x, 4).tolist())


result = diagnose(setups, smk.params.simulation, smk.params.fit_settings, settings, base_values, base_intervals,
                  evaluations, smk.threads, progress)
bar.close()
record = result.record()
record.update(evaluations.times())
log.info("verdict: %s", record["verdict"])
for name, words in ((n, m["words"]) for n, m in record["mismatch"].items()):
    log.info("%s: %s", name, words)

extra = ""
curves = [read_flow_curve(p) for p in getattr(smk.input, "rheometer", [])]
band = result.band
if curves and band is not None:
    refits = {"base fit": result.base, **{refit.name: refit for refit in result.candidates}, "open drag": result.open}
    laws = {label: tuple(result.values(refit)[k] for k in RESULT_KEYS.values())
            for label, refit in refits.items() if refit is not None}
    table, errors = rheometer_comparison(laws, curves, band)
    for name, error in errors.items():
        log.info("%s: RMS log10 error %s over %.3g-%.3g 1/s", name, error, *band)
    record["flow_curve_rms_log10"] = {"band_per_s": band, "by_curve": errors}
    extra = (f"<h3>Flow curve against the rheometer</h3><p>Every refit's law over the shear rates the base fit's "
             f"flow reaches ({band[0]:.3g}-{band[1]:.3g} 1/s).</p>{table}")

frames = {name: (np.load(files[1])["masks"], result.before[name].silhouettes,
                 None if result.chosen is None else result.after[name].silhouettes, result.before[name].fitted)
          for name, files in setups.items()}
save_figure(maps_figure(frames), smk.output.maps)
write_json_atomic(output, record)
body = f"<h2>What the model leaves out</h2>{section(record, Path(smk.output.maps).read_bytes(), extra)}"
write_text_atomic(smk.output.report, page(smk.params.title, body))
evaluations.path.unlink(missing_ok=True)
