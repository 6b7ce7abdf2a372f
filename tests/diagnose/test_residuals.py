"""Locating a mismatch: synthetic silhouettes of the test channel whose front, or surface, differ in known frames."""

import numpy as np

from rheo.diagnose.residuals import REGIONS, locate, region_masks
from rheo.experiments.virheometry import container_silhouette


def _outflow(setup, columns: int, top: int = 0) -> np.ndarray:
    """The container and a band right of it, ``columns`` px long, from the floor edge up ``top`` px more."""
    mask = container_silhouette(setup).copy()
    rows, cols = np.nonzero(mask)
    gate, bottom = cols.max(), rows.max()
    mask[bottom - 12 - top:bottom + 1, gate:gate + columns] = True
    return mask


def test_a_simulated_front_that_lags_in_late_frames_is_named_so(channel):
    setup = channel((0.0, 0.05, 0.0, 0.04), frames=6)
    observed = [_outflow(setup, 10 + 8 * k) for k in range(6)]
    simulated = [_outflow(setup, 10 + 8 * k - (6 if k >= 4 else 0)) for k in range(6)]
    location = locate(setup, simulated, observed, [str(k + 1) for k in range(6)])
    assert location.by_frame()[:4].sum() == 0 and location.by_frame()[4:].min() > 0
    assert max(location.by_region(), key=location.by_region().get) == "front"
    words = location.words()
    assert "frames 5-6 (late)" in words and "lags behind" in words and "missing" in words


def test_a_surface_that_stands_too_high_throughout(channel):
    setup = channel((0.0, 0.05, 0.0, 0.04), frames=6)
    observed = [_outflow(setup, 40) for _ in range(6)]
    simulated = [_outflow(setup, 40, top=3) for _ in range(6)]
    location = locate(setup, simulated, observed, [str(k + 1) for k in range(6)])
    assert location.missing.sum() == 0 and location.by_region()["free surface"] > 0.5
    words = location.words()
    assert "(throughout)" in words and "stands higher" in words
    assert locate(setup, observed, observed, ["1"] * 6).words() == "The simulation matches every frame."


def test_material_left_in_the_container_is_said_to_lie_inside_it(channel):
    setup = channel((0.0, 0.05, 0.0, 0.04), frames=4)
    container = container_silhouette(setup)
    rows = np.nonzero(container)[0]
    drained = container & (np.arange(container.shape[0])[:, None] > (rows.min() + rows.max()) // 2)
    observed = [_outflow(setup, 30) & ~(container & ~drained) for _ in range(4)]
    simulated = [_outflow(setup, 30) for _ in range(4)]
    location = locate(setup, simulated, observed, [str(k + 1) for k in range(4)])
    assert max(location.by_region(), key=location.by_region().get) == "inside the container"
    assert "% of it inside the container, where the simulation leaves more material in the container" in \
        location.words()
    assert "% of it at the " not in location.words()


def test_the_regions_split_the_image(channel):
    setup = channel((0.0, 0.05, 0.0, 0.04))
    regions = region_masks(setup, [_outflow(setup, 40)])
    stacked = np.stack([regions[name] for name in REGIONS])
    assert np.all(stacked.sum(axis=0) == 1)
    assert np.array_equal(regions["inside the container"], container_silhouette(setup))
