"""seed: the particles the fit starts from, with their densities and colours: from a voxel radiance field fitted to
the first frame of every camera, or (one camera) from the proxy's geometry coloured from the view."""

import numpy as np

from rheo.experiments.scene import particle_spacing, start_bounds
from rheo.fit.observations import load
from rheo.fit.seed import (
    Seed,
    colour_from_view,
    fit_radiance_field,
    hull_grid,
    opaque_density,
    proxy_particles,
    seed_from_field,
    silhouette_iou,
    trim_top,
    visual_hull,
)
from rheo.io import read_json, write_atomic, write_json_atomic
from rheo.report.figures import contact_sheet, save_figure
from rheo.report.fit import focus_crop, observed_crop, rendered_crop
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
settings, simulation = smk.params.settings, smk.params.simulation
spacing = particle_spacing(simulation)
bounds = start_bounds(simulation)
obs = load(smk.input.recordings, smk.input.matte, smk.input.cameras, frames=1)
method = settings["method"] if settings["method"] != "auto" else ("radiance" if len(obs.views) > 1 else "proxy")
summary = {"method": method, "spacing": spacing}
if method == "radiance":
    grid = hull_grid(obs, bounds, spacing)
    hull = visual_hull(obs, grid)
    log.info("visual hull of %d views: %d voxels of %.4g m (%.4g m^3), grid %s", len(obs.views), hull.sum(), spacing,
             hull.sum() * spacing**3, grid.shape)
    density, colour, losses = fit_radiance_field(obs, grid, hull, levels=settings["levels"],
                                                 iterations=settings["iterations"],
                                                 rays_per_view=settings["rays_per_view"],
                                                 surface_weight=settings["surface_weight"])
    log.info("radiance field: loss %.4g -> %.4g over %d steps", losses[0], losses[-1], len(losses))
    seed, threshold, scores = seed_from_field(obs, density, colour, grid)
    untrimmed = len(seed.positions)
    seed, trimmed_layers = trim_top(obs, seed)
    if trimmed_layers:
        log.info("trimmed the top %d layers (%d particles): no view's outline needs them", trimmed_layers,
                 untrimmed - len(seed.positions))
        scores = silhouette_iou(obs, seed)
    summary.update(visual_hull_volume=float(hull.sum() * spacing**3), opacity_threshold=threshold,
                   trimmed_layers=trimmed_layers, trimmed_particles=untrimmed - len(seed.positions),
                   field_loss=losses)
else:
    proxy = np.load(smk.input.proxy)
    positions = proxy_particles(proxy["occupancy"], proxy["origin"], float(proxy["spacing"]), spacing)
    seed = Seed(positions, np.full(len(positions), opaque_density(spacing)), colour_from_view(obs, positions),
                spacing)
    scores = silhouette_iou(obs, seed)
inside = ((seed.positions >= bounds[0]) & (seed.positions <= bounds[1])).all(axis=1)
if not inside.all():
    log.warning("%d seed particles lie outside the box particles may start in (%s to %s m): dropped",
                int((~inside).sum()), np.round(bounds[0], 4).tolist(), np.round(bounds[1], 4).tolist())
    seed = Seed(seed.positions[inside], seed.density[inside], seed.colour[inside], spacing)
summary.update(particles=len(seed.positions), volume=seed.volume, silhouette_iou=scores,
               mean_silhouette_iou=float(np.mean(list(scores.values()))))
if hasattr(smk.input, "truth"):
    truth = read_json(smk.input.truth)
    true_volume = truth["particles"] * truth["particle_spacing"] ** 3
    summary.update(true_volume=true_volume, volume_error=seed.volume / true_volume - 1)
log.info("seed (%s): %d particles, volume %.5g m^3%s, mean silhouette IoU %.4f", method, len(seed.positions),
         seed.volume, f" ({summary['volume_error']:+.2%} against the truth)" if "volume_error" in summary else "",
         summary["mean_silhouette_iou"])
write_atomic(smk.output.particles, lambda p: np.savez_compressed(
    p, positions=seed.positions, density=seed.density, colour=seed.colour, spacing=seed.spacing))
write_json_atomic(smk.output.summary, summary)

rows = {}
for view in obs.views[:4]:
    crop = focus_crop(view, margin=20)
    rows[view.name] = [("first frame, matted", observed_crop(view, 0, crop)),
                       (f"seed, IoU {scores[view.name]:.3f}",
                        rendered_crop(seed.positions, seed.density, seed.colour, spacing, view, crop))]
save_figure(contact_sheet(rows), smk.output.figure)
