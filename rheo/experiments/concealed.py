"""Concealed-effect dam breaks: a virtual lab films a dam break with effects switched on that the fit's base model
lacks (none, one, two, or one that no candidate models), and neither the fit nor the diagnosis is told which.

The lab simulates with the fit's simulator on a finer grid, with its own time step and particles (more per cell) and
its own account of each effect (``concealed_truth``, apart from the diagnosis' candidates), and draws the material with
the virtual lab's renderer (splats of another radius, supersampled); it still shares the fit's simulator, so it is
not independent of the fit. The recording takes the form of imported ViRheometry setups (setup.json and
masks.npz: silhouettes that include the container), one per channel of the scene, as the real recordings come in
pairs (a low and a tall column): one geometry alone lets a Bingham law mimic shear thinning. The first frame comes
``release_s`` after the release (one frame interval unless the case says), which the fit searches for.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rheo.experiments.dam_break import dam_break_scene
from rheo.experiments.effects import Effects
from rheo.experiments.virheometry import Setup, StaticBox, container_silhouette
from rheo.experiments.virtual_lab import lab_mask
from rheo.physics import HerschelBulkley
from rheo.vision.cameras import Camera, intrinsics, look_at

WALL = 0.003  # m: the channel's walls' thickness
WALL_HEIGHT = 0.2  # m
RELEASE_STEP = 1.0 / 240.0  # s: the lab's sampling, on which the release and the frames fall


def channel(scene: dict, geometry: dict, index: int, name: str, masks: list[np.ndarray] | None = None) -> Setup:
    """A channel of material ``geometry`` (``height`` and ``width``, m; the scene's ``depth`` in m, ``walls`` and
    ``floor`` contact laws, ``camera``, ``fps``, ``density``) as a setup named ``{name}_{index}``, with ``masks`` if
    given."""
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


def anonymous(name: str) -> str:
    """A label that says nothing of what it names: the case's, in the recordings the fit and the diagnosis read."""
    return "c" + hashlib.sha256(name.encode()).hexdigest()[:8]


def rolled(camera: Camera, degrees: float) -> Camera:
    """The camera turned about its optical axis by ``degrees``."""
    angle = math.radians(degrees)
    roll = np.eye(4)
    roll[:2, :2] = [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]]
    return dataclasses.replace(camera, c2w=camera.c2w @ roll)


def zoomed(camera: Camera, share: float) -> Camera:
    """The camera with its focal length ``share`` longer (negative: shorter) than its calibration says."""
    return dataclasses.replace(camera, K=camera.K @ np.diag([1.0 + share, 1.0 + share, 1.0]))


# The lab's own account of each effect it can film (written apart from the diagnosis' candidates, which the lab never
# reads): the Effects field it sets, or the optional physics; shear thinning sets the law's n.
EFFECT_FIELDS = {"floor_friction": "floor_friction", "wall_slip": "wall_slip", "gate_lift": "gate_lift_time"}
PHYSICS_FIELDS = ("wall_adhesion", "thixotropy", "surface_tension", "air_drag")
# what the lab can film that no candidate models, a camera miscalibrated: rolled about its axis (deg) while the
# recording states it level, or its focal length longer by a share than the recording states
OUTSIDE_EFFECTS = ("camera_roll", "camera_zoom")


@dataclass(frozen=True)
class Truth:
    """What the lab films: the law (tau_y, K, n), the simulated effects, the camera's roll (deg) and its focal
    length's error (a share)."""

    law: dict[str, float]
    effects: Effects
    camera_roll: float = 0.0
    camera_zoom: float = 0.0


def concealed_truth(case: dict, base: dict[str, float]) -> Truth:
    """The law and effects the lab films: the case's own ``law`` (else ``base``), Bingham, with each of its
    ``effects`` ({effect, magnitude}) switched on."""
    law, effects, camera = {"n": 1.0, **base, **case.get("law", {})}, Effects(), {}
    for item in case.get("effects", []):
        name, magnitude = item["effect"], item["magnitude"]
        if name == "shear_thinning":
            law["n"] = magnitude
        elif name in EFFECT_FIELDS:
            effects = dataclasses.replace(effects, **{EFFECT_FIELDS[name]: magnitude})
        elif name in PHYSICS_FIELDS:
            effects = dataclasses.replace(effects, physics=dataclasses.replace(effects.physics, **{name: magnitude}))
        elif name in OUTSIDE_EFFECTS:
            camera[name] = camera.get(name, 0.0) + magnitude
        else:
            known = ["shear_thinning", *EFFECT_FIELDS, *PHYSICS_FIELDS, *OUTSIDE_EFFECTS]
            raise ValueError(f"unknown effect {name!r}; known: {', '.join(known)}")
    return Truth(law, effects, **camera)


def film(scene: dict, geometry: dict, index: int, lab: dict, name: str, truth: Truth, mu: float, lam: float,
         release: float) -> Setup:
    """The lab's recording of a channel of material ``geometry``: ``scene["frames"]`` silhouettes, the first
    ``release`` s after the release (a whole number of 1/240 s), simulated at the ``lab``'s resolution
    (``cells_per_height``, ``cells_across``, ``particles_per_cell``, ``cfl``, ``transfer_cfl``; ``reach``: how far
    past the gate (m) the simulated floor extends), filmed with the truth's camera roll and focal length."""
    setup = channel(scene, geometry, index, name)
    if not setup.camera.pixels(setup.cuboid_corners())[1].all():
        raise ValueError(f"concealed channel {index}: the material ({setup.height:g} x {setup.width:g} m) "
                         "leaves the camera's view")
    lab_scene = dam_break_scene(setup, lab["cells_per_height"], lab["cells_across"], lab["particles_per_cell"],
                                reach=lab["reach"], cfl=lab["cfl"], transfer_cfl=lab["transfer_cfl"])
    material = HerschelBulkley(**truth.law, mu=mu, lam=lam, density=setup.density)
    first, per_frame = round(release / RELEASE_STEP), round(1.0 / (setup.fps * RELEASE_STEP))
    if not (math.isclose(first * RELEASE_STEP, release) and math.isclose(per_frame * RELEASE_STEP, 1.0 / setup.fps)):
        raise ValueError(f"release {release!r} s and the frame interval 1/{setup.fps:g} s must be whole numbers of "
                         f"{RELEASE_STEP:.4g} s")
    steps = first + (scene["frames"] - 1) * per_frame
    positions = lab_scene.positions(lab_scene.rollout(material, steps * RELEASE_STEP, RELEASE_STEP, truth.effects))
    camera = zoomed(rolled(setup.camera, truth.camera_roll), truth.camera_zoom)
    container = container_silhouette(dataclasses.replace(setup, camera=camera))
    masks = [lab_mask(camera, positions[first + k * per_frame], lab_scene.spacing) | container
             for k in range(scene["frames"])]
    setup.masks[:] = masks
    return setup
