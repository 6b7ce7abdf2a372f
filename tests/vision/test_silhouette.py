"""Silhouette pose refinement: a perturbed camera is pulled back until the proxy's silhouette matches the mask."""

import math

import numpy as np

from rheo.geometry.proxy import truncated_cone, voxelize
from rheo.vision.cameras import Camera, hemisphere
from rheo.vision.matting import iou
from rheo.vision.silhouette import refine_pose, silhouette_mask


def test_perturbed_pose_matches_the_mask_again():
    mesh = truncated_cone(0.216, 0.152, 0.212)
    mesh.apply_translation([0.5, 0.0, 0.5])
    vox = voxelize(mesh, 0.01)
    truth = hemisphere(1, 1.2, [30.0, 30.0], [0.5, 0.1, 0.5], 320, 240, 45.0)[0]
    mask = silhouette_mask(truth, vox.particles, vox.spacing)
    perturb = np.eye(4)
    angle = math.radians(1.5)
    perturb[:3, :3] = [[1, 0, 0], [0, math.cos(angle), -math.sin(angle)], [0, math.sin(angle), math.cos(angle)]]
    perturb[:3, 3] = [0.0, -0.02, 0.015]
    start = Camera(truth.width, truth.height, truth.K, truth.dist, perturb @ truth.c2w)
    before = iou(silhouette_mask(start, vox.particles, vox.spacing), mask)
    c2w, info = refine_pose(start, vox.particles, vox.spacing, mask)
    refined = Camera(truth.width, truth.height, truth.K, truth.dist, c2w)
    after = iou(silhouette_mask(refined, vox.particles, vox.spacing), mask)
    assert before < 0.8 and after > 0.92, (before, after)  # the objective is flat within about a pixel
    assert info["cost_after"] < 0.2 * info["cost_before"]
