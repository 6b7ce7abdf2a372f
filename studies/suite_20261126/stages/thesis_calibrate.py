"""Pick the elastic constants that best reproduce thesis Table 4.1 (RMS relative height difference)."""

import math
from collections import defaultdict

from rheo.io import read_json, write_json_atomic
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
thesis = {float(k): v for k, v in smk.params.thesis_rows.items()}
errors = defaultdict(list)
for path in smk.input:
    run = read_json(path)
    errors[(run["mu"], run["lam"])].append((run["height"] - thesis[run["sigma_y"]]) / thesis[run["sigma_y"]])
rms = {pair: math.sqrt(sum(e * e for e in errs) / len(errs)) for pair, errs in errors.items()}
for mu, lam in sorted(rms):
    log.info("mu=%g lam=%g: RMS relative difference on Table 4.1 = %.3f", mu, lam, rms[mu, lam])
mu, lam = min(rms, key=rms.get)
log.info("calibrated: mu=%g lam=%g", mu, lam)
write_json_atomic(smk.output[0], {"mu": mu, "lam": lam, "rms_relative_difference": rms[mu, lam],
                                  "candidates": [{"mu": m, "lam": la, "rms_relative_difference": rms[m, la]}
                                                 for m, la in sorted(rms)]})
