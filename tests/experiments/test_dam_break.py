"""The dam-break scene: the floor footprint of a silhouette, the domain around it, and a rollout that holds a strong
material in its cuboid and lets a weak one out through the open gate."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from rheo.experiments.dam_break import dam_break_scene, floor_footprint
from rheo.experiments.virheometry import Setup, StaticBox
from rheo.physics import HerschelBulkley, kernels
from rheo.vision.cameras import Camera, intrinsics, look_at

DEPTH, HEIGHT, WIDTH = 0.04, 0.02, 0.025


def _setup(footprint_rect: tuple[float, float, float, float]) -> Setup:
    """A channel setup whose silhouettes all show the floor rectangle (x0, x1, z0, z1)."""
    camera = Camera(320, 180, intrinsics(320, 180, 50.0), np.zeros(5), look_at([0.04, 0.12, 0.28], [0.04, 0.0, 0.02]))
    x0, x1, z0, z1 = footprint_rect
    corners = np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z1]], float)
    uv, _ = camera.project(corners)
    mask = np.zeros((180, 320), np.uint8)
    cv2.fillConvexPoly(mask, np.round(uv * 16).astype(np.int32), 1, cv2.LINE_8, shift=4)
    walls = [StaticBox((-1.0, -0.01, -1.0), (1.0, 0.0, 1.0), "sticky"),
             StaticBox((-0.01, 0.0, 0.0), (0.0, 0.2, DEPTH), "sticky"),
             StaticBox((-0.01, 0.0, -0.003), (WIDTH, 0.2, 0.0), "sticky"),
             StaticBox((-0.01, 0.0, DEPTH), (WIDTH, 0.2, DEPTH + 0.003), "sticky")]
    return Setup(folder=Path("ref_Test_2.0_2.5_1"), material="Test", index=1, height=HEIGHT, width=WIDTH,
                 depth=DEPTH, density=1000.0, walls=walls, camera=camera, masks=[mask.astype(bool)] * 2,
                 start_point=None)


def test_the_floor_footprint_of_a_silhouette_of_the_floor_is_that_region():
    rect = (0.0, 0.06, -0.01, 0.05)
    low, high = floor_footprint(_setup(rect))
    assert low == pytest.approx([rect[0], rect[2]], abs=1.5e-3)
    assert high == pytest.approx([rect[1], rect[3]], abs=1.5e-3)


def test_the_domain_holds_the_cuboid_and_the_footprint_inside_its_boundary_cells():
    setup = _setup((0.0, 0.06, -0.01, 0.05))
    scene = dam_break_scene(setup, resolution=24)
    lo = np.array(scene.domain_origin) + kernels.BOUND * scene.dx
    hi = np.array(scene.domain_origin) + scene.domain_size - kernels.BOUND * scene.dx
    for point in ([0.0, 0.0, -0.01], [0.06, HEIGHT, 0.05], [WIDTH, HEIGHT, DEPTH]):
        assert np.all(lo <= point) and np.all(np.array(point) <= hi)
    positions = scene.initial_positions()
    assert np.all(positions.min(axis=0) > 0) and np.all(positions.max(axis=0) < [WIDTH, HEIGHT, DEPTH])
    assert len(positions) * scene.particle_volume() == pytest.approx(WIDTH * HEIGHT * DEPTH)
    assert [type(c).__name__ for c in scene.colliders()] == ["Floor", "Box", "Box", "Box"]


@pytest.mark.parametrize("tau_y, flows", [(2000.0, False), (5.0, True)])
def test_a_weak_material_leaves_through_the_gate_and_a_strong_one_stays(tau_y, flows):
    # yield under its own weight where rho g H = 196 Pa exceeds the yield stress (a factor sqrt(3) aside)
    # 6 cells over the height: on coarser grids the sticky floor and walls hold most of the material
    scene = dam_break_scene(_setup((0.0, 0.07, -0.01, 0.05)), resolution=32)
    trajectory = scene.rollout(HerschelBulkley(tau_y=tau_y, K=0.5, n=1.0, mu=2e4, lam=2e4), 0.2, 0.1)
    front = trajectory.x[-1, :, 0].max().item()
    assert (front > WIDTH + 0.01) == flows
    assert trajectory.x[-1, :, 0].min().item() > -1e-3  # the back wall holds
