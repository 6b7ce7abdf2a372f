"""Figures of the ViRheometry dam breaks."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rheo.experiments.virheometry import Setup

CUBOID_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]


def camera_check_figure(setup: Setup, overlap: dict[str, float], margin: int = 25):
    """The first and last silhouettes with the initial cuboid's edges projected through the setup's camera."""
    low, high = setup.cuboid
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    uv, _ = setup.camera.project(corners)
    rows, cols = np.nonzero(setup.masks[0] | setup.masks[-1])
    left, right = min(cols.min(), uv[:, 0].min()) - margin, max(cols.max(), uv[:, 0].max()) + margin
    top, bottom = min(rows.min(), uv[:, 1].min()) - margin, max(rows.max(), uv[:, 1].max()) + margin
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, frame in zip(axes, (0, len(setup.masks) - 1), strict=True):
        ax.imshow(~setup.masks[frame], cmap="gray", vmin=0, vmax=1.6)
        for a, b in CUBOID_EDGES:
            ax.plot(uv[[a, b], 0], uv[[a, b], 1], color="tab:red", lw=1)
        ax.set_xlim(left, right)
        ax.set_ylim(bottom, top)
        ax.set_title(f"frame {frame + 1}" + (" and the initial cuboid" if frame == 0 else ""), fontsize=9)
        ax.axis("off")
    fig.suptitle(f"{setup.folder.name}: cuboid on frame 1, IoU {overlap['iou']:.3f}, "
                 f"{100 * overlap['cuboid_on_silhouette']:.1f} % of the cuboid on the silhouette", fontsize=10)
    fig.tight_layout()
    return fig
