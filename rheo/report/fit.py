"""The experiment report: parameter table, training plots (thesis Appendix A layout), observed / initial-guess /
learned frames, animations per view, the recovered flow curve with its band, stage runtimes and the configuration."""

from __future__ import annotations

import html
import io
import json
import math
import re

import imageio.v2 as imageio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rheo.report.html import image_tag, page, table_tag

SYMBOLS = {"mu": "μ", "lam": "λ", "sigma_y": "σ_y", "eta": "η", "tau_y": "τ_y", "K": "K", "n": "n"}


def training_figure(history: list[dict], names: list[str], truth: dict[str, float]):
    """Thesis Appendix A's layout for a search: the loss of every evaluation and the best so far; each evaluation's
    distance from the best point so far per parameter (the search's step, in place of a learning rate); one panel
    per parameter. Phases are separated by dotted lines (searches run side by side count as one phase). The best so
    far starts again where the rows' "best_loss" does (the warm-up's loss is over fewer frames than the full one's)."""
    rows = math.ceil(len(names) / 2) + 1
    fig, axes = plt.subplots(rows, 2, figsize=(10, 2.8 * rows), squeeze=False)
    step = np.arange(len(history))
    loss = np.array([float(h["loss"]) for h in history])
    values = np.log(np.array([[float(h[n]) for n in names] for h in history]))
    best_index = np.zeros(len(loss), dtype=int)
    for i in range(1, len(loss)):
        restarts = "best_loss" in history[i] and float(history[i]["best_loss"]) > float(history[i - 1]["best_loss"])
        best_index[i] = i if restarts or loss[i] < loss[best_index[i - 1]] else best_index[i - 1]
    best = loss[best_index]
    distance = np.abs(values - values[best_index])
    ax = axes[0, 0]
    ax.plot(step, loss, ".", ms=3, color="0.6", label="evaluation")
    ax.plot(step, best, color="tab:blue", lw=1.2, label="best so far")
    ax.set_yscale("log")
    ax.set_title("loss (mean boundary distance, px)", fontsize=10)
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    for i, n in enumerate(names):
        ax.plot(step, distance[:, i], lw=0.8, label=SYMBOLS.get(n, n))
    ax.set_title("step: |log value - log best so far|", fontsize=10)
    ax.legend(fontsize=8, ncol=2)
    for i, n in enumerate(names):
        ax = axes.ravel()[2 + i]
        ax.plot(step, np.exp(values[:, i]), ".", ms=3, color="0.6")
        ax.plot(step, np.exp(values[best_index, i]), color="tab:blue", lw=1.2)
        if n in truth:
            ax.axhline(truth[n], color="tab:green", ls="--", lw=1, label="truth")
            ax.legend(fontsize=8)
        ax.set_yscale("log")
        ax.set_title(SYMBOLS.get(n, n), fontsize=10)
    phases = [re.sub(r" \d+$", "", h["phase"]) for h in history]  # "start 1", "start 2": one phase
    changes = [i for i in range(1, len(phases)) if phases[i] != phases[i - 1]]
    for ax in axes.ravel()[:2 + len(names)]:
        for i in changes:
            ax.axvline(i, color="0.6", ls=":", lw=1)
        ax.set_xlabel("evaluation")
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[2 + len(names):]:
        ax.axis("off")
    fig.tight_layout()
    return fig


