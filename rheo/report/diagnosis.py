"""The "What the model leaves out" section: residual maps before and after the refit, the candidates' table and
profiles, the verdict and its gain on held-out frames; and the concealed cases' confusion table."""

from __future__ import annotations

from collections.abc import Callable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rheo.diagnose.candidates import CANDIDATES, OPEN_DRAG
from rheo.diagnose.scores import loss_change
from rheo.diagnose.selection import named_below
from rheo.physics.optional import OPEN_LAYER, open_drag_rate
from rheo.report.html import figure_tag, image_tag, in_words, table_tag
from rheo.report.virheometry import held_out_changes, overlay_grid


def shown_frames(fitted: np.ndarray) -> list[int]:
    """Up to four frames to show: the first, the middle, the last, and the first held out if any is."""
    count = len(fitted)
    held = np.flatnonzero(~fitted)
    return sorted({0, (count - 1) // 2, count - 1, *held[:1].tolist()})


def maps_figure(rows: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]], margin: int = 15):
    """Per setup (name: recorded masks, the base fit's silhouettes, the refit's or None, which frames are fitted)
    residual maps of chosen frames: a row for the base fit, a row for the refit."""
    def title(name: str, label: str, fitted: np.ndarray) -> Callable[[int], str]:
        return lambda k: f"{name}, {label}\nframe {k + 1}{'' if fitted[k] else ' (held out)'}"

    lines = [(masks, simulated, title(name, label, fitted))
             for name, (masks, before, after, fitted) in rows.items()
             for label, simulated in (("base fit", before), ("refit", after)) if simulated is not None]
    return overlay_grid(lines, shown_frames(next(iter(rows.values()))[3]), (3.2, 2.3), margin)


def profiles_figure(candidates: list[dict], base_loss: float):
    """Each candidate's profile: the lowest loss found with the effect held at each magnitude (the law refitted
    there), against the base fit's loss."""
    shown = [c for c in candidates if c.get("profile")]
    columns = min(4, len(shown))
    rows = -(-len(shown) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(2.7 * columns, 2.3 * rows), squeeze=False, sharey=True)
    for ax, c in zip(axes.flat, shown, strict=False):  # (spare panels left blank below)
        candidate = CANDIDATES[c["effect"]]
        values, losses = np.array(c["profile"]).T
        ax.plot(values, losses, "o-", ms=3, color="tab:red" if candidate.decoy else "tab:blue")
        ax.axhline(base_loss, color="0.5", ls="--", lw=0.8)
        if candidate.log:
            ax.set_xscale("log")
        ax.set_xticks(values, [f"{v:.2g}" for v in values], rotation=45)
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_title(f"{in_words(c['effect'])} ({c['delta_criterion']:+.1f})", fontsize=8)
        ax.set_xlabel(candidate.parameter + (f" ({candidate.unit})" if candidate.unit else ""), fontsize=7)
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(shown):]:
        ax.axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("fitted frames' loss (px)", fontsize=7)
    fig.tight_layout()
    return fig


def open_drag_figure(rates: list[float]):
    """The open drag's rate (1/s) over height above the floor (material heights) and time (share of the recording):
    where and when it holds the material back (red) or drives it (blue)."""
    height, time = np.meshgrid(np.linspace(0.0, 1.5, 61), np.linspace(0.0, 1.0, 41), indexing="ij")
    rate = open_drag_rate(rates, height, time, layer=OPEN_LAYER, span=1.0)
    largest = max(float(np.abs(rate).max()), 1e-9)
    fig, ax = plt.subplots(figsize=(4.2, 2.8))
    image = ax.pcolormesh(time, height, rate, cmap="RdBu_r", vmin=-largest, vmax=largest, shading="auto")
    fig.colorbar(image, ax=ax, label="drag rate (1/s)")
    ax.set_xlabel("time, share of the recording")
    ax.set_ylabel("height above the floor\n(material heights)")
    fig.tight_layout()
    return fig


def open_drag_section(record: dict) -> str:
    """The open drag's refit: its verdict, losses and the map of where and when it acts."""
    fitted = record["open"]
    if fitted is None:
        return ""
    rates = [fitted["values"][name] for name in OPEN_DRAG]
    said = "explains part of the mismatch" if fitted["explains"] else "does not explain the mismatch"
    return (f"<h3>An open drag</h3><p>No candidate was named, so a generic drag (a rate that is free near the floor "
            f"and above it, early and late) was fitted with the law: it {said} (change of the criterion "
            f"{fitted['delta_criterion']:+.2f}; fitted loss {_value(fitted['loss_px'])} px, held out between "
            f"{_value(fitted['held_out_loss_px'])} px, last frames {_value(fitted['forecast_loss_px'])} px). It "
            f"{fitted['words']}.</p>"
            + figure_tag(open_drag_figure(rates), "the open drag's rate over height and time: red holds the "
                         "material back, blue drives the flow"))


