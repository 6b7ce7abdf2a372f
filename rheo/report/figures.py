"""Figures written beside stage artifacts (PNG), for people and for the report."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def camera_frusta(cameras: dict[str, dict], points: np.ndarray | None = None, title: str = "cameras"):
    """Camera frusta (OpenCV axes, ``c2w``) in the world frame (y up), with optional points (the object or board)."""
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    centers = []
    for name, cam in cameras.items():
        c2w = np.asarray(cam["c2w"])
        K = np.asarray(cam["K"])
        w, h = cam["width"], cam["height"]
        scale = 0.2 * max(np.linalg.norm(c2w[:3, 3]), 1e-3)
        corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)
        rays = np.c_[(corners - K[:2, 2]) / np.diag(K)[:2], np.ones(4)] * scale
        world = rays @ c2w[:3, :3].T + c2w[:3, 3]
        center = c2w[:3, 3]
        centers.append(center)
        for p in world:
            ax.plot(*np.c_[center, p][[0, 2, 1]], color="tab:blue", lw=0.8)
        loop = np.r_[world, world[:1]]
        ax.plot(loop[:, 0], loop[:, 2], loop[:, 1], color="tab:blue", lw=0.8)
        ax.text(center[0], center[2], center[1], name, fontsize=7)
    if points is not None and len(points):
        ax.scatter(points[:, 0], points[:, 2], points[:, 1], s=1, color="tab:orange")
    extent = np.vstack([np.asarray(centers), *([] if points is None else [points])])
    lo, hi = extent.min(axis=0), extent.max(axis=0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2 + 1e-3
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[2] - half, mid[2] + half)
    ax.set_zlim(mid[1] - half, mid[1] + half)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_zlabel("y, up (m)")
    ax.set_title(title)
    return fig


def save_figure(fig, path) -> None:
    """Write a figure atomically as PNG."""
    from rheo.io import write_atomic

    write_atomic(path, lambda p: fig.savefig(p, format="png", dpi=110, bbox_inches="tight"))
    plt.close(fig)


def particle_views(points: np.ndarray, title: str = "particles"):
    """Front (x-y), side (z-y) and top (x-z) views of a particle set."""
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.6))
    for ax, (a, b, label) in zip(axes, [(0, 1, "front: x, y"), (2, 1, "side: z, y"), (0, 2, "top: x, z")],
                                 strict=True):
        ax.scatter(points[:, a], points[:, b], s=0.5, alpha=0.4)
        ax.set_aspect("equal")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    return fig


def mask_overlays(items: list[tuple[str, np.ndarray, np.ndarray]], columns: int = 4):
    """Frames with their masks outlined and tinted: (title, RGB image, boolean mask) per panel."""
    from scipy import ndimage

    rows = max(1, -(-len(items) // columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 3.0 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (title, image, mask) in zip(axes.ravel(), items, strict=False):
        shown = image.astype(float) / 255.0
        shown[mask] = 0.6 * shown[mask] + 0.4 * np.array([0.1, 0.4, 1.0])
        edge = mask & ~ndimage.binary_erosion(mask)
        shown[edge] = [1.0, 1.0, 0.0]
        ax.imshow(shown)
        ax.set_title(title, fontsize=8)
    return fig


def contact_sheet(rows: dict[str, list[tuple[str, np.ndarray]]]):
    """A grid of images: one row per camera, (title, RGB image) per panel."""
    columns = max(len(panels) for panels in rows.values())
    fig, axes = plt.subplots(len(rows), columns, figsize=(3.0 * columns, 2.6 * len(rows)), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for row, (name, panels) in zip(axes, rows.items(), strict=True):
        for ax, (title, image) in zip(row, panels, strict=False):
            ax.imshow(image)
            ax.set_title(f"{name}: {title}", fontsize=8)
    return fig
