"""Convergence of a simulated dam break under grid and time-step refinement.

Herschel-Bulkley laws are simulated against a material's recordings on a sequence of grids (cells over each setup's
height) at several time steps (``cfl``). Per setup, law, grid and step: the loss (px), and at the recorded frame
interval after the release the share of the material past the gate and how far its front has gone (m). From the
three finest grids, the observed order of convergence and a Richardson-extrapolated limit of each quantity; how far
the fit's default grid lies from that limit; how much the flow moves between the smallest and the largest step; and
which law comes closer to the recordings at each resolution. A law that describes the material should win once the
grid resolves the flow; while the quantities still move with the grid or the step, so will the law a fit recovers.

Every simulation is stored with a fingerprint of the engine's source, so a study resumes where it stopped and a
changed engine recomputes.

    python -m rheo.fit.convergence --material Lotion --grids 8 12 16 --cfl 0.4 0.8 --out results/bench/Lotion.json
    python -m rheo.fit.convergence --material Lotion --grids 24 32 48 --device cuda --out results/bench/Lotion_cuda.json
    python -m rheo.fit.convergence --material Lotion --grids 24 32 --lam 1e5 --device cuda --out results/bench/lam.json
    python -m rheo.fit.convergence --material Lotion --setups ref_Lotion_7.0_7.0_2 --grids 16 24 32 48 --cfl 0.8 \
        --law 14.8,0.792,1 --workers 1 --out results/bench/Lotion_7cm.json
    python -m rheo.fit.convergence --material Lotion --grids 12 --cfl 0.2 0.8 \
        --store results/bench/Lotion.evaluations.json --out results/bench/Lotion_cfl.json
"""

from __future__ import annotations

import argparse
import ast
import fcntl
import hashlib
import io
import itertools
import json
import logging
import math
import time
import tokenize
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache, partial
from pathlib import Path

import numpy as np
from scipy.optimize import brentq
from tqdm.auto import tqdm

from rheo.config import ROOT, WORKFLOW_CONFIG, workflow_settings
from rheo.experiments.dam_break import dam_break_scene
from rheo.experiments.rheometer import fit_herschel_bulkley, pooled, read_flow_curve
from rheo.experiments.virheometry import FPS, Setup, read_setup, setup_folders
from rheo.fit.dam_break import OFFSET_STEP, DamBreakTarget, target
from rheo.fit.parallel import Evaluator
from rheo.io import evaluations_path, write_json_atomic
from rheo.physics.device import DEVICES, device_name, set_default_device

logger = logging.getLogger(__name__)

Law = tuple[float, float, float]  # tau_y (Pa), K (Pa s^n), n
# the sources a simulated dam break and its loss depend on: a change to any of them recomputes stored evaluations
ENGINE_SOURCES = ("rheo/physics", "rheo/experiments/dam_break.py", "rheo/experiments/effects.py",
                  "rheo/experiments/virheometry.py", "rheo/fit/dam_break.py", "rheo/render/silhouette.py")
QUANTITIES = {"loss_px": "loss (px)", "outflow": "share of the material past the gate",
              "front_m": "front past the gate (m)"}
KEYED_SETTINGS = ("particles_per_cell", "mu", "lam", "max_offset", "transfer_cfl")  # in every stored record's key
STUDY_ACROSS = 3  # cells across the channel on the study's grids: the height sets the cell


def code_text(source: str) -> str:
    """Python source less its comments, docstrings, blank lines and trailing spaces: the same text on every Python
    version (a syntax tree's dump or unparsed form is not)."""
    lines = source.splitlines()
    cuts = [(*t.start, *t.end) for t in tokenize.generate_tokens(io.StringIO(source).readline)
            if t.type == tokenize.COMMENT]
    for node in ast.walk(ast.parse(source)):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            doc = body[0]  # the syntax tree counts columns in UTF-8 bytes, the tokenizer in characters
            start = len(lines[doc.lineno - 1].encode()[:doc.col_offset].decode())
            end = len(lines[doc.end_lineno - 1].encode()[:doc.end_col_offset].decode())
            cuts.append((doc.lineno, start, doc.end_lineno, end))
    for first_row, first_col, last_row, last_col in sorted(cuts, reverse=True):
        lines[first_row - 1:last_row] = [lines[first_row - 1][:first_col] + lines[last_row - 1][last_col:]]
    return "\n".join(line.rstrip() for line in lines if line.strip())


