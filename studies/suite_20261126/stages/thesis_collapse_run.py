"""One column-collapse simulation of the thesis' tables: a calibration run (elastic constants from the params) or a
prediction (elastic constants from the calibration input)."""

import time

from rheo.experiments.collapse import CollapseSetup, simulate_collapse
from rheo.io import read_json, write_json_atomic
from rheo.physics import HerschelBulkley
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
setup = CollapseSetup(**smk.params.setup)
if hasattr(smk.input, "calibration"):
    calibration = read_json(smk.input.calibration)
    mu, lam = calibration["mu"], calibration["lam"]
else:
    mu, lam = smk.params.elastic
sigma_y, eta = float(smk.params.sigma_y), float(smk.params.eta)
log.info("collapse: sigma_y=%g eta=%g mu=%g lam=%g on a %d^3 grid", sigma_y, eta, mu, lam, setup.resolution)
start = time.perf_counter()
result = simulate_collapse(HerschelBulkley.from_pacnerf(sigma_y, eta, mu, lam, setup.density), setup, progress=True)
log.info("height at t=%g s: %.5f m (%d particles, dt=%.3g s, %.1f s)", setup.duration, result["height"],
         result["particles"], result["dt"], time.perf_counter() - start)
write_json_atomic(smk.output[0], {"sigma_y": sigma_y, "eta": eta, "mu": mu, "lam": lam, **result})
