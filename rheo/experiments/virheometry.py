"""ViRheometry dam-break setups (Hamamichi et al. 2023) read into SI units.

A setup folder ``ref_<Material>_<H>_<W>_<k>`` holds settings.xml (density, H, W, the particle cuboid, the static
boxes), camera_params.xml (eye, OpenGL quaternion, vertical field of view, window size) and config_01.png ...
binary silhouettes (black: material) at twice the window size, 24 frames per second. The files are in CGS units
(cm, g/cm^3, dyn/cm^2); everything returned here is in m, kg/m^3 and Pa. The material starts as the cuboid
x in [0, W], y in [0, H], z between the side walls; the back wall is x = 0 and the gate at x = W is lifted.
"""

from __future__ import annotations

import dataclasses
import logging
import re
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from rheo.render.silhouette import iou
from rheo.vision.cameras import Camera

logger = logging.getLogger(__name__)

CM = 0.01  # m
G_PER_CM3 = 1000.0  # kg/m^3
DYN_PER_CM2 = 0.1  # Pa
FPS = 24.0
FRAMES = 8  # silhouettes per setup, config_01.png to config_08.png
DENSITY_RANGE = (300.0, 3000.0)  # kg/m^3: pastes, creams and sauces lie well inside it
MASK_COVERAGE = (1e-4, 0.9)  # share of the image a silhouette (with its container) may cover
FOLDER_NAME = re.compile(r"^ref_(?P<material>[A-Za-z0-9]+)_(?P<H>\d+(?:\.\d+)?)_(?P<W>\d+(?:\.\d+)?)_(?P<k>\d+)$")
CONTACTS = {"sticking": "sticky", "slipping": "slip"}
CONTAINER_RIM = 3  # px at half the window size: how much wider the recorded container is than the cuboid's outline


class SetupError(ValueError):
    """A setup folder or file that cannot be read as a ViRheometry dam break."""


@dataclass(frozen=True)
class StaticBox:
    """An axis-aligned solid box (m) with its contact law."""

    low: tuple[float, float, float]
    high: tuple[float, float, float]
    contact: str


@dataclass
class Setup:
    """One recorded dam break: geometry (m), density (kg/m^3), camera, silhouettes (frame 1 first) and, where the
    file gives one, the authors' search start point (tau_y in Pa, K in Pa s^n, n; not a measurement)."""

    folder: Path
    material: str
    index: int
    height: float
    width: float
    depth: float
    density: float
    walls: list[StaticBox]
    camera: Camera
    masks: list[np.ndarray] = field(repr=False)
    start_point: dict[str, float] | None
    fps: float = FPS

    @property
    def cuboid(self) -> tuple[np.ndarray, np.ndarray]:
        """Corners (low, high) of the material at rest before the gate opens."""
        return np.array([0.0, 0.0, 0.0]), np.array([self.width, self.height, self.depth])

    def cuboid_corners(self) -> np.ndarray:
        """The cuboid's eight corners (8, 3), corner i at (high if bit 2, 1, 0 of i is set for x, y, z)."""
        low, high = self.cuboid
        return np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])

    def record(self) -> dict:
        """Everything but the masks, JSON-ready."""
        return {"folder": str(self.folder), "material": self.material, "index": self.index, "height": self.height,
                "width": self.width, "depth": self.depth, "density": self.density,
                "walls": [dataclasses.asdict(w) for w in self.walls], "camera": self.camera.record(),
                "start_point": self.start_point, "fps": self.fps}

    @classmethod
    def from_record(cls, record: dict, masks: np.ndarray) -> Setup:
        walls = [StaticBox(tuple(w["low"]), tuple(w["high"]), w["contact"]) for w in record["walls"]]
        return cls(folder=Path(record["folder"]), material=record["material"], index=record["index"],
                   height=record["height"], width=record["width"], depth=record["depth"],
                   density=record["density"], walls=walls, camera=Camera.from_record(record["camera"]),
                   masks=list(masks), start_point=record["start_point"], fps=record["fps"])