def engine_fingerprint() -> str:
    """A hash of the engine's code (``code_text`` of its source files)."""
    hasher = hashlib.sha256()
    for name in ENGINE_SOURCES:
        path = ROOT / name
        for f in sorted(path.rglob("*.py")) if path.is_dir() else [path]:
            hasher.update(f.relative_to(ROOT).as_posix().encode())
            hasher.update(code_text(f.read_text()).encode())
    return hasher.hexdigest()[:16]


def outflow_pixels(silhouette: np.ndarray, container: np.ndarray) -> int:
    """Pixels of a silhouette outside the container: the material past the gate."""
    return int((silhouette & ~container).sum())


def measure(compared: DamBreakTarget, law: Law) -> dict:
    """One simulation of ``law`` against a setup: its loss and the flow at every recorded frame interval after the
    release (share of the particles past the gate, the front's distance past it)."""
    start = time.perf_counter()
    trajectory = compared.simulate(*law)
    comparison = compared.score(trajectory)
    x = compared.scene.positions(trajectory)[..., 0]
    samples = np.arange(compared.frame_steps, len(x), compared.frame_steps)
    past = x[samples] - compared.setup.width
    return {"h_m": compared.scene.dx, "resolution": compared.scene.resolution,
            "particles": len(compared.scene.initial_positions), "time_step_s": trajectory.dt,
            "loss_px": comparison.loss, "offset_s": comparison.offset,
            "times_s": (samples * OFFSET_STEP).tolist(), "outflow": (past > 0).mean(axis=1).tolist(),
            "front_m": np.maximum(past.max(axis=1), 0.0).tolist(),
            "outflow_px": [outflow_pixels(s, compared.container) for s in comparison.silhouettes],
            "recorded_outflow_px": [outflow_pixels(m, compared.container) for m in compared.masks],
            "seconds": round(time.perf_counter() - start, 1)}


@dataclass(frozen=True)
class Case:
    """One simulation of the study: a setup (its folder, read at ``fps``), a law, a grid (cells over the height,
    across) and a step."""

    folder: str
    label: str
    law: Law
    cells_per_height: int
    cells_across: int
    cfl: float
    grids: tuple[str, ...]  # every grid of the study (CxA) that gives this setup this cell
    fps: float

    def simulation(self, base: dict) -> dict:
        return {**base, "cells_per_height": self.cells_per_height, "cells_across": self.cells_across,
                "cfl": self.cfl}


class Targets(dict):
    """Targets by (setup folder, frame rate, simulation settings) as JSON, built when first asked for (in a worker
    process)."""

    def __init__(self, scale: float) -> None:
        super().__init__()
        self.scale = scale

    def __missing__(self, name: str) -> Callable[[np.ndarray], dict]:
        folder, fps, simulation = json.loads(name)
        compared = target(_setup(folder, self.scale, fps), simulation)
        self[name] = partial(measure, compared)
        return self[name]


@cache
def _setup(folder: str, scale: float, fps: float) -> Setup:
    return read_setup(folder, scale, fps)


def _targets(scale: float) -> Targets:
    return Targets(scale)


class StudyRecords(dict):
    """A study's results by label, kept in a JSON file under the engine's fingerprint beside those stored with other
    engines, so that a study run again with the same engine replays them; ``save`` writes the file atomically."""

    def __init__(self, path: Path) -> None:
        self.path, self.fingerprint = Path(path), engine_fingerprint()
        self.stored = json.loads(self.path.read_text()) if self.path.is_file() else {}
        super().__init__(self.stored.get(self.fingerprint, {}))

    def save(self) -> None:
        write_json_atomic(self.path, {**self.stored, self.fingerprint: dict(self)})


