"""Shared test settings (Warp's quiet start-up) and a synthetic dam-break channel."""

import html
from pathlib import Path

import cv2
import numpy as np
import pytest
import warp as wp

from rheo.experiments.virheometry import Setup, StaticBox
from rheo.vision.cameras import Camera, intrinsics, look_at

wp.config.quiet = True


DEPTH, HEIGHT, WIDTH = 0.04, 0.02, 0.025


def channel_setup(footprint_rect: tuple[float, float, float, float], frames: int = 2,
                  walls: str = "sticky") -> Setup:
    """A channel 2.5 cm wide, 2 cm high, 4 cm deep on a sticky floor, its standing walls' contact ``walls``, whose
    ``frames`` silhouettes all show the floor rectangle (x0, x1, z0, z1)."""
    camera = Camera(320, 180, intrinsics(320, 180, 50.0), np.zeros(5), look_at([0.04, 0.12, 0.28], [0.04, 0.0, 0.02]))
    x0, x1, z0, z1 = footprint_rect
    corners = np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z1]], float)
    uv, _ = camera.project(corners)
    mask = np.zeros((180, 320), np.uint8)
    cv2.fillConvexPoly(mask, np.round(uv * 16).astype(np.int32), 1, cv2.LINE_8, shift=4)
    boxes = [StaticBox((-1.0, -0.01, -1.0), (1.0, 0.0, 1.0), "sticky"),
             StaticBox((-0.01, 0.0, 0.0), (0.0, 0.2, DEPTH), walls),
             StaticBox((-0.01, 0.0, -0.003), (WIDTH, 0.2, 0.0), walls),
             StaticBox((-0.01, 0.0, DEPTH), (WIDTH, 0.2, DEPTH + 0.003), walls)]
    return Setup(folder=Path("ref_Test_2.0_2.5_1"), material="Test", index=1, height=HEIGHT, width=WIDTH,
                 depth=DEPTH, density=1000.0, walls=boxes, camera=camera, masks=[mask.astype(bool)] * frames,
                 start_point=None)


def table_cells(row: str) -> list[str]:
    """The text of an HTML table row's cells."""
    return [html.unescape(c.split("</td>")[0]) for c in row.split("<td>")[1:]]


@pytest.fixture
def channel():
    """The synthetic channel setup, by its floor rectangle and frame count."""
    return channel_setup
