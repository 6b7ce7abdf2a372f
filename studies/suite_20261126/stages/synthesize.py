"""synthesize: simulate a virtual experiment with the lab's particles and film it (frames, masks, clean plates,
checkerboard images) with the lab renderer; truth.json records the parameters, cameras and board."""


from rheo.experiments.scene import material
from rheo.experiments.virtual_lab import LabBoard, simulate_truth, write_recordings
from rheo.io import write_json_atomic
from rheo.report.figures import camera_frusta, save_figure
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
exp = smk.params.experiment
lab = exp["lab"]
board = LabBoard(**lab["board"], views=lab["views"], ground_origin=tuple(lab["ground_origin"]))
log.info("simulating %s at %d^3 with %d^3 particles per cell for %g s", exp["name"],
         exp["simulation"]["resolution"], exp["simulation"]["particles_per_cell"], exp["simulation"]["duration"])
truth = simulate_truth(exp)
log.info("%d particles, dt = %.3g s; rendering %d cameras", truth["positions"].shape[1], truth["dt"],
         exp["cameras"]["count"])
record = write_recordings(smk.output.recordings, exp, truth, board, seed=lab["seed"], workers=smk.threads)
m = material(exp["material"])
write_json_atomic(smk.output.truth, {
    "experiment": exp["name"], "material": {"tau_y": m.tau_y, "K": m.K, "n": m.n, "mu": m.mu, "lam": m.lam,
                                            "density": m.density, "as_configured": exp["material"]},
    "resolution": exp["simulation"]["resolution"], "particles_per_cell": exp["simulation"]["particles_per_cell"],
    "particles": int(truth["positions"].shape[1]),
    "particle_spacing": truth["spacing"], "dt": truth["dt"],
    "masks": "coverage of the material's splats with slits under two particle spacings closed, rendered at "
             "twice the resolution and averaged", **record})
save_figure(camera_frusta(record["cameras"], truth["positions"][0][:: max(1, truth["positions"].shape[1] // 4000)],
                          f"{exp['name']}: lab cameras and the material at t = 0"), smk.output.figure)
log.info("recordings written to %s", smk.output.recordings)
