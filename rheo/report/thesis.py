"""The thesis report: the recovery Tables 4.3-4.5 from our fits beside the thesis' numbers, and the forward Tables
4.1 and 4.2 from the column-collapse runs."""

from __future__ import annotations

import html

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rheo.report.fit import SYMBOLS, interval_text
from rheo.report.html import figure_tag, page, table_tag


def recovery_rows(thesis_recovered: dict[str, float], params: dict) -> list[dict]:
    """One row per parameter: truth, initial guess, the thesis' recovered value and error, ours with its interval."""
    rows = []
    for name, ours in params["parameters"].items():
        truth = ours.get("truth")
        thesis = thesis_recovered.get(name)
        rows.append({"parameter": name, "truth": truth, "initial": ours["initial"], "thesis": thesis,
                     "thesis_error": None if thesis is None or truth is None else abs(thesis / truth - 1.0),
                     "rheo": ours["value"], "interval": interval_text(ours), "determined": ours["determined"],
                     "held": ours.get("held_at_initial_guess", False),
                     # a parameter held at its guess was not recovered, however near the truth the guess was
                     "rheo_error": None if truth is None or ours.get("held_at_initial_guess", False)
                     else abs(ours["value"] / truth - 1.0)})
    return rows


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def recovery_table(rows: list[dict]) -> str:
    header = ["parameter", "truth", "initial guess", "thesis", "thesis error", "rheo", "rheo tolerance interval",
              "rheo error"]
    cells, classes = [], []
    for r in rows:
        status = "" if r["determined"] else (" (not determined: held at the guess)" if r["held"]
                                             else " (not determined)")
        cells.append([SYMBOLS.get(r["parameter"], r["parameter"]), f"{r['truth']:.4g}", f"{r['initial']:.4g}",
                      "-" if r["thesis"] is None else f"{r['thesis']:.4g}", _percent(r["thesis_error"]),
                      f"{r['rheo']:.4g}{status}", r["interval"],
                      "not recovered" if r["held"] else _percent(r["rheo_error"])])
        # green only where the recording determines our value: an undetermined one near the truth is luck
        better = (r["determined"] and r["rheo_error"] is not None and r["thesis_error"] is not None
                  and r["rheo_error"] <= r["thesis_error"])
        classes.append("good" if better else "bad")
    return table_tag(header, cells, classes)


def error_figure(tables: list[tuple[str, list[dict]]]):
    """Percent error per parameter, thesis against rheo, one panel per table."""
    fig, axes = plt.subplots(1, len(tables), figsize=(4.2 * len(tables), 3.4), squeeze=False)
    for ax, (title, rows) in zip(axes[0], tables, strict=True):
        x = np.arange(len(rows))
        thesis = [100 * (r["thesis_error"] or 0.0) for r in rows]
        ours = [np.nan if r["rheo_error"] is None else 100 * r["rheo_error"] for r in rows]
        ax.bar(x - 0.2, thesis, 0.4, label="thesis", color="0.6")
        ax.bar(x + 0.2, ours, 0.4, label="rheo", color="tab:blue")
        for k in np.flatnonzero([r["held"] for r in rows]):
            ax.text(x[k] + 0.2, 0.0, "not recovered", rotation=90, ha="center", va="bottom", fontsize=7)
        ax.set_xticks(x, [SYMBOLS.get(r["parameter"], r["parameter"]) for r in rows])
        ax.set_ylabel("error (%)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def collapse_table(rows: list[dict], table: str) -> str:
    first, label = ("sigma_y", "sigma_y (Pa)") if table == "4.1" else ("eta_over_sigma_y", "eta / sigma_y (s)")
    picked = [r for r in rows if r["table"] == table]
    return table_tag([label, "thesis height (m)", "rheo height (m)", "difference"],
                     [[f"{float(r[first]):g}", f"{float(r['thesis_height']):.5f}", f"{float(r['rheo_height']):.5f}",
                       f"{100 * float(r['relative_difference']):+.1f} %"] for r in picked])


def render(tables: list[tuple[str, str, list[dict]]], collapse: list[dict]) -> str:
    """``tables``: (thesis table name, title, rows) per recovery table; ``collapse``: the rows of collapse.csv."""
    body = ["<p>Inverse experiments rebuilt from our runs of the thesis' virtual experiments with the thesis' "
            "initial guesses (rows in green: determined by the recording, our error at most the thesis'). Intervals: "
            "the materials whose loss lies within the fit model's tolerance of the best fit's; a parameter the "
            "recording does not determine is flagged, and held at its initial guess where that lies inside its "
            "interval.</p>",
            figure_tag(error_figure([(f"Table {name}: {title}", rows) for name, title, rows in tables]),
                       "percent error of each recovered parameter, thesis and rheo")]
    for name, title, rows in tables:
        body.append(f"<h2>Table {html.escape(name)}: {html.escape(title)}</h2>" + recovery_table(rows))
    body.append("<h2>Table 4.1: column collapse, varying sigma_y (eta = 10)</h2>" + collapse_table(collapse, "4.1"))
    body.append("<h2>Table 4.2: column collapse, varying eta / sigma_y (sigma_y = 1000)</h2>"
                + collapse_table(collapse, "4.2"))
    body.append("<p>Figures and the elastic constants' calibration of Tables 4.1 and 4.2: collapse.html.</p>")
    return page("rheo against the thesis: Tables 4.1-4.5", "".join(body))
