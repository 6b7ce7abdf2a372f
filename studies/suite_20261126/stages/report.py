"""report: one self-contained HTML file (opens offline): parameter table, training plots, observed / initial-guess /
learned frames and an animation per view, the flow curve with its band, the new-shape prediction, stage runtimes and
the configuration."""

import csv
from pathlib import Path

import numpy as np
import torch

from rheo.fit.inverse import build_problem, initial_guess, log_values, simulator_parameters
from rheo.fit.observations import load
from rheo.fit.uncertainty import Interval, log_draws
from rheo.io import read_json, write_text_atomic
from rheo.report.fit import (
    SYMBOLS,
    flow_curve_figure,
    focus_crop,
    frames_figure,
    gif_tag,
    material_colour,
    observed_crop,
    render,
    surface_crop,
    training_figure,
)
from rheo.report.html import figure_tag, image_tag
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
exp = smk.params.experiment
params = read_json(smk.input.params)
with open(smk.input.history) as f:
    history = list(csv.DictReader(f))
names = list(params["parameters"])
truth = {k: p["truth"] for k, p in params["parameters"].items() if "truth" in p}
sections = [("The search (derivative-free, so no learning rate; dotted: phase changes)",
             figure_tag(training_figure(history, names, truth),
                        "every simulated material in order: a survey on the first frames, then simplex searches "
                        "and a quadratic surface on every frame. Loss in pixels (mean distance between the "
                        "simulated and recorded boundaries); the step panel, the search's distance from its best "
                        "point so far in log units, stands where a gradient fit plots its learning rate"))]

# observed, initial guess and learned, from the simulations of both parameter sets
obs = load(smk.input.recordings, smk.input.matte, smk.input.cameras)
problem = build_problem(exp, obs, smk.input.seed)
seed = np.load(smk.input.seed)
colour, spacing = material_colour(seed["colour"]), float(seed["spacing"])
last = obs.frames - 1
runs = {}
with torch.no_grad():
    for label, values, v0 in [("initial guess", initial_guess(exp), read_json(smk.input.velocity)["v0"]),
                              ("learned", {k: p["value"] for k, p in params["parameters"].items()},
                               params["initial_velocity"])]:
        runs[label] = problem.simulate(log_values(values, names), torch.tensor(v0, dtype=torch.float64),
                                       last).x.numpy()
picks = sorted({0, last // 2, last})
rows = []
for view in obs.views[:2]:
    crop = focus_crop(view)
    for label in ("observed", "initial guess", "learned"):
        panels = []
        for k in picks:
            image = observed_crop(view, k, crop) if label == "observed" else surface_crop(
                runs[label][k], spacing, view, crop, colour)
            panels.append((f"t = {obs.times[k]:.2f} s", image))
        rows.append((f"{view.name} {label}", panels))
sections.append(("Observed, initial guess and learned", figure_tag(frames_figure(rows), "beginning, middle, end")))
animations = []
for view in obs.views:
    crop = focus_crop(view)
    frames = [np.concatenate([observed_crop(view, k, crop), surface_crop(runs["learned"][k], spacing, view, crop,
                                                                         colour)], axis=1)
              for k in range(obs.frames)]
    animations.append(gif_tag(frames, f"{view.name}: observed (left), learned (right)"))
sections.append(("Every view, animated", "".join(animations)))

# the flow curve, with a band from the parameters' tolerance intervals (each taken as the central 95 % of an
# independent normal log-parameter)
draws = log_draws([Interval(p["value"], *p["interval"]) for p in params["parameters"].values()])
density_value = params["herschel_bulkley"]["density"]
samples = np.array([simulator_parameters(dict(zip(names, torch.exp(torch.as_tensor(d)), strict=True)),
                                         params["convention"], density_value)[1:4].numpy() for d in draws])
hb = params["herschel_bulkley"]
true_hb = None
if truth:
    t = simulator_parameters({k: torch.tensor(float(v)) for k, v in truth.items()}, params["convention"],
                             density_value)
    true_hb = tuple(t[1:4].tolist())
flow_curve = figure_tag(flow_curve_figure(hb["tau_y"], hb["K"], hb["n"], samples, true_hb),
                        "the recovered flow curve: shear stress (Pa) against shear rate (1/s); band: the curves of "
                        "the parameters drawn within their tolerance intervals (coverage not calibrated)")
sections.append(("Prediction on a new shape", image_tag(Path(smk.input.novel).read_bytes(), "png",
                                                       f"{exp['novel']['mesh']} with the recovered material "
                                                       "(video: novel/bunny.mp4)")))
runtimes = []
for path in smk.input.benchmarks:
    with open(path) as f:
        row = next(csv.DictReader(f, delimiter="\t"))
    runtimes.append((Path(path).stem, float(row["s"])))
runtimes.append(("total", sum(t for _, t in runtimes)))
write_text_atomic(smk.output.report, render(exp["name"], params, sections, exp, runtimes, flow_curve))
log.info("report: %s (%s)", smk.output.report, ", ".join(f"{SYMBOLS.get(k, k)} {p['value']:.4g}"
                                                         for k, p in params["parameters"].items()))