def _xml(path: Path, salvage: str | None = None) -> ET.Element:
    """The file's root element; where the file is not well-formed XML but holds one complete ``<salvage .../>``
    element (one published camera file lacks its opening root tag), that element alone, with a warning."""
    if not path.is_file():
        raise SetupError(f"{path}: missing")
    text = path.read_text(errors="replace")
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        found = re.findall(rf"<{salvage}\b[^<>]*/>", text) if salvage else []
        if len(found) != 1:
            raise SetupError(f"{path}: not valid XML ({err})") from err
        logger.warning("%s: not valid XML (%s); read its one <%s/> element alone", path, err, salvage)
        return ET.fromstring(found[0])


def _attribute(path: Path, root: ET.Element, tag: str, name: str, count: int = 1) -> list[float]:
    """``count`` numbers from attribute ``name`` of the first ``tag`` element."""
    element = next(root.iter(tag), None)
    if element is None or name not in element.attrib:
        raise SetupError(f"{path}: no <{tag} {name}=...>")
    try:
        values = [float(v) for v in element.attrib[name].split()]
    except ValueError as err:
        raise SetupError(f"{path}: <{tag} {name}={element.attrib[name]!r}> is not a list of numbers") from err
    if len(values) != count or not np.all(np.isfinite(values)):
        raise SetupError(f"{path}: <{tag} {name}> needs {count} finite numbers, got {element.attrib[name]!r}")
    return values


def opengl_camera(eye: np.ndarray, quaternion: np.ndarray, fov_y_deg: float, width: int, height: int) -> Camera:
    """A camera from an OpenGL pose (viewing direction q (0, 0, -1), up q (0, 1, 0); q = (w, x, y, z)) and a
    perspective of vertical field of view ``fov_y_deg`` on a ``width`` x ``height`` image."""
    norm = np.linalg.norm(quaternion)
    if not np.isfinite(norm) or norm < 1e-9:
        raise SetupError(f"camera quaternion {quaternion.tolist()} has no direction")
    w, x, y, z = quaternion / norm
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    c2w = np.eye(4)
    c2w[:3, :3] = rotation @ np.diag([1.0, -1.0, -1.0])  # OpenGL (x right, y up, -z forward) to OpenCV axes
    c2w[:3, 3] = eye
    focal = 0.5 * height / np.tan(np.radians(fov_y_deg) / 2)
    # OpenGL pixel centres lie at half-integers, OpenCV's at integers
    K = np.array([[focal, 0.0, width / 2 - 0.5], [0.0, focal, height / 2 - 0.5], [0.0, 0.0, 1.0]])
    return Camera(width, height, K, np.zeros(5), c2w)


def _walls(path: Path, root: ET.Element) -> list[StaticBox]:
    walls = []
    for element in root.iter("static_box"):
        try:
            low = tuple(CM * float(v) for v in element.attrib["min"].split())
            high = tuple(CM * float(v) for v in element.attrib["max"].split())
            behaviour = element.attrib["boundary_behavior"]
        except (KeyError, ValueError) as err:
            raise SetupError(f"{path}: a <static_box> without numeric min, max and a boundary_behavior") from err
        if len(low) != 3 or len(high) != 3 or not all(h > lo for lo, h in zip(low, high, strict=True)):
            raise SetupError(f"{path}: <static_box min={element.attrib['min']!r} max={element.attrib['max']!r}> is "
                             "not a box")
        if behaviour not in CONTACTS:
            raise SetupError(f"{path}: boundary_behavior {behaviour!r} unknown; known: {sorted(CONTACTS)}")
        walls.append(StaticBox(low, high, CONTACTS[behaviour]))
    return walls


