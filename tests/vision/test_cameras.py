import cv2
import numpy as np
import pytest

from rheo.vision.cameras import Camera, look_at


@pytest.mark.parametrize("dist", [np.zeros(5), np.array([0.05, -0.02, 0.001, -0.002, 0.0])])
def test_projection_matches_opencv_with_and_without_distortion(dist):
    K = np.array([[700.0, 0.0, 330.0], [0.0, 690.0, 250.0], [0.0, 0.0, 1.0]])
    camera = Camera(640, 480, K, dist, look_at([0.3, 0.4, 0.9], [0.0, 0.05, 0.0]))
    points = np.random.default_rng(0).uniform(-0.2, 0.2, (500, 3))
    w2c = np.linalg.inv(camera.c2w)
    expected, _ = cv2.projectPoints(points, cv2.Rodrigues(w2c[:3, :3])[0], w2c[:3, 3], K, dist)
    uv, depth = camera.project(points)
    np.testing.assert_allclose(uv, expected.reshape(-1, 2), atol=1e-6)
    np.testing.assert_allclose(depth, (points @ w2c[:3, :3].T + w2c[:3, 3])[:, 2])
