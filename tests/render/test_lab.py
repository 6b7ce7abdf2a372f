"""The virtual lab's renderer: a ball of particles on a lattice is shaded as the sphere it samples, without the
lattice showing."""

import numpy as np

from rheo.experiments.virtual_lab import lab_mask, lab_view
from rheo.render.lab import Scene, render
from rheo.vision.cameras import hemisphere

RADIUS, SPACING = 0.15, 0.01
CENTER = np.array([0.5, 0.3, 0.5])


def ball() -> np.ndarray:
    axis = np.arange(-RADIUS, RADIUS + 1e-9, SPACING)
    lattice = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    return CENTER + lattice[np.linalg.norm(lattice, axis=1) <= RADIUS]


def test_a_ball_of_particles_is_shaded_as_a_sphere():
    camera = hemisphere(1, 1.5, [25.0, 25.0], CENTER, 320, 240, 40.0)[0]
    points = ball()
    scene = Scene(noise=0.0)
    image, mask = render(camera, points, SPACING, scene=scene)

    # Blinn-Phong shading of the true sphere (the lab's lighting) where each pixel's ray meets it
    origin, dirs = camera.pixel_rays()
    to_center = CENTER - origin
    along = dirs @ to_center
    miss = np.linalg.norm(to_center) ** 2 - along**2
    hit = miss < RADIUS**2
    t = along - np.sqrt(np.clip(RADIUS**2 - miss, 0.0, None))
    surface = origin + t[..., None] * dirs
    normal = (surface - CENTER) / RADIUS
    light = np.asarray(scene.light) / np.linalg.norm(scene.light)
    view = -dirs
    half = (view + light) / np.linalg.norm(view + light, axis=-1, keepdims=True)
    diffuse = np.clip(normal @ light, 0.0, 1.0)
    specular = 0.25 * np.clip(np.sum(normal * half, axis=-1), 0.0, 1.0) ** 30
    expected = np.asarray(scene.albedo) * (scene.ambient + (1 - scene.ambient) * diffuse[..., None])
    expected = np.clip(expected + specular[..., None], 0.0, 1.0) * 255

    # the silhouette is the sphere's, within a pixel or two at the rim
    assert abs(mask.sum() / hit.sum() - 1) < 0.06
    # away from the rim (where a smoothed depth cannot turn the normal fully sideways), the shade is the sphere's
    inner = hit & (miss < (0.8 * RADIUS) ** 2) & mask
    error = np.abs(image[inner].astype(float) - expected[inner]).max(axis=-1)
    assert np.median(error) < 6 and np.percentile(error, 95) < 20, (np.median(error), np.percentile(error, 95))


def test_the_lab_s_mask_alone_is_the_mask_it_films_with_the_image():
    camera = hemisphere(1, 1.5, [25.0, 25.0], CENTER, 160, 120, 40.0, (0.1, -0.2, 0.0, 0.0, 0.05))[0]
    mask = lab_mask(camera, ball(), SPACING)
    assert mask.any() and (mask == lab_view(camera, ball(), SPACING)[1]).all()