def _channel_depth(path: Path, walls: list[StaticBox], width: float) -> float:
    """The gap between the two side walls (boxes beside the material, z below 0 and above it)."""
    beside = [w for w in walls if w.low[0] < width and w.high[1] > 0.0 and w.low[1] >= 0.0 and w.high[0] > 0.0]
    front = [w.high[2] for w in beside if w.high[2] <= 1e-9]
    back = [w.low[2] for w in beside if w.low[2] > 1e-9]
    if not front or not back:
        raise SetupError(f"{path}: no pair of side walls (static boxes at z <= 0 and z > 0 beside the material)")
    return min(back) - max(front)


def read_masks(folder: Path, width: int, height: int) -> list[np.ndarray]:
    """The silhouettes config_01.png, config_02.png, ... (black: material), averaged down to ``width`` x ``height``
    and thresholded at half coverage."""
    paths = sorted(folder.glob("config_[0-9][0-9].png"))
    if not paths:
        raise SetupError(f"{folder}: no silhouettes config_01.png, config_02.png, ...")
    numbers = [int(p.stem.split("_")[1]) for p in paths]
    expected = range(1, max(FRAMES, len(paths)) + 1)
    missing = [f"config_{k:02d}.png" for k in expected if k not in numbers]
    if missing:
        raise SetupError(f"{folder}: {', '.join(missing)} missing; a setup holds the silhouettes config_01.png to "
                         f"config_{len(expected):02d}.png")
    masks = []
    for path in paths:
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise SetupError(f"{path}: not a readable image")
        if image.shape[1] * height != image.shape[0] * width:
            raise SetupError(f"{path}: {image.shape[1]}x{image.shape[0]} px does not have the camera's aspect "
                             f"{width}x{height}")
        material = (image < 128).astype(np.float32)
        coverage = float(material.mean())
        if not MASK_COVERAGE[0] <= coverage <= MASK_COVERAGE[1]:
            raise SetupError(f"{path}: the silhouette covers {100 * coverage:.3g} % of the image; black marks the "
                             f"material and its container, white the rest ({100 * MASK_COVERAGE[0]:g} to "
                             f"{100 * MASK_COVERAGE[1]:g} % expected)")
        masks.append(cv2.resize(material, (width, height), interpolation=cv2.INTER_AREA) >= 0.5)
    return masks


def setup_folders(data: str | Path, material: str) -> list[Path]:
    """A material's setup folders (ref_<material>_<H>_<W>_<k>) in ``data``, by setup index k."""
    def index(folder: Path) -> tuple[int, str]:  # a misnamed folder last, for read_setup to refuse
        match = FOLDER_NAME.match(folder.name)
        return (int(match["k"]), "") if match else (sys.maxsize, folder.name)

    folders = sorted(Path(data).glob(f"ref_{material}_*_*_*"), key=index)
    if not folders:
        raise ValueError(f"{data}: no setup folders ref_{material}_<H>_<W>_<k>")
    return folders


