"""virheometry_import: one ViRheometry setup folder in SI units (geometry, walls, density, camera, silhouettes), with
its camera checked by projecting the material's initial cuboid onto the first silhouette."""

import numpy as np

from rheo.experiments.virheometry import cuboid_overlap, read_setup
from rheo.fit.dam_break import frame_steps
from rheo.io import write_atomic, write_json_atomic
from rheo.report.figures import save_figure
from rheo.report.virheometry import camera_check_figure
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
frame_steps(smk.params.fps, f"{smk.params.folder} (virheometry.fps)")  # refused before anything is read
setup = read_setup(smk.params.folder, smk.params.scale, smk.params.fps)
overlap = cuboid_overlap(setup)
log.info("%s: %s, H %.3g m, W %.3g m, depth %.3g m, density %.0f kg/m^3, %d frames at %g fps; initial cuboid on "
         "frame 1: IoU %.3f, %.1f %% of the cuboid on the silhouette", setup.folder, setup.material, setup.height,
         setup.width, setup.depth, setup.density, len(setup.masks), setup.fps, overlap["iou"],
         100 * overlap["cuboid_on_silhouette"])
write_json_atomic(smk.output.setup, {**setup.record(), "units": "SI (m, kg/m^3, Pa, s)", "frames": len(setup.masks),
                                     "camera_check": overlap})
write_atomic(smk.output.masks, lambda p: np.savez_compressed(p, masks=np.stack(setup.masks)))
save_figure(camera_check_figure(setup, overlap), smk.output.figure)
