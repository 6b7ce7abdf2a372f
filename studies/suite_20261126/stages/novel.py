"""novel: the recovered material on a new shape (the Stanford bunny by default), filmed by a calibrated camera and
drawn as a shaded surface framed to fill the view: an mp4 and a strip of the beginning, middle and end."""

from pathlib import Path

import imageio.v2 as imageio

from rheo.experiments.novel import mesh_particles, recovered_material, simulate
from rheo.experiments.scene import particle_spacing, simulator
from rheo.io import read_json, write_atomic
from rheo.render.surface import framing, surface_image
from rheo.report.figures import contact_sheet, save_figure
from rheo.stage import start_stage
from rheo.vision.cameras import Camera

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
exp = smk.params.experiment
cfg, sim_cfg = exp["novel"], exp["simulation"]
if "duration" not in sim_cfg:  # a real recording: as long as the first camera's
    recorded = next(iter(read_json(Path(smk.input.recordings) / "recording.json").values()))
    sim_cfg.update(frames=recorded["frames"], duration=(recorded["frames"] - 1) / recorded["fps"])
params = read_json(smk.input.params)
cameras = read_json(smk.input.cameras)["cameras"]
camera = Camera.from_record(cameras[cfg["camera"] or next(iter(cameras))])
spacing = particle_spacing(sim_cfg)
size = sim_cfg["domain_size"]
height = cfg["height"] or size / 5
particles = mesh_particles(cfg["mesh"], height, tuple(cfg["position"] or (size / 2, size / 2)), spacing)
material = recovered_material(params["herschel_bulkley"])
log.info("%s scaled to %.3g m: %d particles; simulating %g s with %s", cfg["mesh"], height, len(particles),
         sim_cfg["duration"], material)
positions = simulate(simulator(exp, sim_cfg["resolution"], mat=material), particles, spacing, sim_cfg["duration"],
                     sim_cfg["frames"])
images = [surface_image(p, spacing, camera) for p in positions]
rows, cols = framing(images)  # the shape fills the view
images = [(255 * image[rows, cols] + 0.5).astype("uint8") for image in images]
fps = (len(images) - 1) / sim_cfg["duration"]
write_atomic(smk.output.video, lambda path: imageio.mimwrite(path, images, format="FFMPEG", fps=max(fps, 1.0),
                                                             macro_block_size=1, quality=8))
picks = sorted({0, len(images) // 2, len(images) - 1})
save_figure(contact_sheet({"bunny": [(f"t = {k / fps:.2f} s", images[k]) for k in picks]}), smk.output.strip)
log.info("height %.3f m -> %.3f m", positions[0][:, 1].max(), positions[-1][:, 1].max())
