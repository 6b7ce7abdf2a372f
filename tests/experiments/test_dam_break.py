"""The dam-break scene: the floor footprint of a silhouette and the runout past the gate, the domain around it,
and a rollout that holds a strong material in its cuboid and lets a weak one out through the open gate."""


import dataclasses

import numpy as np
import pytest

from rheo.experiments.dam_break import FACE_MARGIN, dam_break_scene, floor_footprint, runout
from rheo.experiments.effects import DamBreakError, Effects
from rheo.physics import HerschelBulkley, OptionalPhysics, kernels
from tests.conftest import DEPTH, HEIGHT, WIDTH


def test_the_floor_footprint_of_a_silhouette_of_the_floor_is_that_region(channel):
    rect = (0.0, 0.06, -0.01, 0.05)
    setup = channel(rect)
    low, high = floor_footprint(setup.camera, setup.masks[0])
    assert low == pytest.approx([rect[0], rect[2]], abs=1.5e-3)
    assert high == pytest.approx([rect[1], rect[3]], abs=1.5e-3)
    assert runout(setup) == pytest.approx(rect[1] - WIDTH, abs=1.5e-3)  # past the gate at x = W


def test_the_domain_holds_the_cuboid_and_the_footprint_inside_its_boundary_cells(channel):
    setup = channel((0.0, 0.06, -0.01, 0.05))
    scene = dam_break_scene(setup, cells_per_height=4)
    lo = np.array(scene.domain_origin) + kernels.BOUND * scene.dx
    hi = np.array(scene.domain_origin) + scene.domain_size - kernels.BOUND * scene.dx
    # the walls are symmetric about the channel's mid-plane: the half before it is simulated
    assert scene.mid_plane == pytest.approx(DEPTH / 2)
    for point in ([0.0, 0.0, -0.01], [0.06, HEIGHT, DEPTH / 2], [WIDTH, HEIGHT, DEPTH / 2]):
        assert np.all(lo <= point) and np.all(np.array(point) <= hi)
    positions = scene.initial_positions
    assert np.all(positions.min(axis=0) > 0) and np.all(positions.max(axis=0) < [WIDTH, HEIGHT, DEPTH / 2])
    assert len(positions) * scene.particle_volume == pytest.approx(WIDTH * HEIGHT * DEPTH / 2)
    colliders = scene.colliders()
    assert [type(c).__name__ for c in colliders] == ["Floor", "Box", "Box", "Box"]
    # the 3 mm side walls are thickened outwards to two cells, so that grid nodes lie inside them
    for box in colliders[1:]:
        assert min(box.half_extents) >= scene.dx - 1e-12
    # grown by a thousandth of a cell: the node on the inner face is inside the wall whatever the rounding
    inner_faces = (colliders[1].center[0] + colliders[1].half_extents[0],
                   colliders[2].center[2] + colliders[2].half_extents[2],
                   DEPTH - (colliders[3].center[2] - colliders[3].half_extents[2]))
    assert inner_faces == pytest.approx((FACE_MARGIN * scene.dx,) * 3, rel=1e-6)


def test_walls_not_symmetric_about_the_mid_plane_are_simulated_whole(channel):
    setup = channel((0.0, 0.06, -0.01, 0.05))
    far = setup.walls[3]
    setup.walls[3] = dataclasses.replace(far, high=(far.high[0], far.high[1], far.high[2] + 0.002))
    scene = dam_break_scene(setup, cells_per_height=4)
    assert scene.mid_plane is None
    assert len(scene.initial_positions) * scene.particle_volume == pytest.approx(WIDTH * HEIGHT * DEPTH)


@pytest.mark.parametrize("cells_per_height, cells_across, expected_dx", [(4, 7, 0.005), (3, 10, 0.004), (5, 3, 0.004)])
def test_the_walls_and_the_mid_plane_lie_on_node_planes_at_the_finer_resolution(channel, cells_per_height,
                                                                                cells_across, expected_dx):
    scene = dam_break_scene(channel((0.0, 0.06, -0.01, 0.05)), cells_per_height, cells_across)
    # H / 4 = 5 mm; depth / 10 = 4 mm; H / 5 = 4 mm
    assert scene.dx == pytest.approx(expected_dx)
    for axis, face in ((0, 0.0), (1, 0.0), (2, 0.0), (2, DEPTH / 2), (2, DEPTH)):
        cells = (face - scene.domain_origin[axis]) / scene.dx
        assert cells == pytest.approx(round(cells), abs=1e-9)


@pytest.mark.parametrize("tau_y, flows", [(2000.0, False), (5.0, True)])
def test_a_weak_material_leaves_through_the_gate_and_a_strong_one_stays(channel, tau_y, flows):
    # yield under its own weight where rho g H = 196 Pa exceeds the yield stress (a factor sqrt(3) aside)
    # 6 cells over the height: on coarser grids the sticky floor and walls hold most of the material
    scene = dam_break_scene(channel((0.0, 0.05, 0.0, 0.04)), cells_per_height=6)
    x = scene.positions(scene.rollout(HerschelBulkley(tau_y=tau_y, K=0.5, n=1.0, mu=2e4, lam=2e4), 0.2, 0.1))
    front = x[-1, :, 0].max()
    assert (front > WIDTH + 0.01) == flows
    assert x[-1, :, 0].min() > -1e-3  # the back wall holds
    # the whole material: the simulated half and its mirror image
    half = len(scene.initial_positions)
    assert x.shape[1] == 2 * half
    mirror = x[:, half:].copy()
    mirror[..., 2] = DEPTH - mirror[..., 2]
    assert np.abs(mirror - x[:, :half]).max() < 1e-6


