"""Figures of the ViRheometry dam breaks."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rheo.diagnose.scores import LAST_FRAMES_GAIN, down, loss_change
from rheo.experiments.rheometer import RESULT_KEYS, FlowCurve, log_rms_error
from rheo.experiments.virheometry import Setup
from rheo.fit.uncertainty import best_determined_stress
from rheo.report.fit import flow_curve_figure
from rheo.report.html import in_words, table_tag

# pairs of Setup.cuboid_corners() that differ along one axis
CUBOID_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]


def camera_check_figure(setup: Setup, overlap: dict[str, float], margin: int = 25):
    """The first and last silhouettes with the initial cuboid's edges projected through the setup's camera."""
    uv, _ = setup.camera.project(setup.cuboid_corners())
    rows, cols = np.nonzero(setup.masks[0] | setup.masks[-1])
    left, right = min(cols.min(), uv[:, 0].min()) - margin, max(cols.max(), uv[:, 0].max()) + margin
    top, bottom = min(rows.min(), uv[:, 1].min()) - margin, max(rows.max(), uv[:, 1].max()) + margin
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, frame in zip(axes, (0, len(setup.masks) - 1), strict=True):
        ax.imshow(~setup.masks[frame], cmap="gray", vmin=0, vmax=1.6)
        for a, b in CUBOID_EDGES:
            ax.plot(uv[[a, b], 0], uv[[a, b], 1], color="tab:red", lw=1)
        ax.set_xlim(left, right)
        ax.set_ylim(bottom, top)
        ax.set_title(f"frame {frame + 1}" + (" and the initial cuboid" if frame == 0 else ""), fontsize=9)
        ax.axis("off")
    fig.suptitle(f"{setup.folder.name}: cuboid on frame 1, IoU {overlap['iou']:.3f}, "
                 f"{100 * overlap['cuboid_on_silhouette']:.1f} % of the cuboid on the silhouette", fontsize=10)
    fig.tight_layout()
    return fig


def overlay(observed: np.ndarray, simulated: np.ndarray) -> np.ndarray:
    """RGB: both grey, recorded only red, simulated only blue, neither white."""
    image = np.ones((*observed.shape, 3))
    image[observed & simulated] = 0.55
    image[observed & ~simulated] = (0.85, 0.15, 0.1)
    image[simulated & ~observed] = (0.1, 0.35, 0.9)
    return image


def frames_figure(rows: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]], margin: int = 15):
    """Per setup (name: recorded masks, simulated silhouettes, IoU per frame) the first, middle and last frames
    overlaid."""
    count = len(next(iter(rows.values()))[0])
    frames = (0, (count - 1) // 2, count - 1)
    return overlay_grid([(masks, simulated, lambda k, name=name, iou=iou: f"{name}\nframe {k + 1}: IoU {iou[k]:.3f}")
                         for name, (masks, simulated, iou) in rows.items()], frames, (3.4, 2.4), margin)


def overlay_grid(lines: list[tuple[np.ndarray, np.ndarray, Callable[[int], str]]], frames: Sequence[int],
                 panel: tuple[float, float], margin: int = 15):
    """One row per line (recorded masks, simulated silhouettes, the title of frame k), the ``frames`` overlaid
    (``overlay``) and cropped to what either shows; ``panel``: a panel's size (inches)."""
    fig, axes = plt.subplots(len(lines), len(frames), figsize=(panel[0] * len(frames), panel[1] * len(lines)),
                             squeeze=False)
    for row, (masks, simulated, title) in zip(axes, lines, strict=True):
        ys, xs = np.nonzero(masks.any(axis=0) | simulated.any(axis=0))
        for ax, k in zip(row, frames, strict=True):
            ax.imshow(overlay(masks[k], simulated[k]))
            ax.set_xlim(xs.min() - margin, xs.max() + margin)
            ax.set_ylim(ys.max() + margin, ys.min() - margin)
            ax.set_title(title(k), fontsize=8)
            ax.axis("off")
    fig.suptitle("grey: both; red: recorded only; blue: simulated only", fontsize=9)
    fig.tight_layout()
    return fig


