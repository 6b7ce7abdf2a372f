"""concealed_synthesize: the virtual lab films one concealed-effect dam break in each of the scene's channels (its
own particles, account of the effects and renderer) and writes each as an imported setup under a label that says
nothing of the case, with the truth kept apart for scoring."""

import numpy as np

from rheo.experiments.concealed import anonymous, concealed_truth, film
from rheo.io import write_atomic, write_json_atomic
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
case, scene = smk.params.case, smk.params.scene
truth = concealed_truth(case, smk.params.truth)
mu, lam = (case["elastic"]["mu"], case["elastic"]["lam"]) if "elastic" in case else smk.params.elastic
release = case.get("release_s", 1.0 / scene["fps"])
effects = ", ".join(f"{e['effect']} {e['magnitude']:g}" for e in case["effects"]) or "no effect"
log.info("%s: %s; law tau_y %.4g Pa, K %.4g Pa s, n %.3g; mu %.4g, lam %.4g Pa; first frame %.4g s after the release",
         case["name"], effects, truth.law["tau_y"], truth.law["K"], truth.law["n"], mu, lam, release)
channels = case.get("channels", scene["setups"])
for index, (setup_path, masks_path, geometry) in enumerate(zip(smk.output.setups, smk.output.masks, channels,
                                                               strict=True), start=1):
    setup = film(scene, geometry, index, smk.params.lab, anonymous(case["name"]), truth, mu, lam, release)
    log.info("setup %d (%g m high, %g m long) filmed", index, setup.height, setup.width)
    write_json_atomic(setup_path, {**setup.record(), "units": "SI (m, kg/m^3, Pa, s)", "frames": len(setup.masks)})
    write_atomic(masks_path, lambda p, setup=setup: np.savez_compressed(p, masks=np.stack(setup.masks)))
names = [e["effect"] for e in case["effects"]]
write_json_atomic(smk.output.truth, {
    "effect": names[0] if names else "none", "magnitude": case["effects"][0]["magnitude"] if names else None,
    "effects": case["effects"], "tau_y_Pa": truth.law["tau_y"], "K_Pa_s_n": truth.law["K"], "n": truth.law["n"],
    "mu_Pa": mu, "lam_Pa": lam, "release_s": release})