def _fronts(scene, effects=None, duration=0.2):
    material = HerschelBulkley(tau_y=5.0, K=0.5, n=1.0, mu=2e4, lam=2e4)
    trajectory = scene.rollout(material, duration, duration / 4, effects)
    return trajectory.x[:, :, 0].max(dim=1).values.numpy(), trajectory


def test_effects_at_their_null_values_are_the_base_dam_break_and_each_moves_the_flow(channel):
    scene = dam_break_scene(channel((0.0, 0.05, 0.0, 0.04)), cells_per_height=6)
    base, trajectory = _fronts(scene)
    _, again = _fronts(scene, Effects(physics=OptionalPhysics()))
    assert np.array_equal(trajectory.x.numpy(), again.x.numpy())
    # a gate clearing the material's height in 0.15 s holds the front back; a slippery floor lets it run further
    gated, _ = _fronts(scene, Effects(gate_lift_time=0.15))
    assert gated[1] < base[1] - 0.002 and np.all(gated <= base + 1e-3)
    sliding, _ = _fronts(scene, Effects(floor_friction=0.1))
    assert sliding[-1] > base[-1] + 0.002
    # gravity tilted down the channel speeds the front; a heavier material flows further against its yield stress
    tilted, _ = _fronts(scene, Effects(gravity_tilt=0.2))
    heavier, _ = _fronts(scene, Effects(density_factor=2.0))
    assert tilted[-1] > base[-1] and heavier[-1] > base[-1]
    with pytest.raises(DamBreakError, match="gate lift time"):
        Effects(gate_lift_time=-1.0)


def _open_drag(*rates: float) -> Effects:
    return Effects(physics=OptionalPhysics(open_drag=rates, open_layer=9.0, open_span=9.0))


def test_the_open_drag_acts_over_the_rollout_on_a_floor_layer_a_quarter_of_the_height_thick(channel):
    scene = dam_break_scene(channel((0.0, 0.05, 0.0, 0.04)), cells_per_height=6)
    material = HerschelBulkley(tau_y=5.0, K=0.5, n=1.0, mu=2e4, lam=2e4)
    physics = scene.simulator(material, _open_drag(0.0, 3.0, 0.0, 0.0), duration=0.2).physics
    assert physics.open_drag == (0.0, 3.0, 0.0, 0.0)
    assert (physics.open_layer, physics.open_span) == (pytest.approx(scene.setup.height / 4), 0.2)
    base, _ = _fronts(scene)
    held, _ = _fronts(scene, _open_drag(0.0, 0.0, 20.0, 20.0))
    driven, _ = _fronts(scene, _open_drag(-8.0, -8.0, -8.0, -8.0))
    assert held[-1] < base[-1] - 0.002 and driven[-1] > base[-1] + 0.001


def test_wall_slip_lets_the_material_slide_on_the_floor_and_walls_the_less_the_larger_its_coefficient(channel):
    scene = dam_break_scene(channel((0.0, 0.05, 0.0, 0.04)), cells_per_height=6)
    colliders = scene.colliders(Effects(wall_slip=300.0, gate_lift_time=0.1))
    assert [(c.contact, c.friction) for c in colliders[:-1]] == [("navier", 300.0)] * (len(colliders) - 1)
    assert colliders[-1].contact == "slip"  # the gate
    assert scene.colliders(Effects(wall_slip=300.0, floor_friction=0.2))[0].contact == "friction"
    base, _ = _fronts(scene)
    held, _ = _fronts(scene, Effects(wall_slip=3.0e3))
    sliding, _ = _fronts(scene, Effects(wall_slip=30.0))
    assert base[-1] < held[-1] < sliding[-1] - 0.002
    with pytest.raises(DamBreakError, match="wall slip"):
        Effects(wall_slip=float("nan"))


def test_wall_slip_leaves_walls_that_slip_freely_as_they_are(channel):
    smooth = channel((0.0, 0.05, 0.0, 0.04), walls="slip")
    colliders = dam_break_scene(smooth, cells_per_height=6).colliders(Effects(wall_slip=300.0))
    assert [c.contact for c in colliders] == ["navier"] + ["slip"] * (len(colliders) - 1)


def test_the_gate_stands_on_the_cuboids_front_face_across_the_channel(channel):
    scene = dam_break_scene(channel((0.0, 0.05, 0.0, 0.04)), cells_per_height=6)
    gate = scene.colliders(Effects(gate_lift_time=0.1))[-1]
    low = np.array(gate.center) - gate.half_extents
    high = np.array(gate.center) + gate.half_extents
    assert low[0] == pytest.approx(WIDTH - FACE_MARGIN * scene.dx) and low[1] < 0 < HEIGHT < high[1]
    assert low[2] < 0 and high[2] > DEPTH and gate.contact == "slip"
    assert gate.velocity == pytest.approx((0.0, HEIGHT / 0.1, 0.0))
