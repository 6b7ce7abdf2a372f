"""The convergence study's page: which law wins at each resolution, each quantity against the cell size with its
extrapolated limit, the flow over time on every grid, the time step's effect, and each law against the recording
frame by frame."""

from __future__ import annotations

import itertools
import math

import matplotlib.pyplot as plt

from rheo.fit.convergence import QUANTITIES
from rheo.report.html import figure_tag, page, table_tag

LINESTYLES = ("-", "--", ":", "-.")


def _number(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def refinement_figure(result: dict, setup: str):
    """Each quantity against the cell size, per law and step, with the extrapolated limits."""
    entries = [e for e in result["convergence"] if e["setup"] == setup]
    laws = sorted({e["law"] for e in entries})
    cfls = sorted({e["cfl"] for e in entries})
    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(4.2 * len(QUANTITIES), 3.4))
    for ax, (quantity, label) in zip(axes, QUANTITIES.items(), strict=True):
        for entry in entries:
            colour = f"C{laws.index(entry['law'])}"
            q = entry["quantities"][quantity]
            h_mm = [1e3 * h for h in entry["h_m"]]
            ax.plot(h_mm, q["values"], marker="o", color=colour, ls=LINESTYLES[cfls.index(entry["cfl"]) % 4],
                    label=f"{entry['law']}, cfl {entry['cfl']:g}")
            if q["limit"] is not None:
                ax.plot([0.0], [q["limit"]], marker="*", ms=10, color=colour, ls="none")
        ax.axvline(1e3 * result["default_h_m"][setup], color="0.6", lw=0.8)
        ax.set_xlim(left=0.0)
        ax.set_xlabel("cell (mm)")
        ax.set_title(label, fontsize=10)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{setup}: values at the last frame interval; stars: Richardson limits; grey: default grid",
                 fontsize=10)
    fig.tight_layout()
    return fig


def _rows(result: dict, setup: str, cfl: float) -> list[dict]:
    return [r for r in result["rows"] if r["setup"] == setup and r["cfl"] == cfl]


def flow_figure(result: dict, setup: str, cfl: float):
    """The share of the material past the gate over time, per grid and law, at one step."""
    rows = _rows(result, setup, cfl)
    laws = sorted({r["law"] for r in rows})
    cells = sorted({r["h_m"] for r in rows}, reverse=True)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for row in rows:
        style = dict(color=f"C{laws.index(row['law'])}", alpha=0.35 + 0.65 * cells.index(row["h_m"]) / max(
            len(cells) - 1, 1))
        axes[0].plot(row["times_s"], row["outflow"], **style)
        axes[1].plot(row["times_s"], [1e2 * f for f in row["front_m"]], **style)
    for law in laws:
        axes[0].plot([], [], color=f"C{laws.index(law)}", label=law)
    axes[0].legend(fontsize=8, title="darker: finer grid", title_fontsize=8)
    axes[0].set_ylabel("share past the gate")
    axes[1].set_ylabel("front past the gate (cm)")
    for ax in axes:
        ax.set_xlabel("time after the release (s)")
    fig.suptitle(f"{setup}, cfl {cfl:g}", fontsize=10)
    fig.tight_layout()
    return fig


def frames_figure(result: dict, setup: str, cfl: float):
    """The material outside the container at each recorded frame, recorded and simulated by each law on the
    default grid (each at the release time its comparison chose)."""
    rows = sorted((r for r in _rows(result, setup, cfl) if math.isclose(r["h_m"], result["default_h_m"][setup])),
                  key=lambda r: r["law"])
    fig, ax = plt.subplots(figsize=(5, 3.4))
    recorded = rows[0]["recorded_outflow_px"]
    frames = range(1, len(recorded) + 1)
    ax.plot(frames, recorded, "ko", label="recording")
    for i, row in enumerate(rows):
        ax.plot(frames, row["outflow_px"], "-", marker=".", color=f"C{i}", label=row["law"])
    ax.set_xlabel("frame")
    ax.set_ylabel("pixels outside the container")
    ax.legend(fontsize=8)
    ax.set_title(f"{setup}, default grid, cfl {cfl:g}", fontsize=10)
    fig.tight_layout()
    return fig


def render(result: dict) -> str:
    laws = sorted(result["laws"])
    setups = sorted(result["default_h_m"])
    law_text = "; ".join(f"{label}: tau_y {law[0]:.3g} Pa, K {law[1]:.3g} Pa s^n, n {law[2]:.3g}"
                         for label, law in sorted(result["laws"].items()))
    body = [f"<p>Laws: {law_text}. Engine {result['engine']}. Grids: cells over each setup's height "
            f"{result['study']['grids']} (and the fit's default grid, "
            f"{result['simulation']['cells_per_height']} x {result['simulation']['cells_across']}); steps "
            f"{result['study']['cfls']} of a cell's crossing time.</p>", "<h2>Which law comes closer</h2>"]
    contest_rows = []
    for contest in result["contests"]:
        cells = [contest["grid"], f"{contest['cfl']:g}"]
        for law in laws:
            cells += [_number(contest["losses"][law][s], 4) for s in setups] + [_number(contest["joint"][law], 4)]
        cells += [contest["winner"]]
        contest_rows.append(cells)
    header = ["grid", "cfl", *(f"{law} {name}" for law in laws for name in [*setups, "joint"]), "winner"]
    body.append(table_tag(header, contest_rows))
    body.append("<h2>Convergence under grid refinement</h2><p>Order and limit from the three finest grids "
                "(Richardson); '-' where the values do not converge monotonically. Errors relative to the "
                "limit.</p>")
    conv_rows = []
    for entry, quantity in itertools.product(result["convergence"], QUANTITIES):
        q = entry["quantities"][quantity]
        conv_rows.append([entry["setup"], entry["law"], f"{entry['cfl']:g}", quantity,
                          " / ".join(_number(v, 4) for v in q["values"]), _number(q["order"], 2),
                          _number(q["limit"], 4), _percent(q["finest_error"]), _percent(q["default_error"])])
    body.append(table_tag(["setup", "law", "cfl", "quantity", "coarse to fine", "order", "limit",
                           "finest grid's error", "default grid's error"], conv_rows))
    for setup in setups:
        body.append(figure_tag(refinement_figure(result, setup), f"{setup}: refinement"))
    body.append("<h2>The time step</h2><p>Change of the flow at the last frame interval from the smallest to the "
                "largest step, relative to the smallest's.</p>")
    body.append(table_tag(["setup", "law", "grids", "cell (mm)", "cfl", "share past the gate", "front"],
                          [[s["setup"], s["law"], ", ".join(s["grids"]), f"{1e3 * s['h_m']:.2f}",
                            " to ".join(f"{c:g}" for c in s["cfl"]), _percent(s["outflow"]), _percent(s["front_m"])]
                           for s in result["time_steps"]]))
    middle = sorted(result["study"]["cfls"])[len(result["study"]["cfls"]) // 2]
    for setup in setups:
        body.append(figure_tag(flow_figure(result, setup, middle), f"{setup}: the flow on every grid"))
    body.append("<h2>Against the recording, frame by frame</h2><p>Each law on the fit's default grid, timed as "
                "its comparison with the recording chose.</p>")
    for setup in setups:
        body.append(figure_tag(frames_figure(result, setup, middle), f"{setup}: frame by frame"))
    return page(f"{result['material']}: convergence of the simulated dam breaks", "".join(body))
