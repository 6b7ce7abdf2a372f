"""The proxy's shapes by their parameters: the keys each needs, their checks and the primitives' analytic volumes
(no mesh is built, so planning a run does not load the mesh library)."""

from __future__ import annotations

import math


class ProxyError(ValueError):
    """A proxy description or mesh that cannot be voxelised."""


REQUIRED = {"truncated_cone": ("base_diameter", "top_diameter", "height"), "spheroid": ("radius", "height"),
            "cylinder": ("radius", "height"), "box": ("extents",), "mesh": ("mesh",)}


def check_positive(**values: float) -> None:
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0):
            raise ProxyError(f"proxy {name} = {value!r} must be finite and > 0")


def truncated_cone_volume(base_diameter: float, top_diameter: float, height: float) -> float:
    r1, r2 = base_diameter / 2, top_diameter / 2
    return math.pi * height * (r1 * r1 + r1 * r2 + r2 * r2) / 3


def sizes(cfg: dict) -> dict[str, float | list[float]]:
    """The sizes (m) of the primitive an experiment's ``proxy`` section describes, scaled by its ``scale`` and
    checked (every key given, finite and > 0), as its mesh builder takes them; {} for a mesh file."""
    shape = cfg["shape"]
    missing = [key for key in REQUIRED[shape] if key not in cfg]
    if missing:
        raise ProxyError(f"proxy shape {shape!r} needs {', '.join(missing)}")
    if shape == "mesh":
        return {}
    s = cfg.get("scale", 1.0)
    if shape == "box":
        extents = [float(e) * s for e in cfg["extents"]]
        check_positive(**{f"extent {i}": e for i, e in enumerate(extents)})
        return {"extents": extents}
    scaled = {key: cfg[key] * s for key in REQUIRED[shape]}
    check_positive(**scaled)
    return scaled


def analytic_volume(cfg: dict) -> float | None:
    """The volume (m^3) of the primitive an experiment's ``proxy`` section describes (its ``sizes``); None for a mesh
    file."""
    return primitive_volume(cfg["shape"], sizes(cfg))


def primitive_volume(shape: str, size: dict[str, float | list[float]]) -> float | None:
    """The volume (m^3) of a primitive ``shape`` of checked ``sizes``; None for a mesh file."""
    if shape == "truncated_cone":
        return truncated_cone_volume(**size)
    if shape in ("spheroid", "cylinder"):
        return (2 / 3 if shape == "spheroid" else 1.0) * math.pi * size["radius"] ** 2 * size["height"]
    if shape == "box":
        return math.prod(size["extents"])
    return None
