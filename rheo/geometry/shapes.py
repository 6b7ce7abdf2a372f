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


def analytic_volume(cfg: dict) -> float | None:
    """The volume (m^3) of the primitive an experiment's ``proxy`` section describes, its keys and sizes checked;
    None for a mesh file."""
    shape = cfg["shape"]
    missing = [key for key in REQUIRED[shape] if key not in cfg]
    if missing:
        raise ProxyError(f"proxy shape {shape!r} needs {', '.join(missing)}")
    s = cfg.get("scale", 1.0)
    if shape == "truncated_cone":
        sizes = {"base_diameter": cfg["base_diameter"] * s, "top_diameter": cfg["top_diameter"] * s,
                 "height": cfg["height"] * s}
        check_positive(**sizes)
        return truncated_cone_volume(**sizes)
    if shape in ("spheroid", "cylinder"):
        r, h = cfg["radius"] * s, cfg["height"] * s
        check_positive(radius=r, height=h)
        return (2 / 3 if shape == "spheroid" else 1.0) * math.pi * r * r * h
    if shape == "box":
        extents = [float(e) * s for e in cfg["extents"]]
        check_positive(**{f"extent {i}": e for i, e in enumerate(extents)})
        return math.prod(extents)
    return None
