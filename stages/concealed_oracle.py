"""concealed_oracle: the concealed truth (its law and effect) in the fit's own simulation, compared with the
recording: about the least loss any fit with the right effect can reach. Where the base fit already reaches below
it, the recording does not show the effect at the fit's resolution, and no diagnosis can name it."""

from rheo.experiments.concealed import concealed_truth
from rheo.fit.dam_break import setup_files, targets
from rheo.io import read_json, write_json_atomic
from rheo.stage import setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
truth = read_json(smk.input.truth)
target, = targets(setup_files([smk.input.setup], [smk.input.masks]), smk.params.simulation).values()
law, effects = concealed_truth(truth, {"tau_y": truth["tau_y_Pa"], "K": truth["K_Pa_s_n"]})  # as the lab filmed it
result = target.compare(law["tau_y"], law["K"], law["n"], effects)
log.info("the truth in the fit's simulation: loss %.4g px, held out %.4g px", result.loss, result.held_out_loss)
write_json_atomic(smk.output[0], {"loss_px": result.loss, "held_out_loss_px": result.held_out_loss})
