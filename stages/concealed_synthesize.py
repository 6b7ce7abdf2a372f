"""concealed_synthesize: the virtual lab films one concealed-effect dam break in each of the scene's channels (its
own particles and renderer) and writes each as an imported setup, with the truth kept apart for scoring."""

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
for index, (setup_path, masks_path) in enumerate(zip(smk.output.setups, smk.output.masks, strict=True), start=1):
    setup = film(smk.params.scene, index, smk.params.lab, case["name"], law, effects, mu, lam)
    log.info("setup %d (%g m high, %g m long) filmed", index, setup.height, setup.width)
    write_json_atomic(setup_path, {**setup.record(), "units": "SI (m, kg/m^3, Pa, s)", "frames": len(setup.masks)})
    write_atomic(masks_path, lambda p, setup=setup: np.savez_compressed(p, masks=np.stack(setup.masks)))
write_json_atomic(smk.output.truth, {"effect": case["effect"], "magnitude": case.get("magnitude"),
                                     "tau_y_Pa": law["tau_y"], "K_Pa_s_n": law["K"], "n": law["n"]})