def rheometer_comparison(laws: dict[str, tuple[float, float, float]], curves: list[FlowCurve],
                         band: tuple[float, float]) -> tuple[str, dict[str, dict[str, float]]]:
    """The RMS of log10(tau_law / tau_rheometer) of every law (label: tau_y, K, n) against every rheometer curve
    over the shear-rate ``band``: an HTML table (a row per law, its label in words: an effect's name with spaces, a
    column per curve) and the errors by curve and label."""
    inside = [curve.within(tuple(band)) for curve in curves]
    errors = {curve.name: {label: log_rms_error(*law, points) if len(points.shear_rate) else float("nan")
                           for label, law in laws.items()} for curve, points in zip(curves, inside, strict=True)}
    header = ["law", "tau_y (Pa)", "K (Pa s^n)", "n",
              *(f"RMS log10, {curve.name} ({curve.temperature:.1f} C; {len(points.shear_rate)} points in the band)"
                for curve, points in zip(curves, inside, strict=True))]
    rows = [[in_words(label), *(f"{v:.3g}" for v in law),
             *(f"{errors[curve.name][label]:.3f}" for curve in curves)] for label, law in laws.items()]
    return table_tag(header, rows), errors


def determined_stress_text(fit: dict, curves: list[FlowCurve]) -> str | None:
    """Where, over the shear rates the flow reached, the flow curves of a fit's (params.json) evaluated laws within
    the tolerance agree best: their stresses, the rate and how many laws, and the rheometer's stresses there where
    there are ``curves``; None without a band or where ``best_determined_stress`` finds nothing."""
    band = fit["shear_rate_band_per_s"]
    found = None if band is None else best_determined_stress(fit["within_tolerance"]["laws"], band)
    if found is None:
        return None
    text = f"{found.low:.3g}-{found.high:.3g} Pa at {found.rate:.2g} 1/s, {len(fit['within_tolerance']['laws'])} laws"
    if curves:
        measured = [curve.stress_at(found.rate) for curve in curves]
        text += f" (rheometer {min(measured):.3g}-{max(measured):.3g} Pa)"
    return text


def held_out_changes(candidate: dict, base: dict, words: tuple[str, str] = ("between", "last")) -> list[str]:
    """The refit's changes of the held-out losses (between fitted frames; the last frames) against the base fit, each
    after its word, those of frames not held out left out."""
    return [f"{word} {change:+.0f} %" for word, key in zip(words, ("held_out_loss_px", "forecast_loss_px"), strict=True)
            if (change := loss_change(base.get(key), candidate.get(key))) is not None]


def candidates_table(diagnoses: dict[str, dict], curves: dict[str, list[FlowCurve]]) -> str:
    """Per material (name: diagnosis.json's record) what each candidate effect's refit did: the change of the
    information criterion from the base fit, of the held-out losses (between fitted frames; the last frames), the
    refit's flow index and, where the material has rheometer ``curves``, its largest RMS log10 error against them
    over the diagnosis' shear-rate band; "-" where the candidate was not tried (not applicable to the setups). The
    last row counts, per candidate, the materials whose last frames its refit predicts better (LAST_FRAMES_GAIN)."""
    names = list(dict.fromkeys(c["effect"] for record in diagnoses.values() for c in record["candidates"]))

    def law_text(fit: dict, material: str) -> str:
        law = tuple(fit["values"][key] for key in RESULT_KEYS.values())
        text = f"n {law[2]:.2f}"
        band = diagnoses[material].get("flow_curve_rms_log10", {}).get("band_per_s")
        if curves.get(material) and band is not None:
            errors = rheometer_comparison({"law": law}, curves[material], band)[1]
            text += f", RMS {max(e['law'] for e in errors.values()):.3f}"
        return text

    def cell(candidate: dict, record: dict, material: str) -> str:
        changes = held_out_changes(candidate, record["base"])
        return "; ".join([f"{candidate['delta_criterion']:+.1f}", *([", ".join(changes)] if changes else []),
                          law_text(candidate, material)])

    rows, better, tried_on = [], dict.fromkeys(names, 0), dict.fromkeys(names, 0)
    for material, record in diagnoses.items():
        tried = {c["effect"]: c for c in record["candidates"]}
        for name, candidate in tried.items():
            change = loss_change(record["base"].get("forecast_loss_px"), candidate.get("forecast_loss_px"))
            tried_on[name] += change is not None
            better[name] += down(change, LAST_FRAMES_GAIN)
        rows.append([material, law_text(record["base"], material),
                     *(cell(tried[n], record, material) if n in tried else "-" for n in names)])
    rows.append([f"last frames predicted {-LAST_FRAMES_GAIN:.0f} % better or more", "",
                 *(f"{better[n]} of {tried_on[n]}" for n in names)])
    return table_tag(["material", "base fit", *(in_words(n) for n in names)], rows)