class EvaluationStore:
    """Measured simulations in a JSON file, by case and engine fingerprint, written atomically after each. Studies
    running side by side may share one: each write merges the records the others wrote, under a lock."""

    def __init__(self, path: Path, fingerprint: str) -> None:
        self.path, self.fingerprint = Path(path), fingerprint
        self.records: dict[str, dict] = json.loads(self.path.read_text()) if self.path.is_file() else {}

    def key(self, case: Case, simulation: dict) -> str:
        """The case and every simulation setting it does not set itself; beyond the first five, only those given
        (wall slip, say), and the frame rate where not the recordings' own, so that the keys of stored studies stay
        as they were."""
        settings = {k: simulation.get(k) for k in KEYED_SETTINGS}
        settings |= {k: v for k, v in simulation.items()
                     if k not in (*KEYED_SETTINGS, "cells_per_height", "cells_across", "cfl") and v is not None}
        if case.fps != FPS:
            settings["fps"] = case.fps
        return json.dumps([self.fingerprint, case.folder, [float(v) for v in case.law], case.cells_per_height,
                           case.cells_across, case.cfl, settings])

    def get(self, case: Case, simulation: dict) -> dict | None:
        """The record of the case, or of one whose law agrees within a part in 1e6 (a law fitted to rheometer
        curves differs in the eighth digit from one machine's SciPy to another's)."""
        key = self.key(case, simulation)
        if key in self.records:
            return self.records[key]
        wanted = json.loads(key)  # [fingerprint, folder, law, grid and settings...]
        for stored, record in self.records.items():
            parts = json.loads(stored)
            if parts[:2] + parts[3:] == wanted[:2] + wanted[3:] and np.allclose(parts[2], wanted[2], rtol=1e-6,
                                                                                 atol=0.0):
                return record
        return None

    def put(self, case: Case, simulation: dict, record: dict) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path.with_name(f".{self.path.name}.lock"), "w") as lock:  # hidden: not archived
            fcntl.flock(lock, fcntl.LOCK_EX)
            if self.path.is_file():
                self.records |= json.loads(self.path.read_text())
            self.records[self.key(case, simulation)] = record
            write_json_atomic(self.path, self.records)


def run(cases: Sequence[Case], simulation: dict, scale: float, store: EvaluationStore, workers: int) -> list[dict]:
    """Every case measured (stored ones replayed), ``workers`` simulations side by side, the costliest first."""
    todo = [c for c in cases if store.get(c, simulation) is None]
    logger.info("%d of %d simulations stored; %d to run", len(cases) - len(todo), len(cases), len(todo))
    # cost grows as the fourth power of the cells over the height (particles and steps)
    todo.sort(key=lambda c: -(max(c.cells_per_height, c.cells_across) ** 4) / c.cfl)
    with Evaluator(partial(_targets, scale), workers) as evaluator, \
            tqdm(total=len(todo), desc="convergence study", unit="simulation") as bar:
        for first in range(0, len(todo), workers):
            batch = todo[first:first + workers]
            tasks = [(json.dumps([c.folder, c.fps, c.simulation(simulation)]), np.array(c.law)) for c in batch]
            for case, record in zip(batch, evaluator.map(tasks), strict=True):
                store.put(case, simulation, record)
                logger.info("%s %s %dx%d cfl %g: %.4f px, %.1f s", Path(case.folder).name, case.label,
                            case.cells_per_height, case.cells_across, case.cfl, record["loss_px"], record["seconds"])
                bar.update()
    return [{"setup": Path(c.folder).name, "law": c.label, "tau_y_Pa": c.law[0], "K_Pa_s_n": c.law[1], "n": c.law[2],
             "grids": list(c.grids), "cfl": c.cfl, **store.get(c, simulation)}
            for c in cases]


def observed_order(h: Sequence[float], q: Sequence[float]) -> float | None:
    """The order p of q(h) = q0 + c h^p through three points of decreasing h (None where the differences change
    sign or no p in (0.05, 10) fits: not yet converging monotonically)."""
    (h1, h2, h3), (q1, q2, q3) = h, q
    d21, d32 = q2 - q1, q3 - q2
    if d21 == 0 or d32 == 0 or (d21 > 0) != (d32 > 0):
        return None
    ratio = d21 / d32

    def mismatch(p: float) -> float:
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    try:
        return brentq(mismatch, 0.05, 10.0)
    except ValueError:
        return None


def richardson(h: Sequence[float], q: Sequence[float]) -> dict:
    """From the three finest grids (h decreasing): the observed order, the extrapolated limit q0 and the finest
    grid's relative distance from it (all None where the values do not converge monotonically)."""
    order = observed_order(h[-3:], q[-3:]) if len(h) >= 3 else None
    if order is None:
        return {"order": None, "limit": None, "finest_error": None}
    h2, h3 = h[-2] ** order, h[-1] ** order
    limit = q[-1] + (q[-1] - q[-2]) * h3 / (h2 - h3)
    return {"order": order, "limit": limit, "finest_error": relative(q[-1], limit)}


