"""The material drawn as a surface: a ball of particles is drawn as a disc of the size a pinhole camera sees, lit
brighter where it faces the light, and framing finds the drawn region."""

import math

import numpy as np

from rheo.render.surface import framing, particle_surface, shade, surface_image
from rheo.vision.cameras import Camera

RADIUS, DISTANCE, FOCAL = 0.1, 1.0, 400.0


def ball(spacing: float) -> np.ndarray:
    axis = np.arange(-RADIUS, RADIUS + spacing / 2, spacing)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid[np.linalg.norm(grid, axis=1) <= RADIUS]


def camera() -> Camera:
    """Looking along +z at the origin from z = -DISTANCE (OpenCV axes: x right, y down), 320 x 320 px."""
    c2w = np.eye(4)
    c2w[:3, :3] = np.diag([-1.0, -1.0, 1.0])
    c2w[:3, 3] = [0.0, 0.0, -DISTANCE]
    K = np.array([[FOCAL, 0.0, 159.5], [0.0, FOCAL, 159.5], [0.0, 0.0, 1.0]])
    return Camera(320, 320, K, np.zeros(5), c2w)


def test_a_ball_of_particles_is_a_disc_of_the_size_the_camera_sees():
    spacing = 0.01
    particles = ball(spacing)
    radius = (3 * len(particles) * spacing**3 / (4 * math.pi)) ** (1 / 3)  # of the volume the particles stand for
    vertices, faces = particle_surface(particles, spacing)
    # the level set lies within half a particle spacing of that ball's surface
    assert abs(np.median(np.linalg.norm(vertices, axis=1)) - radius) < spacing / 2
    image = shade(vertices, faces, camera())
    drawn = np.abs(image - 1.0).max(axis=-1) > 0.5
    # a sphere seen from distance D: a disc of radius f R / sqrt(D^2 - R^2)
    expected = math.pi * (FOCAL * radius / math.sqrt(DISTANCE**2 - radius**2)) ** 2
    assert abs(drawn.sum() / expected - 1) < 0.05
    centre, rim = image[160, 160], image[160, 160 + int(0.9 * FOCAL * radius)]
    assert centre.sum() > rim.sum()  # the face towards the camera is lit, the limb darker
    rows, cols = framing([image])
    assert drawn[rows, cols].sum() == drawn.sum() and (rows.stop - rows.start) % 2 == 0


def test_nothing_to_draw_is_a_blank_image():
    image = surface_image(np.zeros((1, 3)), 0.01, camera())
    assert image.shape == (320, 320, 3) and np.all(image == 1.0)
