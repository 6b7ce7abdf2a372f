"""The dam-break comparison: boundary distances, shear rates of known flows, and the first frame's offset found
again on silhouettes drawn from a known rollout."""

import numpy as np
import pytest

from rheo.experiments.dam_break import dam_break_scene
from rheo.fit.dam_break import OFFSET_STEP, DamBreakTarget, shear_rates, skin
from rheo.render.silhouette import boundary_distance, distance_to


def test_shear_rate_of_simple_shear_and_of_a_rotation():
    shear = np.zeros((3, 3))
    shear[0, 1] = 4.0  # v_x = 4 y
    assert shear_rates(shear) == pytest.approx(4.0)
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert shear_rates(rotation) == pytest.approx(0.0)
    assert shear_rates(np.eye(3)) == pytest.approx(0.0)  # expansion is not shear


def test_boundary_distance_of_a_shifted_square():
    mask = np.zeros((60, 60), bool)
    mask[20:40, 20:40] = True
    shifted = np.roll(mask, 3, axis=1)
    assert boundary_distance(mask, mask, distance_to(mask)) == 0.0
    # 3 of 20 columns lie 1, 2, 3 px off on each side: mean (1+2+3)/20 each way
    assert boundary_distance(shifted, mask, distance_to(mask)) == pytest.approx(6 / 20, rel=1e-6)


def test_the_first_frames_offset_is_found_on_silhouettes_of_a_known_rollout(channel):
    setup = channel((0.0, 0.07, -0.01, 0.05), frames=4)
    scene = dam_break_scene(setup, cells_per_height=4)
    truth = dict(tau_y=5.0, K=0.5, n=0.8)
    target = DamBreakTarget(scene, max_offset=0.05, elastic=(2e4, 2e4))
    offset_steps, frames = 7, len(setup.masks)
    trajectory = scene.rollout(target.material(**truth), (offset_steps + (frames - 1) * target.frame_steps)
                               * OFFSET_STEP, OFFSET_STEP)
    observed = [skin(setup.camera, trajectory.x[offset_steps + k * target.frame_steps].numpy(), scene.spacing)
                | target.container for k in range(frames)]
    setup.masks[:] = observed
    target = DamBreakTarget(scene, max_offset=0.05, elastic=(2e4, 2e4))
    result = target.compare(**truth)
    assert result.offset == pytest.approx(offset_steps * OFFSET_STEP) and result.loss == 0.0
    assert np.all(result.outflow_iou[1:] == 1.0) and np.all(result.shear_rates > 0.1)
    assert target.compare(tau_y=50.0, K=0.5, n=0.8).loss > 0.05  # a stronger material flows less
