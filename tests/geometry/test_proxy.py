"""Proxy shapes: voxelised volume against the analytic volume; mesh files; bad meshes."""

import math
from pathlib import Path

import pytest
import trimesh

from rheo.geometry import proxy
from rheo.geometry.shapes import analytic_volume, truncated_cone_volume

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"


@pytest.mark.parametrize(("mesh", "volume"), [
    # the thesis' 3 oz cup (rim 54 mm, bottom 38 mm, height 53 mm), upturned, scaled by 4
    (proxy.truncated_cone(0.216, 0.152, 0.212), truncated_cone_volume(0.216, 0.152, 0.212)),
    (proxy.cylinder(0.1, 0.2), math.pi * 0.1**2 * 0.2),
    (proxy.spheroid(0.1, 0.6), 4 / 3 * math.pi * 0.1**2 * 0.3),
    (proxy.box((0.1, 0.2, 0.3)), 0.006),
], ids=["cup", "cylinder", "spheroid", "box"])
def test_voxelised_volume_within_one_percent(mesh, volume):
    vox = proxy.voxelize(mesh, 0.005)
    assert vox.volume == pytest.approx(volume, rel=0.01)
    assert mesh.volume == pytest.approx(volume, rel=0.001)
    assert vox.particles[:, 1].min() > 0  # standing on y = 0, y up
    assert vox.occupancy.sum() == len(vox.particles)


@pytest.mark.parametrize("cfg", [
    {"shape": "truncated_cone", "base_diameter": 0.054, "top_diameter": 0.038, "height": 0.053, "scale": 4.0},
    {"shape": "cylinder", "radius": 0.12, "height": 0.2, "position": [0.5, 0.0, 0.5]},
    {"shape": "spheroid", "radius": 0.1, "height": 0.3},
    {"shape": "box", "extents": [0.1, 0.2, 0.3], "scale": 0.5},
], ids=["cup", "cylinder", "spheroid", "box"])
def test_a_configured_primitive_s_volume_without_its_mesh_is_its_mesh_s(cfg):
    mesh, volume = proxy.from_config(cfg)
    assert analytic_volume(cfg) == volume == pytest.approx(mesh.volume, rel=0.002)


def test_a_configured_primitive_s_sizes_are_checked_without_its_mesh():
    with pytest.raises(proxy.ProxyError, match="proxy shape 'cylinder' needs height"):
        analytic_volume({"shape": "cylinder", "radius": 0.1})
    with pytest.raises(proxy.ProxyError, match=r"proxy extent 1 = -0\.2 must be finite and > 0"):
        analytic_volume({"shape": "box", "extents": [0.1, -0.2, 0.3]})
    assert analytic_volume({"shape": "mesh", "mesh": "bunny.obj"}) is None


def test_spheroid_is_tall_along_y():
    vox = proxy.voxelize(proxy.spheroid(0.1, 0.6), 0.01)
    extent = vox.particles.max(axis=0) - vox.particles.min(axis=0)
    assert extent[1] == pytest.approx(0.59, abs=0.011) and extent[0] == pytest.approx(0.19, abs=0.011)


@pytest.mark.parametrize("suffix", [".stl", ".ply", ".obj"])
def test_mesh_files_round_trip(tmp_path, suffix):
    path = tmp_path / f"cylinder{suffix}"
    proxy.cylinder(0.05, 0.1).export(path)
    mesh = proxy.load_mesh(path, scale=2.0)
    assert proxy.voxelize(mesh, 0.004).volume == pytest.approx(math.pi * 0.1**2 * 0.2, rel=0.01)


def test_mesh_that_is_not_watertight_is_refused():
    with pytest.raises(proxy.ProxyError, match=r"bunny.obj: the mesh is not watertight \(\d+ open edges\)"):
        proxy.load_mesh(SHARED / "meshes" / "bunny.obj")


def test_bad_proxy_input(tmp_path):
    with pytest.raises(proxy.ProxyError, match=r"unsupported mesh format '\.fbx'"):
        proxy.load_mesh(tmp_path / "shape.fbx")
    with pytest.raises(proxy.ProxyError, match="no such mesh file"):
        proxy.load_mesh(tmp_path / "missing.stl")
    with pytest.raises(proxy.ProxyError, match=r"proxy height = -1\.0 must be finite and > 0"):
        proxy.cylinder(0.1, -1.0)


def test_majority_voxelization_tolerates_a_hole_in_a_scanned_mesh(tmp_path):
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    bottom = sphere.triangles_center[:, 1] < -0.095  # a hole around the south pole, as under a scanned bunny
    holed = trimesh.Trimesh(sphere.vertices, sphere.faces[~bottom], process=False)
    path = tmp_path / "holed.stl"
    holed.export(path)
    with pytest.raises(proxy.ProxyError, match="not watertight"):
        proxy.load_mesh(path)
    mesh = proxy.load_mesh(path, require_watertight=False)
    exact = sphere.volume
    assert proxy.voxelize(mesh, 0.005, directions=3).volume == pytest.approx(exact, rel=0.02)
    assert abs(proxy.voxelize(mesh, 0.005).volume / exact - 1) > 0.02  # vertical rays alone see through the hole