def relative(value: float, reference: float | None) -> float | None:
    """|value - reference| / |reference| (None without a reference or at a reference of 0)."""
    if reference is None or reference == 0:
        return None
    return abs(value - reference) / abs(reference)


def last(row: dict, quantity: str) -> float:
    """A row's value of ``quantity`` (at the last frame interval for the flow's)."""
    value = row[quantity]
    return value[-1] if isinstance(value, list) else value


def summarize(rows: list[dict], default_h: dict[str, float]) -> dict:
    """Per setup, law and step: each quantity's values over the grids with their order, limit and the default
    grid's distance from the limit (``default_h``: each setup's cell at the fit's default grid); per grid and step,
    each law's loss per setup and joint and which law wins; per setup, law and grid, how much the flow moves between
    the smallest and the largest step."""
    setups, laws = sorted({r["setup"] for r in rows}), sorted({r["law"] for r in rows})
    cfls = sorted({r["cfl"] for r in rows})
    convergence = []
    for setup, law, cfl in itertools.product(setups, laws, cfls):
        series = sorted((r for r in rows if (r["setup"], r["law"], r["cfl"]) == (setup, law, cfl)),
                        key=lambda r: -r["h_m"])
        if not series:
            continue
        h = [r["h_m"] for r in series]
        entry = {"setup": setup, "law": law, "cfl": cfl, "h_m": h, "quantities": {}}
        for quantity in QUANTITIES:
            values = [last(r, quantity) for r in series]
            fit = richardson(h, values)
            at_default = next((v for hh, v in zip(h, values, strict=True) if math.isclose(hh, default_h[setup])), None)
            entry["quantities"][quantity] = {"values": values, **fit,
                                             "default_error": None if at_default is None
                                             else relative(at_default, fit["limit"])}
        convergence.append(entry)
    contests = []
    grids = sorted({g for r in rows for g in r["grids"]}, key=lambda g: [int(v) for v in g.split("x")])
    for grid, cfl in itertools.product(grids, cfls):
        losses = {law: {r["setup"]: r["loss_px"] for r in rows
                        if grid in r["grids"] and (r["cfl"], r["law"]) == (cfl, law)} for law in laws}
        if not all(len(v) == len(setups) for v in losses.values()):
            continue
        joint = {law: float(np.mean(list(v.values()))) for law, v in losses.items()}
        per_setup = {s: min(laws, key=lambda law, s=s: losses[law][s]) for s in setups}
        contests.append({"grid": grid, "cfl": cfl, "losses": losses, "joint": joint,
                         "winner": min(joint, key=joint.get), "winner_per_setup": per_setup})
    steps = []
    for setup, law in itertools.product(setups, laws):
        for h in sorted({r["h_m"] for r in rows if r["setup"] == setup}, reverse=True):
            series = sorted((r for r in rows if (r["setup"], r["law"], r["h_m"]) == (setup, law, h)),
                            key=lambda r: r["cfl"])
            if len(series) < 2:
                continue
            small, large = series[0], series[-1]
            steps.append({"setup": setup, "law": law, "grids": small["grids"], "h_m": h,
                          "cfl": [small["cfl"], large["cfl"]],
                          **{quantity: relative(last(large, quantity), last(small, quantity))
                             for quantity in ("outflow", "front_m")}})
    return {"convergence": convergence, "contests": contests, "time_steps": steps}


def rheometer_law(files: list[str], band: tuple[float, float] | None) -> Law:
    """The Herschel-Bulkley law fitted to all the rheometer's points (within ``band``, 1/s, if given)."""
    curve = pooled([read_flow_curve(f) for f in files])
    return fit_herschel_bulkley(curve.within(band) if band is not None else curve)


def material_rheometer_law(config: dict, material: str) -> Law:
    """``material``'s rheometer law within the convergence study's band (``config``: the virheometry settings)."""
    return rheometer_law(config["rheometer"][material], config["convergence"]["rheometer_band"])


