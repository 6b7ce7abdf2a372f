"""The thesis' column-collapse tables reproduced: our heights beside the thesis', with Figures 4.2 and 4.4."""

from __future__ import annotations

import csv
import io

import matplotlib.pyplot as plt

from rheo.report.html import figure_tag, page, table_tag

COLUMNS = ["table", "sigma_y", "eta", "eta_over_sigma_y", "thesis_height", "rheo_height", "relative_difference"]


def rows_from_runs(table: str, runs: list[dict], thesis: dict[float, float], key) -> list[dict]:
    rows = []
    for run in sorted(runs, key=key):
        ref = thesis[key(run)]
        rows.append({"table": table, "sigma_y": run["sigma_y"], "eta": run["eta"],
                     "eta_over_sigma_y": run["eta"] / run["sigma_y"], "thesis_height": ref,
                     "rheo_height": run["height"], "relative_difference": (run["height"] - ref) / ref,
                     "times": run["times"], "heights": run["heights"]})
    return rows


def to_csv(rows: list[dict]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def _comparison_plot(rows: list[dict], x: str, xlabel: str, title: str):
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    xs = [r[x] for r in rows]
    ax.plot(xs, [r["thesis_height"] for r in rows], "o-", label="thesis")
    ax.plot(xs, [r["rheo_height"] for r in rows], "s--", label="rheo")
    ax.set_xscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("height at t = 1 s (m)")
    ax.set_title(title)
    ax.legend()
    ax.grid(alpha=0.3)
    return fig


def _history_plot(rows: list[dict], label: str, title: str):
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for r in rows:
        ax.plot(r["times"], r["heights"], label=f"{label} = {r[label]:g}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("height (m)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def render(table_41: list[dict], table_42: list[dict], calibration: dict, tolerance: float = 0.10) -> str:
    def html_rows(rows, first):
        cells = [[f"{r[first]:g}", f"{r['thesis_height']:.5f}", f"{r['rheo_height']:.5f}",
                  f"{100 * r['relative_difference']:+.1f} %"] for r in rows]
        classes = ["good" if abs(r["relative_difference"]) <= tolerance else "bad" for r in rows]
        return cells, classes

    t41, c41 = html_rows(table_41, "sigma_y")
    t42, c42 = html_rows(table_42, "eta_over_sigma_y")
    candidates = table_tag(["mu (Pa)", "lam (Pa)", "RMS relative difference on Table 4.1"],
                           [[f"{c['mu']:g}", f"{c['lam']:g}", f"{c['rms_relative_difference']:.3f}"]
                            for c in calibration["candidates"]])
    within = sum(abs(r["relative_difference"]) <= tolerance for r in table_41 + table_42)
    body = (
        f"<p>Cylinder of radius 0.2 m and height 0.4 m, density 1000 kg/m^3, gravity 9.8 m/s^2, on a sticky floor wide "
        f"enough that no pile reaches the domain walls; height = top of the material at t = 1 s (m). The thesis' "
        f"(sigma_y in Pa, eta in Pa s) are "
        f"PAC-NeRF's convention and enter rheo "
        f"as tau_y = sigma_y / sqrt(3), K = eta / 2. Elastic constants calibrated on Table 4.1 only: "
        f"mu = {calibration['mu']:g} Pa, lam = {calibration['lam']:g} Pa; Table 4.2 is predicted with no further "
        f"tuning. {within} of {len(table_41) + len(table_42)} rows lie within {100 * tolerance:.0f} %.</p>"
        "<h2>Table 4.1: varying sigma_y (eta = 10)</h2>"
        + table_tag(["sigma_y (Pa)", "thesis (m)", "rheo (m)", "difference"], t41, c41)
        + "<h2>Table 4.2: varying eta / sigma_y (sigma_y = 1000), predicted</h2>"
        + table_tag(["eta / sigma_y (s)", "thesis (m)", "rheo (m)", "difference"], t42, c42)
        + "<h2>Figures 4.2 and 4.4</h2>"
        + figure_tag(_comparison_plot(table_41, "sigma_y", "sigma_y (Pa)", "Figure 4.2: height vs sigma_y"),
                     "Height at t = 1 s against sigma_y: thesis and rheo")
        + figure_tag(_comparison_plot(table_42, "eta_over_sigma_y", "eta / sigma_y (s)",
                                      "Figure 4.4: height vs eta / sigma_y"),
                     "Height at t = 1 s against eta / sigma_y: thesis and rheo")
        + "<h2>Height over time</h2>"
        + figure_tag(_history_plot(table_41, "sigma_y", "Table 4.1 runs"), "Height over time, Table 4.1")
        + figure_tag(_history_plot(table_42, "eta_over_sigma_y", "Table 4.2 runs"),
                     "Height over time, Table 4.2")
        + "<h2>Calibration of the elastic constants</h2>" + candidates
    )
    return page("Column collapse: thesis Tables 4.1 and 4.2", body)
