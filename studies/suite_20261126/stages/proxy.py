"""proxy: the starting shape from a primitive or a mesh file, voxelised into an occupancy grid and particles."""

import numpy as np

from rheo.geometry.proxy import from_config, voxelize
from rheo.io import write_atomic, write_json_atomic
from rheo.report.figures import particle_views, save_figure
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
cfg = smk.params.proxy
mesh, analytic = from_config(cfg)
vox = voxelize(mesh, cfg["spacing"])
summary = {"shape": cfg["shape"], "particles": len(vox.particles), "spacing": vox.spacing,
           "particle_volume": vox.particle_volume, "voxel_volume": vox.volume, "mesh_volume": float(mesh.volume),
           "analytic_volume": analytic, "bounds": mesh.bounds.tolist(),
           "volume_error": None if analytic is None else vox.volume / analytic - 1.0}
log.info("proxy %s: %d particles, voxel volume %.6g m^3 (analytic %s, error %s)", cfg["shape"], len(vox.particles),
         vox.volume, analytic, summary["volume_error"])
write_atomic(smk.output.particles, lambda p: np.savez_compressed(
    p, positions=vox.particles, particle_volume=vox.particle_volume, occupancy=vox.occupancy, origin=vox.origin,
    spacing=vox.spacing))
write_json_atomic(smk.output.summary, summary)
save_figure(particle_views(vox.particles, f"proxy: {cfg['shape']}, {len(vox.particles)} particles"), smk.output.figure)
