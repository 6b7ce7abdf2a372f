"""Lotion's laws that several studies compare, as their stores label them (docs/real-data.md): its joint fit at the
default settings, rounded, its rheometer's law, and three laws of that fit's flow-index profile; and the arguments
that name another material's fit in their place."""

import argparse
from pathlib import Path

from rheo.fit.convergence import material_rheometer_law

BINGHAM = (14.5, 0.978, 1.0)
SHAPES = {"n 0.55": (2.4576, 6.5717, 0.55), "n 1": (14.4528, 0.97793, 1.0), "n 1.4": (17.2573, 0.20308, 1.4)}


def lotion_laws(config: dict) -> dict[str, tuple[float, float, float]]:
    """The two laws the studies compare: Lotion's rounded joint fit and its rheometer's law (``config``: the
    workflow's ``virheometry`` settings)."""
    return {"bingham": BINGHAM, "rheometer": material_rheometer_law(config, "Lotion")}


def add_material_arguments(parser: argparse.ArgumentParser) -> None:
    """``--material`` (Lotion by default) and ``--fit``, the joint fit (params.json) that gives another material's
    laws."""
    parser.add_argument("--material", default="Lotion")
    parser.add_argument("--fit", type=Path, help="the material's joint fit (params.json); Lotion's laws by default")


def require_fit(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse a material other than Lotion without its fit: the laws written here are Lotion's."""
    if args.material != "Lotion" and args.fit is None:
        parser.error(f"--fit is needed for {args.material}: the laws shipped are Lotion's")
