"""Disc silhouettes of particle sets against the analytic outline of a sphere."""

import numpy as np
import pytest

from rheo.render.silhouette import silhouette
from rheo.vision.cameras import Camera, look_at


@pytest.mark.parametrize("spacing", [0.01, 0.02])
def test_a_sphere_of_particles_has_the_sphere_outline(spacing):
    radius, centre = 0.1, np.array([0.5, 0.2, 0.5])
    axis = np.arange(-radius, radius + 1e-9, spacing) + spacing / 2
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    points = centre + grid[np.linalg.norm(grid, axis=1) <= radius]
    K = np.array([[600.0, 0, 200], [0, 600.0, 150], [0, 0, 1]])
    eye = centre + np.array([0.0, 0.6, -1.5])
    camera = Camera(400, 300, K, np.zeros(5), look_at(eye, centre))
    mask = silhouette(camera, points, spacing)
    distance = np.linalg.norm(eye - centre)
    # the outline of a sphere seen from a distance d is a disc of angular radius asin(r / d)
    expected = np.pi * (600.0 * np.tan(np.arcsin(radius / distance))) ** 2
    assert mask.sum() == pytest.approx(expected, rel=0.1)  # the lattice reaches past the sphere by up to half a spacing
    rows, cols = np.nonzero(mask)
    u, v = camera.project(centre[None])[0][0]
    assert cols.mean() == pytest.approx(u, abs=0.5) and rows.mean() == pytest.approx(v, abs=0.5)
