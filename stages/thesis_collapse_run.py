"""One column-collapse simulation of the thesis' tables: a calibration run (wildcards mu, sigma_y: Table 4.1) or a
prediction (wildcard ratio = eta / sigma_y: Table 4.2, elastic constants from the calibration)."""

import time

from rheo.experiments.collapse import CollapseSetup, simulate_collapse, thesis_material
from rheo.io import read_json, write_json_atomic
from rheo.stage import setup_logging

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
cfg = smk.params.setup
setup = CollapseSetup(**{k: cfg[k] for k in ("resolution", "radius", "height", "density", "gravity", "duration",
                                             "frames")})
if hasattr(smk.wildcards, "ratio"):
    calibration = read_json(smk.input.calibration)
    mu, lam = calibration["mu"], calibration["lam"]
    sigma_y = float(cfg["table_4_2"]["sigma_y"])
    eta = float(smk.wildcards.ratio) * sigma_y
else:
    mu = float(smk.wildcards.mu)
    lam = float(smk.wildcards.lam)
    sigma_y = float(smk.wildcards.sigma_y)
    eta = float(cfg["table_4_1"]["eta"])
log.info("collapse: sigma_y=%g eta=%g mu=%g lam=%g on a %d^3 grid", sigma_y, eta, mu, lam, setup.resolution)
start = time.perf_counter()
result = simulate_collapse(thesis_material(sigma_y, eta, mu, lam, setup.density), setup, progress=True)
log.info("height at t=%g s: %.5f m (%d particles, dt=%.3g s, %.1f s)", setup.duration, result["height"],
         result["particles"], result["dt"], time.perf_counter() - start)
write_json_atomic(smk.output[0], {"sigma_y": sigma_y, "eta": eta, "mu": mu, "lam": lam, **result})
