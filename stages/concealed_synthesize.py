"""concealed_synthesize: the virtual lab films one concealed-effect dam break (its own particles and renderer)
and writes it as an imported setup, with the truth kept apart for scoring."""

import numpy as np

from rheo.experiments.concealed import concealed_truth, film
from rheo.io import write_atomic, write_json_atomic
from rheo.stage import setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
case = smk.params.case
law, effects = concealed_truth(case, {**smk.params.truth, **case.get("truth", {})})
mu, lam = smk.params.elastic
log.info("%s: %s at %s; law tau_y %.4g Pa, K %.4g Pa s, n %.3g", case["name"], case["effect"],
         case.get("magnitude"), law["tau_y"], law["K"], law["n"])
setup = film(smk.params.scene, smk.params.lab, case["name"], law, effects, mu, lam)
write_json_atomic(smk.output.setup, {**setup.record(), "units": "SI (m, kg/m^3, Pa, s)", "frames": len(setup.masks)})
write_atomic(smk.output.masks, lambda p: np.savez_compressed(p, masks=np.stack(setup.masks)))
write_json_atomic(smk.output.truth, {"effect": case["effect"], "magnitude": case.get("magnitude"),
                                     "tau_y_Pa": law["tau_y"], "K_Pa_s_n": law["K"], "n": law["n"]})
