"""The proxy stage through Snakemake: a primitive (the tiny experiment) and a mesh file."""

import json

import numpy as np
import pytest
import yaml

from rheo.geometry import proxy


def test_tiny_proxy_volume_and_particles(workflow):
    run = workflow.run("results/tiny/proxy/proxy.json")
    assert run.returncode == 0, run.stderr[-3000:]
    summary = json.loads((workflow.root / "results/tiny/proxy/proxy.json").read_text())
    assert abs(summary["volume_error"]) < 0.01
    data = np.load(workflow.root / "results/tiny/proxy/particles.npz")
    assert len(data["positions"]) == summary["particles"] == int(data["occupancy"].sum())
    assert data["positions"][:, 1].min() > 0 and data["positions"][:, 1].max() < 0.2  # on the floor, 0.2 tall
    assert (workflow.root / "results/tiny/proxy/particles.png").is_file()


def test_mesh_file_proxy(workflow, tmp_path):
    mesh_path = tmp_path / "block.stl"
    proxy.box((0.1, 0.05, 0.2)).export(mesh_path)
    exp = {"name": "block", "proxy": {"shape": "mesh", "mesh": str(mesh_path), "scale": 2.0,
                                      "position": [0.5, 0.0, 0.5], "spacing": 0.01}}
    (workflow.root / "config/experiments/block.yaml").write_text(yaml.safe_dump(exp))
    run = workflow.run("results/block/proxy/proxy.json")
    assert run.returncode == 0, run.stderr[-3000:]
    summary = json.loads((workflow.root / "results/block/proxy/proxy.json").read_text())
    assert summary["voxel_volume"] == pytest.approx(0.2 * 0.1 * 0.4, rel=0.01)
    assert summary["analytic_volume"] is None