def study_cases(setups: Sequence[Setup], laws: dict[str, Law], grids: Sequence[int], cfls: Sequence[float],
                default: tuple[int, int]) -> list[Case]:
    """Every setup, law, step and grid (``grids``: cells over the height, and the fit's ``default`` grid), grids
    that give a setup the same cell simulated once."""
    shapes = [(c, STUDY_ACROSS) for c in grids] + [default]
    cases = []
    for setup in setups:
        by_cell: dict[float, list[tuple[int, int]]] = {}
        for cells, across in shapes:
            by_cell.setdefault(round(dam_break_scene(setup, cells, across).dx, 12), []).append((cells, across))
        for same, (label, law), cfl in itertools.product(by_cell.values(), laws.items(), cfls):
            cases.append(Case(str(setup.folder), label, tuple(float(v) for v in law), *same[0], cfl,
                              tuple(f"{c}x{a}" for c, a in same), setup.fps))
    return cases


def default_cells(setups: Sequence[Setup], simulation: dict) -> dict[str, float]:
    """Each setup's cell (m) at the fit's default grid."""
    return {s.folder.name: dam_break_scene(s, simulation["cells_per_height"], simulation["cells_across"]).dx
            for s in setups}


def grid(text: str) -> int:
    try:
        cells = int(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"grid {text!r}: expected cells over the material's height, e.g. 12") \
            from err
    if cells < 3:
        raise argparse.ArgumentTypeError(f"grid {text!r}: at least 3 cells over the material's height")
    return cells


def law(text: str) -> Law:
    try:
        tau_y, K, n = (float(v) for v in text.split(","))
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"law {text!r}: expected tau_y,K,n, e.g. 4.5,7,0.47") from err
    return tau_y, K, n


def modulus(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"modulus {text!r}: expected a positive number of Pa, e.g. 1e5")
    return value


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--material", required=True)
    parser.add_argument("--grids", type=grid, nargs="+", required=True, help="cells over the material's height")
    parser.add_argument("--cfl", type=float, nargs="+", help="time steps, as fractions of a cell's crossing time")
    parser.add_argument("--law", type=law, action="append", default=[], help="tau_y,K,n (repeatable)")
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--store", type=Path, help="simulations to replay and extend, which studies may share "
                        "(default: beside --out, its .evaluations.json)")
    parser.add_argument("--mu", type=modulus, help="shear modulus (Pa) in place of the config's")
    parser.add_argument("--lam", type=modulus, help="Lame's lambda (Pa) in place of the config's")
    parser.add_argument("--setups", nargs="+", help="the setups' folder names to study (default: all the material's)")
    parser.add_argument("--config", type=Path, default=WORKFLOW_CONFIG)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--device", choices=DEVICES, default="cpu", help="cuda: one simulation at a time on the GPU")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO)
    set_default_device(args.device)
    config = workflow_settings(args.config)["virheometry"]
    laws = {f"given {i + 1}": given for i, given in enumerate(args.law)}
    if args.material in config["rheometer"]:
        laws["rheometer"] = material_rheometer_law(config, args.material)
    if not laws:
        parser.error(f"{args.material}: no law to simulate (give --law; no rheometer curves)")
    simulation = config["simulation"] | {k: v for k, v in (("mu", args.mu), ("lam", args.lam)) if v is not None}
    folders = setup_folders(config["data"], args.material)
    if args.setups:
        unknown = set(args.setups) - {f.name for f in folders}
        if unknown:
            parser.error(f"{args.material} has no setup {', '.join(sorted(unknown))} (its setups: "
                         f"{', '.join(f.name for f in folders)})")
        folders = [f for f in folders if f.name in args.setups]
    setups = [read_setup(f, config["scale"], config["fps"]) for f in folders]
    cases = study_cases(setups, laws, args.grids, args.cfl or [simulation["cfl"]],
                        (simulation["cells_per_height"], simulation["cells_across"]))
    store = EvaluationStore(args.store or evaluations_path(args.out), engine_fingerprint())
    rows = run(cases, simulation, config["scale"], store, args.workers)
    default_h = default_cells(setups, simulation)
    write_json_atomic(args.out, {"material": args.material, "device": device_name(), "laws": laws,
                                 "simulation": simulation, "rows": rows,
                                 **summarize(rows, default_h)})


if __name__ == "__main__":
    main()