def flow_figure(law: tuple[float, float, float], samples: np.ndarray, band: tuple[float, float] | None,
                curves: list[FlowCurve]):
    """The recovered flow curve with its band (``flow_curve_figure``), the shear rates the flow reached and the
    rheometer's points."""
    fig = flow_curve_figure(*law, samples)
    ax = fig.axes[0]
    if band is not None:
        ax.axvspan(*band, color="0.85", zorder=0, label="shear rates reached")
    for curve, marker in zip(curves, "os^v", strict=False):
        ax.plot(curve.shear_rate, curve.stress, marker, ms=4, mfc="none", label=f"rheometer {curve.temperature:.0f} C")
    ax.legend(fontsize=7)
    return fig


def summary_figure(laws: dict[str, tuple[tuple[float, float, float], tuple[float, float] | None]]):
    """Every material's recovered flow curve: solid over the shear rates its flow reached, dotted elsewhere."""
    rate = np.logspace(-2, 3, 200)
    fig, ax = plt.subplots(figsize=(10, 5), layout="constrained")
    reached = []
    for (name, (law, band)), colour in zip(laws.items(), plt.cm.tab20(np.linspace(0, 1, max(len(laws), 1))),
                                           strict=False):
        stress = law[0] + law[1] * rate ** law[2]
        ax.plot(rate, stress, ":", color=colour, lw=1, label=name if band is None else None)
        if band is None:
            continue
        inside = (rate >= band[0]) & (rate <= band[1])
        ax.plot(rate[inside], stress[inside], "-", color=colour, lw=2, label=name)
        reached.extend(stress[inside])
    ax.set_xscale("log")
    ax.set_yscale("log")
    if reached:  # the stresses the flows reached, not a shear-thickening law's extrapolation
        ax.set_ylim(min(reached) / 2, max(reached) * 3)
    ax.set_xlabel("shear rate (1/s)")
    ax.set_ylabel("shear stress (Pa)")
    ax.set_title("recovered flow curves (solid: shear rates the flow reached)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def flow_index_profile_figure(profile: dict[str, list[float]], level: float, n_interval: tuple[float, float],
                              band: tuple[float, float] | None, curves: list[FlowCurve]):
    """Left, the flow index's profile (each searched index's best loss) against the tolerance's level and n's
    interval; right, those laws' flow curves (solid where within the level) with the rheometer's points."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    n, loss = np.array(profile["n"]), np.array(profile["loss_px"])
    within = loss <= level
    left.axvspan(*n_interval, color="0.88", label="n's tolerance interval")
    left.plot(n, loss, "-", color="0.4")
    left.plot(n[within], loss[within], "o", color="C0", label="within the tolerance")
    left.plot(n[~within], loss[~within], "o", mfc="none", color="C3", label="beyond it")
    left.axhline(level, ls="--", color="0.3", lw=1, label="tolerance level")
    left.set_xscale("log")
    left.set_xticks(n, [f"{v:.2g}" for v in n])
    left.minorticks_off()
    left.set_xlabel("flow index n")
    left.set_ylabel("best loss at n (px)")
    left.legend(fontsize=7)
    rate = np.logspace(-1, 2.5, 120)
    if band is not None:
        right.axvspan(*band, color="0.9", zorder=0, label="shear rates reached")
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(n)))
    for tau_y, K, index, inside, colour in zip(profile["tau_y_Pa"], profile["K_Pa_s_n"], n, within, colours,
                                               strict=True):
        right.plot(rate, tau_y + K * rate**index, "-" if inside else ":", color=colour, lw=1.5 if inside else 1,
                   label=f"n {index:.2g}")
    for curve, marker in zip(curves, "os^v", strict=False):
        right.plot(curve.shear_rate, curve.stress, marker, ms=3, mfc="none", color="0.3",
                   label=f"rheometer {curve.temperature:.0f} C")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlim(rate[0], rate[-1])
    right.set_xlabel("shear rate (1/s)")
    right.set_ylabel("shear stress (Pa)")
    right.legend(fontsize=6, ncol=2)
    return fig