def _value(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def closest_text(record: dict) -> str:
    """Where no candidate is named, the one that lowers the criterion most: how far it came and what its refit did
    to the held-out losses."""
    if record["chosen"] is not None or not record["candidates"]:
        return ""
    closest = min(record["candidates"], key=lambda c: c["delta_criterion"])
    if closest["delta_criterion"] >= 0:
        return "<p>No candidate lowers the criterion.</p>"
    changes = held_out_changes(closest, record["base"], ("between fitted frames", "last frames"))
    threshold = named_below(record["evidence"], (record.get("recheck") or {}).get("delta_criterion"))
    return (f"<p>Closest to being named: {closest['title']}, criterion {closest['delta_criterion']:+.1f} (named "
            f"below {threshold:.3g})" + (f"; its refit's held-out loss {', '.join(changes)}" if changes else "")
            + ".</p>")


def section(record: dict, maps: bytes | None = None, extra: str = "") -> str:
    """HTML of the diagnosis ``record`` (diagnosis.json)."""
    chosen = record["chosen"]
    losses = record["loss_before_after_px"]
    before = losses["fitted"]

    def gain(pair: list[float | None], words: str) -> str:
        if chosen is None or (change := loss_change(*pair)) is None:
            return ""
        return f" {words} {_value(pair[0])} px before, {_value(pair[1])} px after: {change:+.0f} % change."

    gains = (gain(losses["held_out"], "Loss on the frames held out between fitted ones")
             + gain(losses["forecast"], "Loss on the last frames, held out as a prediction"))
    verdict = (f"<p><b>Verdict: {record['verdict']}</b>"
               + ("" if chosen is None else f", fitted magnitude {_value(record['magnitude'])}") + ". "
               f"Fitted frames' loss {_value(before[0])} px before, {_value(before[1])} px after.{gains}</p>")
    mismatch = "".join(f"<p>{name}: {m['words']}</p>" for name, m in record["mismatch"].items())

    def row(model: str, delta: str, fit: dict, note: str) -> list[str]:
        return [model, delta, _value(fit["loss_px"]), _value(fit["held_out_loss_px"]),
                _value(fit["forecast_loss_px"]), note, ", ".join(f"{k} {_value(v)}" for k, v in fit["values"].items())]

    rows = [row("base model", "0", record["base"], "-")]
    if recheck := record.get("recheck"):
        rows.append(row("base model, refitted from the winner's law", f"{recheck['delta_criterion']:+.2f}", recheck,
                        ""))
    rows += [row(c["title"], f"{c['delta_criterion']:+.2f}", c, "decoy" if c["decoy"] else "")
             for c in record["candidates"]]
    table = table_tag(["model", "change of the criterion", "fitted loss (px)", "held-out loss, between (px)",
                       "held-out loss, last frames (px)", "", "values"], rows)
    criterion = (f"<p>Ranked by {record['criterion']}; an effect is named when it lowers the criterion by more "
                 f"than {record['evidence']:g}" + (", and below the base model refitted from its law" if "recheck" in
                                                   record else "") + ".</p>")
    figure = "" if maps is None else image_tag(maps, "png", "residual maps before and after the refit")
    profiles = ("" if not any(c.get("profile") for c in record["candidates"]) else figure_tag(
        profiles_figure(record["candidates"], record["base"]["loss_px"]),
        "each candidate's profile: the lowest loss with the effect held at each magnitude, the law refitted there "
        "(dashed: the base fit; in brackets, the change of the criterion; red: decoys)"))
    return (verdict + closest_text(record) + mismatch + criterion + table + profiles + open_drag_section(record)
            + figure + extra)


def confusion_figure(truths: list[str], named: list[str], labels: list[str]):
    """Counts of (true effect, named effect)."""
    index = {label: i for i, label in enumerate(labels)}
    counts = np.zeros((len(labels), len(labels)), int)
    for t, n in zip(truths, named, strict=True):
        counts[index[t], index[n]] += 1
    fig, ax = plt.subplots(figsize=(1.0 + 0.6 * len(labels), 0.8 + 0.5 * len(labels)))
    ax.imshow(counts, cmap="Blues")
    for i in range(len(labels)):
        for j in range(len(labels)):
            if counts[i, j]:
                ax.text(j, i, str(counts[i, j]), ha="center", va="center", fontsize=9)
    ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize=8)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    ax.set_xlabel("named by the diagnosis")
    ax.set_ylabel("concealed in the recording")
    fig.tight_layout()
    return fig


def confusion_section(truths: list[str], named: list[str], labels: list[str]) -> str:
    counts = [[str(sum(1 for t, n in zip(truths, named, strict=True) if t == row and n == col)) for col in labels]
              for row in labels]
    return (table_tag(["concealed \\ named", *labels], [[row, *c] for row, c in zip(labels, counts, strict=True)])
            + figure_tag(confusion_figure(truths, named, labels),
                         "cases by the effect concealed in the recording (rows) and the one the diagnosis named "
                         "(columns): a correct diagnosis lies on the diagonal; outside: an effect no candidate "
                         "models, for which none is the right answer"))