def flow_curve_figure(tau_y: float, K: float, n: float, samples: np.ndarray | None, truth: tuple | None = None):
    """tau(gamma_dot) = tau_y + K gamma_dot^n with the band of ``samples``' middle 95 % (rows of tau_y, K, n)."""
    rate = np.logspace(-2, 3, 200)
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    if samples is not None and len(samples):
        curves = samples[:, :1] + samples[:, 1:2] * rate[None, :] ** samples[:, 2:3]
        ax.fill_between(rate, *np.percentile(curves, [2.5, 97.5], axis=0), color="tab:blue", alpha=0.2,
                        label="tolerance band")
    ax.plot(rate, tau_y + K * rate**n, color="tab:blue", label="recovered")
    if truth is not None:
        ax.plot(rate, truth[0] + truth[1] * rate ** truth[2], "--", color="tab:green", label="truth")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("shear rate (1/s)")
    ax.set_ylabel("shear stress (Pa)")
    ax.set_title("flow curve (Herschel-Bulkley)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig


def frames_figure(rows: list[tuple[str, list[tuple[str, np.ndarray]]]]):
    """Rows of labelled images (observed / initial guess / learned at chosen times)."""
    columns = max(len(r[1]) for r in rows)
    fig, axes = plt.subplots(len(rows), columns, figsize=(4.0 * columns, 2.6 * len(rows)), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for r, (label, panels) in enumerate(rows):
        for c, (title, image) in enumerate(panels):
            axes[r, c].imshow(np.clip(image, 0, 1))
            axes[r, c].set_title(f"{label}, {title}", fontsize=8)
    fig.tight_layout()
    return fig


def gif_tag(frames: list[np.ndarray], caption: str, fps: float = 6.0, min_height: int = 320) -> str:
    """An animated GIF (frames as float RGB in [0, 1]) inline, enlarged to at least ``min_height`` pixels."""
    factor = max(1, math.ceil(min_height / frames[0].shape[0]))
    buf = io.BytesIO()
    imageio.mimwrite(buf, [np.kron((np.clip(f, 0, 1) * 255).astype(np.uint8), np.ones((factor, factor, 1), np.uint8))
                           for f in frames], format="GIF", duration=1.0 / fps, loop=0)
    return image_tag(buf.getvalue(), "gif", caption)


def interval_text(entry: dict) -> str:
    """A fitted parameter's tolerance interval, "[low, high]", an open end (the region within the tolerance goes on past
    the fit's reach) marked < or >."""
    (low, high), (open_low, open_high) = entry["interval"], entry.get("interval_open", [False, False])
    return f"[{'<' if open_low else ''}{low:.3g}, {'>' if open_high else ''}{high:.3g}]"


def parameter_rows(params: dict) -> tuple[list[str], list[list[str]], list[str]]:
    """The parameter table: initial guess, recovered, interval, determined; with the truth and the % error where the
    truth is known (a virtual experiment)."""
    known = any("truth" in p for p in params.values())
    header = ["parameter", *(["truth"] if known else []), "initial guess", "recovered", "tolerance interval",
              *(["error"] if known else []), "determined by the recording"]
    rows, classes = [], []
    for name, p in params.items():
        error, held = p.get("error"), p.get("held_at_initial_guess", False)
        truth = [f"{p['truth']:.4g}" if "truth" in p else "unknown"] if known else []
        error_text = ["not recovered" if held else f"{error:+.1%}" if error is not None else "-"] if known else []
        rows.append([SYMBOLS.get(name, name), *truth, f"{p['initial']:.4g}",
                     f"{p['value']:.4g}" + (" (held at the guess)" if held else ""), interval_text(p), *error_text,
                     "yes" if p["determined"] else "no"])
        # a parameter held at its guess was not recovered, however near the truth the guess was
        classes.append("" if error is None or held else ("good" if abs(error) <= 0.1 else "bad"))
    return header, rows, classes


UNITS = {"mu": "Pa", "lam": "Pa", "sigma_y": "Pa", "eta": "Pa s", "tau_y": "Pa", "K": "Pa s^n", "n": ""}


def headline(parameters: dict[str, dict], subject: str = "recording") -> str:
    """The result in a sentence: the law with its intervals, the elastic constants where they were fitted, and what
    the ``subject`` does not determine."""
    law = ", ".join(f"{SYMBOLS.get(k, k)} = {p['value']:.3g}{' ' + UNITS[k] if UNITS[k] else ''} "
                    f"{interval_text(p)}{' (held at its guess)' if p.get('held_at_initial_guess') else ''}"
                    for k, p in parameters.items() if k not in ("mu", "lam"))
    elastic = ""
    if "mu" in parameters:
        mu, lam = parameters["mu"]["value"], parameters["lam"]["value"]
        elastic = f"; elastic constants μ = {mu:.3g} Pa, λ = {lam:.3g} Pa"
    undetermined = [SYMBOLS.get(k, k) for k, p in parameters.items() if not p["determined"]]
    plural = subject.endswith("s")
    rest = (f" The {subject} {'do' if plural else 'does'} not determine {', '.join(undetermined)}: the loss barely "
            f"changes along {'it' if len(undetermined) == 1 else 'them'}." if undetermined else
            f" The {subject} {'determine' if plural else 'determines'} every parameter.")
    return (f"<p class='headline'><b>Recovered law</b> (tolerance intervals in brackets): {html.escape(law)}"
            f"{elastic}.{html.escape(rest)}</p>")


def render(name: str, params: dict, sections: list[tuple[str, str]], config: dict,
           runtimes: list[tuple[str, float]], flow_curve: str = "") -> str:
    """The page: the result in a sentence, its flow curve and the parameter table first, then each (heading, html)
    section, the runtimes and the configuration (folded)."""
    header, rows, classes = parameter_rows(params["parameters"])
    body = [headline(params["parameters"]), flow_curve, table_tag(header, rows, classes),
            f"<p>Tolerance interval: each parameter's range over the materials whose loss lies within "
            f"{params['tolerance']:.0%} of the best fit's (the fit model's own error; coverage not calibrated), from "
            "the surface fitted to the loss around the estimate, trade-offs between parameters included, each end "
            "then walked out on the loss itself along the surface's valley floor; &lt; or &gt; marks an end where "
            "that region goes on past the evaluations' reach. A parameter whose interval spans more than a factor 4 "
            "(a flow index 1.5) or has an open end is not determined; those whose initial guess lies inside their "
            f"interval were held at it while the others were fitted again. Convention: "
            f"{html.escape(params['convention'])}; initial velocity {np.round(params['initial_velocity'], 4).tolist()} "
            "m/s.</p>"]
    for heading, content in sections:
        body.append(f"<h2>{html.escape(heading)}</h2>{content}")
    body.append("<h2>Stage runtimes</h2>" + table_tag(["stage", "seconds"],
                                                      [[s, f"{t:.1f}"] for s, t in runtimes]))
    body.append("<details><summary>Configuration</summary><pre>" + html.escape(json.dumps(config, indent=2))
                + "</pre></details>")
    return page(f"rheo: {name}", "".join(body))


def focus_crop(view, frames: slice = slice(None), margin: int = 16) -> tuple[slice, slice]:
    """The image region (rows, columns) around the material over ``frames`` of a view, with ``margin`` pixels."""
    cam = view.camera
    seen = view.masks[frames].any(axis=0).reshape(cam.height, cam.width)
    rows, cols = np.nonzero(seen) if seen.any() else (np.array([0, cam.height - 1]), np.array([0, cam.width - 1]))
    return (slice(max(rows.min() - margin, 0), min(rows.max() + margin + 1, cam.height)),
            slice(max(cols.min() - margin, 0), min(cols.max() + margin + 1, cam.width)))


def observed_crop(view, frame: int, crop: tuple[slice, slice]) -> np.ndarray:
    cam = view.camera
    return view.images[frame].reshape(cam.height, cam.width, 3)[crop] / 255.0


def material_colour(colours: np.ndarray) -> tuple[float, float, float]:
    """The particles' median colour (RGB in [0, 1]), brightened for a lit surface."""
    median = np.median(colours, axis=0)
    return tuple((0.8 * median / max(float(median.max()), 1e-3)).tolist())


def surface_crop(positions: np.ndarray, spacing: float, view, crop: tuple[slice, slice],
                 colour: tuple[float, float, float]) -> np.ndarray:
    """The particles drawn as a shaded surface over the cropped pixels of a view."""
    from rheo.render.surface import surface_image

    return surface_image(positions, spacing, view.camera, colour)[crop]


def rendered_crop(positions: np.ndarray, density: np.ndarray, colour: np.ndarray, spacing: float, view,
                  crop: tuple[slice, slice]) -> np.ndarray:
    """The particle field rendered on white over the cropped pixels of a view."""
    from rheo.render.field import render_view

    cam = view.camera
    dirs = view.dirs.reshape(cam.height, cam.width, 3)[crop]
    rgb, _ = render_view(positions, density, colour, spacing, view.origin, dirs.reshape(-1, 3))
    return rgb.reshape(*dirs.shape[:2], 3)