def read_setup(folder: str | Path, scale: float = 1.0, fps: float = FPS) -> Setup:
    """A setup folder, its frames ``fps`` apart; the camera and masks at ``scale`` times the window size (the PNGs
    are at twice it)."""
    folder = Path(folder)
    match = FOLDER_NAME.match(folder.name)
    if not folder.is_dir() or match is None:
        raise SetupError(f"{folder}: not a setup folder named ref_<Material>_<H>_<W>_<k>")
    settings_path, camera_path = folder / "settings.xml", folder / "camera_params.xml"
    settings, camera_xml = _xml(settings_path), _xml(camera_path, salvage="camera")
    (rho,), (height,), (width,) = (_attribute(settings_path, settings, "setup", n) for n in ("RHO", "H", "W"))
    if not DENSITY_RANGE[0] <= rho * G_PER_CM3 <= DENSITY_RANGE[1]:
        raise SetupError(f"{settings_path}: <setup RHO={rho:g}> is a density of {rho * G_PER_CM3:g} kg/m^3; RHO is in "
                         f"g/cm^3, between {DENSITY_RANGE[0] / G_PER_CM3:g} and {DENSITY_RANGE[1] / G_PER_CM3:g} "
                         "for a paste")
    # the simulated cuboid reaches x = W, y = H; one published <setup> swaps H and W, which the cuboid, the walls
    # and the folder name agree on
    cuboid_width, cuboid_height = _attribute(settings_path, settings, "cuboid", "max", 3)[:2]
    if not np.isclose([cuboid_height, cuboid_width], [float(match["H"]), float(match["W"])]).all():
        raise SetupError(f"{settings_path}: the cuboid's top corner (x {cuboid_width}, y {cuboid_height} cm) "
                         f"disagrees with the folder name {folder.name}")
    if not np.isclose([height, width], [cuboid_height, cuboid_width]).all():
        logger.warning("%s: <setup H=%g W=%g> disagrees with the cuboid and the folder name (H %g, W %g cm): "
                       "using the latter", settings_path, height, width, cuboid_height, cuboid_width)
        height, width = cuboid_height, cuboid_width
    start = None
    if next(settings.iter("initial_material"), None) is not None:
        sigma_y, eta, n = (_attribute(settings_path, settings, "initial_material", key)[0]
                           for key in ("sigmaY", "eta", "n"))
        start = {"tau_y": sigma_y * DYN_PER_CM2, "K": eta * DYN_PER_CM2, "n": n}
    walls = _walls(settings_path, settings)
    eye = np.array(_attribute(camera_path, camera_xml, "camera", "eyepos", 3)) * CM
    quaternion = np.array(_attribute(camera_path, camera_xml, "camera", "quat", 4))
    (fov,) = _attribute(camera_path, camera_xml, "camera", "fov")
    window = _attribute(camera_path, camera_xml, "camera", "window_size", 2)
    if not 0.0 < fov < 180.0 or min(window) < 1:
        raise SetupError(f"{camera_path}: fov {fov} or window_size {window} out of range")
    size = (round(window[0] * scale), round(window[1] * scale))
    return Setup(folder=folder, material=match["material"], index=int(match["k"]), height=height * CM,
                 width=width * CM, depth=_channel_depth(settings_path, walls, width * CM), density=rho * G_PER_CM3,
                 walls=walls, camera=opengl_camera(eye, quaternion, fov, *size),
                 masks=read_masks(folder, *size), start_point=start, fps=fps)


def container_silhouette(setup: Setup, rim: int = 0) -> np.ndarray:
    """The silhouette (H, W) of the material's initial cuboid, which is also the container's (the recordings'
    silhouettes include the container, so every frame covers it), grown by ``rim`` px."""
    uv, depth = setup.camera.project(setup.cuboid_corners())
    if (depth <= 0).any():
        raise SetupError(f"{setup.folder}: the material's cuboid lies (partly) behind the camera")
    projected = np.zeros((setup.camera.height, setup.camera.width), np.uint8)
    cv2.fillConvexPoly(projected, cv2.convexHull(np.round(uv * 16).astype(np.int32)), 1, cv2.LINE_8, shift=4)
    if rim:
        projected = cv2.dilate(projected, np.ones((2 * rim + 1, 2 * rim + 1), np.uint8))
    return projected.astype(bool)


def cuboid_overlap(setup: Setup) -> dict[str, float]:
    """How the initial cuboid, projected through the setup's camera, covers the first silhouette: IoU, the fraction
    of the cuboid's projection on the silhouette and of the silhouette on it."""
    projected = container_silhouette(setup)
    mask = setup.masks[0]
    both = float((projected & mask).sum())
    return {"iou": iou(projected, mask), "cuboid_on_silhouette": both / max(float(projected.sum()), 1.0),
            "silhouette_on_cuboid": both / max(float(mask.sum()), 1.0)}
