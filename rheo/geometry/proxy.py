"""Proxy geometry: the shape the material starts in, from primitives or a mesh file, voxelised into an occupancy
grid and particles (y is up; shapes stand on y = 0 unless placed otherwise).

Inside tests use one ray per lattice column (parity of the crossings along +y), so a mesh of any size is voxelised
in a fraction of a second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from rheo.geometry.shapes import ProxyError, check_positive, primitive_volume, sizes


@dataclass(frozen=True)
class Voxelized:
    """Lattice occupancy and the particles at the occupied cell centres."""

    occupancy: np.ndarray  # bool (nx, ny, nz)
    origin: np.ndarray  # centre of cell (0, 0, 0)
    spacing: float
    particles: np.ndarray  # (N, 3)

    @property
    def particle_volume(self) -> float:
        return self.spacing**3

    @property
    def volume(self) -> float:
        return len(self.particles) * self.spacing**3


def _y_up(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """trimesh builds primitives along z; turn them to stand along y with the base on y = 0."""
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, [1, 0, 0]))
    mesh.apply_translation([0.0, -mesh.bounds[0][1], 0.0])
    return mesh


def truncated_cone(base_diameter: float, top_diameter: float, height: float, sections: int = 256) -> trimesh.Trimesh:
    """A solid truncated cone standing on its base (an upturned cup's contents: base = the cup's rim)."""
    check_positive(base_diameter=base_diameter, top_diameter=top_diameter, height=height)
    mesh = trimesh.creation.cylinder(radius=base_diameter / 2, height=height, sections=sections)
    z = mesh.vertices[:, 2]
    scale = 1.0 + (top_diameter / base_diameter - 1.0) * (z + height / 2) / height
    mesh.vertices[:, :2] *= scale[:, None]
    return _y_up(mesh)


def cylinder(radius: float, height: float, sections: int = 256) -> trimesh.Trimesh:
    check_positive(radius=radius, height=height)
    return _y_up(trimesh.creation.cylinder(radius=radius, height=height, sections=sections))


def spheroid(radius: float, height: float, subdivisions: int = 5) -> trimesh.Trimesh:
    """A spheroid with equatorial radius ``radius`` and vertical extent ``height`` (prolate when height > 2 radius)."""
    check_positive(radius=radius, height=height)
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    mesh.apply_scale([radius, height / 2, radius])
    mesh.apply_translation([0.0, height / 2, 0.0])
    return mesh


def box(extents) -> trimesh.Trimesh:
    extents = [float(e) for e in extents]
    check_positive(**{f"extent {i}": e for i, e in enumerate(extents)})
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation([0.0, extents[1] / 2, 0.0])
    return mesh


def load_mesh(path: str | Path, scale: float = 1.0, require_watertight: bool = True) -> trimesh.Trimesh:
    """A closed triangle mesh from an OBJ, STL or PLY file (in its own frame, scaled by ``scale``). A scan with small
    holes passes with ``require_watertight=False`` (then voxelize it with ``directions=3``)."""
    path = Path(path)
    if path.suffix.lower() not in {".obj", ".stl", ".ply"}:
        raise ProxyError(f"{path}: unsupported mesh format {path.suffix!r}; use OBJ, STL or PLY")
    if not path.is_file():
        raise ProxyError(f"{path}: no such mesh file")
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as err:  # trimesh raises many types for bad files
        raise ProxyError(f"{path}: not a readable mesh ({err})") from err
    if len(mesh.faces) == 0:
        raise ProxyError(f"{path}: the mesh has no triangles")
    if require_watertight and not mesh.is_watertight:
        open_edges = len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))
        raise ProxyError(f"{path}: the mesh is not watertight ({open_edges} open edges), so it encloses no volume; "
                         f"close its holes first")
    mesh.apply_scale(scale)
    return mesh


def _parity_occupancy(mesh: trimesh.Trimesh, axes: list[np.ndarray], axis: int, start: float) -> np.ndarray:
    """Cell centres inside the mesh by the parity of surface crossings along rays parallel to ``axis`` (one ray per
    column of cells, slightly off the lattice so that no ray grazes an edge exactly)."""
    a, b = [i for i in range(3) if i != axis]
    spacing = axes[axis][1] - axes[axis][0] if len(axes[axis]) > 1 else 1.0
    ga, gb = np.meshgrid(axes[a] + 1.1e-7 * spacing, axes[b] + 1.3e-7 * spacing, indexing="ij")
    origins = np.zeros((ga.size, 3))
    origins[:, a], origins[:, b], origins[:, axis] = ga.ravel(), gb.ravel(), start
    directions = np.zeros_like(origins)
    directions[:, axis] = 1.0
    locations, ray_index, _ = mesh.ray.intersects_location(origins, directions, multiple_hits=True)
    shape = [len(x) for x in axes]
    occupancy = np.zeros(shape, dtype=bool)
    order = np.lexsort((locations[:, axis], ray_index))
    ray_index, depths = ray_index[order], locations[order, axis]
    for ray in np.unique(ray_index):
        ts = depths[ray_index == ray]
        ts = ts[np.concatenate([[True], np.diff(ts) > 1e-9 * spacing])]  # one crossing per surface
        i, k = divmod(int(ray), shape[b])
        index: list = [None, None, None]
        index[a], index[b] = i, k
        for enter, leave in zip(ts[0::2], ts[1::2], strict=False):
            index[axis] = (axes[axis] > enter) & (axes[axis] < leave)
            occupancy[tuple(index)] = True
    return occupancy


def voxelize(mesh: trimesh.Trimesh, spacing: float, directions: int = 1) -> Voxelized:
    """Occupancy of the lattice of cell centres (spacing ``spacing``) covering the mesh, and its particles.

    Inside is decided by the parity of crossings along vertical rays; with ``directions = 3``, by the majority of
    rays along x, y and z, which tolerates small holes in a scanned mesh (a hole only misleads the rays through it).
    """
    if not (math.isfinite(spacing) and spacing > 0):
        raise ProxyError(f"voxel spacing {spacing!r} must be finite and > 0")
    lo, hi = mesh.bounds
    counts = np.maximum(np.ceil((hi - lo) / spacing).astype(int), 1)
    if counts.prod() > 50_000_000:
        raise ProxyError(f"voxel spacing {spacing:g} m gives {counts.prod():,} cells over the mesh; use a coarser one")
    origin = lo + 0.5 * spacing * np.ones(3)
    axes = [origin[a] + spacing * np.arange(counts[a]) for a in range(3)]
    if directions == 1:
        occupancy = _parity_occupancy(mesh, axes, 1, lo[1] - spacing)
    else:
        votes = sum(_parity_occupancy(mesh, axes, a, lo[a] - spacing).astype(int) for a in range(3))
        occupancy = votes >= 2
    index = np.argwhere(occupancy)
    return Voxelized(occupancy=occupancy, origin=origin, spacing=spacing, particles=origin + index * spacing)


def from_config(cfg: dict) -> tuple[trimesh.Trimesh, float | None]:
    """The proxy mesh described by an experiment's ``proxy`` section, placed in the world; and its analytic volume
    (None for a mesh file)."""
    builders = {"truncated_cone": truncated_cone, "spheroid": spheroid, "cylinder": cylinder, "box": box}
    shape, size = cfg["shape"], sizes(cfg)
    mesh = builders[shape](**size) if shape in builders else load_mesh(cfg["mesh"], scale=cfg.get("scale", 1.0))
    mesh.apply_translation(cfg.get("position", (0.0, 0.0, 0.0)))
    return mesh, primitive_volume(shape, size)
