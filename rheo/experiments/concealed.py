"""Concealed-effect dam breaks: a virtual lab films a dam break with one effect switched on that the fit's base model
lacks (or none), and neither the fit nor the diagnosis is told which.

The lab simulates with the fit's simulator, on its grid and time step, with its own particles (more per cell), and
draws the material with the virtual lab's renderer (splats of another radius, supersampled): only the particles and
the renderer differ from the fit's model, so the cases are close to an inverse crime. The recording takes the form
of imported ViRheometry setups (setup.json and masks.npz: silhouettes that include the container), one per channel
geometry of the scene, as the real recordings come in pairs (a low and a tall column): one geometry alone lets a
Bingham law mimic shear thinning. The first frame comes one frame interval after the release, which the fit is
told.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rheo.diagnose.candidates import CANDIDATES
from rheo.experiments.dam_break import Effects, dam_break_scene
from rheo.experiments.virheometry import Setup, StaticBox, container_silhouette
from rheo.experiments.virtual_lab import lab_view
from rheo.physics import HerschelBulkley
from rheo.vision.cameras import Camera, intrinsics, look_at

WALL = 0.003  # m: the channel's walls' thickness
WALL_HEIGHT = 0.2  # m


def channel(scene: dict, index: int, name: str, masks: list[np.ndarray] | None = None) -> Setup:
    """The scene's channel ``index`` (1-based: its ``setups[index - 1]``'s material ``height`` and ``width``; the
    scene's ``depth`` in m, ``walls`` and ``floor`` contact laws, ``camera``, ``fps``, ``density``) as a setup named
    ``{name}_{index}``, with ``masks`` if given."""
    geometry = scene["setups"][index - 1]
    height, width, depth = geometry["height"], geometry["width"], scene["depth"]
    walls = [StaticBox((-1.0, -0.01, -1.0), (1.0, 0.0, 1.0), scene["floor"]),
             StaticBox((-WALL, 0.0, 0.0), (0.0, WALL_HEIGHT, depth), scene["walls"]),
             StaticBox((-WALL, 0.0, -WALL), (width, WALL_HEIGHT, 0.0), scene["walls"]),
             StaticBox((-WALL, 0.0, depth), (width, WALL_HEIGHT, depth + WALL), scene["walls"])]
    cam = scene["camera"]
    camera = Camera(cam["width"], cam["height"], intrinsics(cam["width"], cam["height"], cam["fov_deg"]),
                    np.zeros(5), look_at(cam["eye"], cam["look_at"]))
    return Setup(folder=Path(f"{name}_{index}"), material=name, index=index, height=height, width=width, depth=depth,
                 density=scene["density"], walls=walls, camera=camera, masks=list(masks or []), start_point=None,
                 fps=scene["fps"])


def concealed_truth(case: dict, base: dict[str, float]) -> tuple[dict[str, float], Effects]:
    """The law (tau_y, K, n) and effects the lab films: the ``base`` law with the case's ``effect`` at its
    ``magnitude`` (effect ``none``: the base law alone)."""
    law = {"n": 1.0, **base}
    if case["effect"] == "none":
        return law, Effects()
    if case["effect"] not in CANDIDATES:
        raise ValueError(f"unknown effect {case['effect']!r}; known: none, {', '.join(CANDIDATES)}")
    return CANDIDATES[case["effect"]].apply(case["magnitude"], law, Effects())


def film(scene: dict, index: int, lab: dict, name: str, law: dict[str, float], effects: Effects,
         mu: float, lam: float) -> Setup:
    """The lab's recording of the scene's channel ``index``: ``scene["frames"]`` silhouettes, the first one frame
    interval after the release, simulated at the ``lab``'s resolution (``cells_per_height``, ``cells_across``,
    ``particles_per_cell``, ``cfl``; ``reach``: how far past the gate (m) the simulated floor extends)."""
    setup = channel(scene, index, name)
    if not setup.camera.pixels(setup.cuboid_corners())[1].all():
        raise ValueError(f"concealed scene, setup {index}: the material ({setup.height:g} x {setup.width:g} m) "
                         "leaves the camera's view")
    lab_scene = dam_break_scene(setup, lab["cells_per_height"], lab["cells_across"], lab["particles_per_cell"],
                                reach=lab["reach"], cfl=lab["cfl"])
    material = HerschelBulkley(**law, mu=mu, lam=lam, density=setup.density)
    dt = 1.0 / setup.fps
    positions = lab_scene.positions(lab_scene.rollout(material, scene["frames"] * dt, dt, effects))
    container = container_silhouette(setup)
    masks = [lab_view(setup.camera, positions[k], lab_scene.spacing)[1] | container
             for k in range(1, scene["frames"] + 1)]
    setup.masks[:] = masks
    return setup
