"""The seed against silhouettes drawn from known particle sets: the lattice placed and carved to the masks, a cap
over a flat top that no view's outline needs trimmed, layers the outlines show kept."""

import numpy as np
import pytest
import torch

from rheo.fit.observations import Observations, View
from rheo.fit.seed import Seed, mismatched_pixels, seed_from_field, trim_top
from rheo.render.field import VoxelGrid
from rheo.render.silhouette import silhouette
from rheo.vision.cameras import hemisphere

SPACING = 0.01
# about 3 px per particle spacing at 2 m, views from 25 to 45 degrees above the horizon, as in the virtual cup
CAMERAS = hemisphere(9, 2.0, (25.0, 45.0), (0.0, 0.08, 0.0), 240, 180, 17.0)


def lattice(radius_of_layer) -> np.ndarray:
    """Particles on the lattice through the origin: layer j holds the nodes within ``radius_of_layer(j)``
    spacings of the vertical axis (none where it is None)."""
    points = []
    for j in range(40):
        radius = radius_of_layer(j)
        if radius is None:
            continue
        i, k = np.mgrid[-20:20, -20:20]
        x, z = (i + 0.5) * SPACING, (k + 0.5) * SPACING
        inside = np.hypot(x, z) <= radius * SPACING
        points.append(np.column_stack([x[inside], np.full(inside.sum(), (j + 0.5) * SPACING), z[inside]]))
    return np.concatenate(points)


def observed(truth: np.ndarray) -> Observations:
    views = [View(f"cam{i}", cam, np.zeros(3), np.zeros((0, 3)), np.zeros((1, 0, 3), np.uint8),
                  silhouette(cam, truth, SPACING).reshape(1, -1), np.zeros(0, bool))
             for i, cam in enumerate(CAMERAS)]
    return Observations(views, np.zeros(1))


def seed_of(positions: np.ndarray) -> Seed:
    return Seed(positions, np.ones(len(positions)), np.full((len(positions), 3), 0.5), SPACING)


def as_set(positions: np.ndarray) -> set:
    return set(map(tuple, np.round(positions / SPACING - 0.5).astype(int).tolist()))


def test_a_cap_over_a_flat_top_that_no_outline_needs_is_trimmed_to_the_top():
    column = lattice(lambda j: 10.0 if j < 15 else None)
    capped = lattice(lambda j: 10.0 if j < 15 else {15: 7.0, 16: 4.0}.get(j))
    trimmed, layers = trim_top(observed(column), seed_of(capped))
    assert layers == 2
    assert as_set(trimmed.positions) == as_set(column)


@pytest.mark.parametrize("shape", [lambda j: 10.0 if j < 15 else None, lambda j: 12.0 - 0.6 * j if j < 18 else None,
                                   lambda j: np.sqrt(max(144.0 - (j + 0.5) ** 2, 0.0)) or None],
                         ids=["flat top", "cone", "dome"])
def test_nothing_the_silhouettes_show_is_trimmed(shape):
    """A dome's apex above the views' outlines (above 65 degrees of latitude here) is as unseen as a cap: it may go,
    and only it."""
    truth = lattice(shape)
    obs = observed(truth)
    trimmed, layers = trim_top(obs, seed_of(truth))
    assert layers <= 1 and len(trimmed.positions) > 0.99 * len(truth)
    for view in obs.views:
        assert (silhouette(view.camera, trimmed.positions, SPACING).ravel() == view.masks[0]).all()


def test_the_seed_takes_the_lattice_placement_and_the_nodes_that_draw_the_masks():
    """Masks of a column on a lattice a third of a spacing off the field's grid; the field opaque a spacing too far
    out on one side (4185 pixels off the masks). The seed finds the placement and carves the masks to a pixel; what
    it gets wrong, a few nodes whose removal no silhouette shows, no image can tell."""
    offset = np.array([1.0, 0.0, 1.0]) * SPACING / 3
    truth = lattice(lambda j: 9.6 if j < 12 else None) + offset
    grid = VoxelGrid.around(truth, SPACING, pad=3, anchor=np.zeros(3))
    centres = grid.centres()
    inside = np.zeros(grid.shape, bool)
    for shift in (0.0, SPACING):  # the column and its copy a spacing along x
        inside |= np.hypot(centres[..., 0] - offset[0] - shift, centres[..., 2] - offset[2]) <= 9.6 * SPACING
    inside &= (centres[..., 1] > 0) & (centres[..., 1] < 12 * SPACING)
    density = torch.as_tensor(np.where(inside, 1e3, 0.0), dtype=torch.float32)
    obs = observed(truth)
    seed, _, _ = seed_from_field(obs, density, torch.full((3, *grid.shape), 0.5), grid)
    nodes = (seed.positions - offset) / SPACING - 0.5
    assert np.allclose(nodes, np.round(nodes), atol=1e-6)
    assert mismatched_pixels(obs, seed.positions, SPACING) <= 2
    assert len(as_set(seed.positions) ^ as_set(truth)) <= 0.005 * len(truth)
