"""Pick the elastic constants that best reproduce thesis Table 4.1 (RMS relative height difference)."""

import math
from collections import defaultdict

from rheo.io import read_json, write_json_atomic
from rheo.stage import setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
thesis = {float(k): v for k, v in smk.params.setup["table_4_1"]["rows"].items()}
errors = defaultdict(list)
lams = {}
for path in smk.input:
    run = read_json(path)
    errors[run["mu"]].append((run["height"] - thesis[run["sigma_y"]]) / thesis[run["sigma_y"]])
    lams[run["mu"]] = run["lam"]
rms = {mu: math.sqrt(sum(e * e for e in errs) / len(errs)) for mu, errs in errors.items()}
for mu in sorted(rms):
    log.info("mu=%g: RMS relative difference on Table 4.1 = %.3f", mu, rms[mu])
best = min(rms, key=rms.get)
log.info("calibrated: mu=%g lam=%g", best, lams[best])
write_json_atomic(smk.output[0], {"mu": best, "lam": lams[best], "rms_relative_difference": rms[best],
                                  "candidates": [{"mu": m, "lam": lams[m], "rms_relative_difference": rms[m]}
                                                 for m in sorted(rms)]})
