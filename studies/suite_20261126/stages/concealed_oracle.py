"""concealed_oracle: the concealed truth (its law, elastic constants and effects; not a miscalibrated camera, which
the simulation cannot hold) in the fit's own simulation, compared with the recordings (the mean over the setups, as the
fit's loss): about the least loss any fit with the right effects can reach. Where the base fit already reaches below
it, the recordings do not show the effect at the fit's resolution, and no diagnosis can name it."""

import numpy as np

from rheo.experiments.concealed import concealed_truth
from rheo.fit.dam_break import setup_files, targets
from rheo.io import read_json, write_json_atomic
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
truth = read_json(smk.input.truth)
filmed = concealed_truth({"effects": truth["effects"]}, {"tau_y": truth["tau_y_Pa"], "K": truth["K_Pa_s_n"]})
simulation = {**smk.params.simulation, "mu": truth["mu_Pa"], "lam": truth["lam_Pa"]}
law = filmed.law
results = {name: target.compare(law["tau_y"], law["K"], law["n"], filmed.effects)
           for name, target in targets(setup_files(smk.input.setups, smk.input.masks), simulation).items()}
for name, result in results.items():
    log.info("%s: the truth in the fit's simulation loses %.4g px, held out %.4g px between fitted frames and %.4g "
             "px on the last ones", name, result.loss, result.held_out_loss, result.forecast_loss)
write_json_atomic(smk.output[0], {
    "loss_px": float(np.mean([r.loss for r in results.values()])),
    "held_out_loss_px": float(np.mean([r.held_out_loss for r in results.values()])),
    "forecast_loss_px": float(np.mean([r.forecast_loss for r in results.values()])),
    "setups": {name: {"loss_px": r.loss, "held_out_loss_px": r.held_out_loss, "forecast_loss_px": r.forecast_loss}
               for name, r in results.items()}})
