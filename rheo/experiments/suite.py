"""A suite of concealed-effect cases drawn from a seed: base laws, channels, elastic constants, release times, and
the effects (none, one, two, or one that no candidate models) with magnitudes from continuous ranges, under names
that say nothing of them. A new seed gives a new, unseen suite.

    python -m rheo.experiments.suite --seed 7 --count 20 --out config/experiments/suite_7

writes one case file per case (``concealed.cases`` then points at the folder) and the seed in ``suite.json``.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import yaml

from rheo.experiments.concealed import OUTSIDE_EFFECTS, RELEASE_STEP, anonymous

# Magnitudes (low, high), drawn log-uniformly, each well inside what the recording can show and the candidate's box.
MAGNITUDES: dict[str, tuple[float, float]] = {
    "floor_friction": (0.15, 1.0),  # Coulomb coefficient
    "wall_slip": (300.0, 1.0e4),  # Pa s/m
    "wall_adhesion": (5.0, 150.0),  # Pa
    "gate_lift": (0.03, 0.25),  # s
    "shear_thinning": (0.3, 0.8),  # flow index
    "thixotropy": (0.1, 3.0),  # breakdown per unit plastic strain
    "surface_tension": (0.02, 0.1),  # N/m
    "air_drag": (2.0, 60.0),  # 1/m
    "camera_roll": (1.5, 5.0),  # deg, either way: no candidate models it
    "camera_zoom": (0.015, 0.05),  # share of the focal length, either way: no candidate models it
}
KINDS = {"none": 0.15, "one": 0.55, "two": 0.15, "outside": 0.15}  # shares of the suite


def log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def uniform(rng: np.random.Generator, low: float, high: float) -> float:
    """A length (m), to a tenth of a millimetre."""
    return round(float(rng.uniform(low, high)), 4)


def draw_effect(rng: np.random.Generator, name: str) -> dict:
    magnitude = log_uniform(rng, *MAGNITUDES[name])
    if name in OUTSIDE_EFFECTS:
        magnitude *= rng.choice([-1.0, 1.0])
    return {"effect": name, "magnitude": round(float(magnitude), 4)}


def draw_case(rng: np.random.Generator, name: str, kind: str, fps: float) -> dict:
    """One case of ``kind`` (none, one, two or outside) for a scene filmed at ``fps``."""
    modelled = [e for e in MAGNITUDES if e not in OUTSIDE_EFFECTS]
    if kind == "none":
        effects = []
    elif kind == "outside":
        effects = [draw_effect(rng, str(rng.choice(OUTSIDE_EFFECTS)))]
    else:
        chosen = rng.choice(modelled, size=1 if kind == "one" else 2, replace=False)
        effects = [draw_effect(rng, str(e)) for e in chosen]
    # a low and a tall column, as the real recordings come, in view of the scene's camera
    channels = [{"height": uniform(rng, 0.03, 0.045), "width": uniform(rng, 0.035, 0.055)},
                {"height": uniform(rng, 0.05, 0.065), "width": uniform(rng, 0.035, 0.05)}]
    # around the fit's own elastic constants (virheometry.simulation: 300 Pa and 1e4 Pa)
    elastic = {"mu": round(log_uniform(rng, 100.0, 1000.0), 1), "lam": round(log_uniform(rng, 5.0e3, 2.0e4), 1)}
    frame_steps = round(1.0 / (fps * RELEASE_STEP))
    return {"name": name, "effects": effects,
            "law": {"tau_y": round(log_uniform(rng, 5.0, 40.0), 3), "K": round(log_uniform(rng, 0.5, 5.0), 3)},
            "channels": channels, "elastic": elastic,
            "release_s": int(rng.integers(1, frame_steps + 1)) * RELEASE_STEP}


def draw_suite(seed: int, count: int, fps: float = 24.0) -> list[dict]:
    """``count`` cases drawn from ``seed``: kinds in the shares ``KINDS`` (rounded; from four cases on every kind at
    least once; single effects make up the rest), in a drawn order, each named by a hash of the seed and its place."""
    rng = np.random.default_rng(seed)
    least = 1 if count >= len(KINDS) else 0
    counts = {kind: max(least, round(share * count)) for kind, share in KINDS.items() if kind != "one"}
    kinds = [kind for kind, n in counts.items() for _ in range(n)]
    kinds += ["one"] * (count - len(kinds))
    rng.shuffle(kinds)
    return [draw_case(rng, anonymous(f"{seed}:{k}"), kind, fps) for k, kind in enumerate(kinds)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--fps", type=float, default=24.0, help="the scene's frame rate (concealed.scene.fps)")
    parser.add_argument("--out", type=Path, required=True, help="a new folder for the case files")
    args = parser.parse_args()
    if args.out.exists() and any(args.out.iterdir()):
        parser.error(f"{args.out} exists and is not empty: a suite is drawn into a new folder")
    args.out.mkdir(parents=True, exist_ok=True)
    cases = draw_suite(args.seed, args.count, args.fps)
    for case in cases:
        (args.out / f"{case['name']}.yaml").write_text(yaml.safe_dump(case, sort_keys=False))
    (args.out / "suite.json").write_text(json.dumps({"seed": args.seed, "count": args.count, "fps": args.fps}))
    print(f"{len(cases)} cases drawn from seed {args.seed} into {args.out}")


if __name__ == "__main__":
    main()
