"""The virtual lab: simulate an experiment with finer particles than any fit (on the fit's grid) from the true
geometry, and film it with the lab renderer (not the fit's).

Recordings layout (the same that ingest writes for real videos), per camera ``<cam>/``: ``frames/NNN.png``,
``video.mp4``, ``clean_plate.png``, ``checkerboard/NN.png`` (board poses for intrinsics), ``ground_board.png`` (the
board lying on the floor: the world frame) and, in the lab only, ``masks/NNN.png`` (true material masks).
"""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import torch
from tqdm.auto import tqdm

from rheo.experiments.scene import particle_spacing, simulator
from rheo.geometry.proxy import from_config, voxelize
from rheo.io import write_atomic_dir
from rheo.render.lab import FloorBoard, Scene, board_texture, render, splats
from rheo.vision.cameras import Camera, hemisphere


@dataclass(frozen=True)
class LabBoard:
    """The lab's calibration board and how it is shown."""

    columns: int = 9
    rows: int = 6
    square: float = 0.06
    views: int = 40  # checkerboard images per camera for intrinsics
    ground_origin: tuple[float, float] = (0.25, 0.35)  # first inner corner on the floor (x, z)


def simulate_truth(exp: dict, progress: bool = True) -> dict:
    """Particle positions at every recorded frame, simulated with the lab's particles per cell."""
    sim_cfg = exp["simulation"]
    sim = simulator(exp, sim_cfg["resolution"])
    spacing = particle_spacing(sim_cfg)
    mesh, _ = from_config(exp["proxy"])
    particles = torch.as_tensor(voxelize(mesh, spacing).particles, dtype=torch.float32)
    frames = sim_cfg["frames"] - 1
    tr = sim.rollout(particles, torch.tensor(sim_cfg["initial_velocity"]), frames=frames,
                     frame_dt=sim_cfg["duration"] / frames, particle_volume=spacing**3, progress=progress)
    return {"positions": tr.x.numpy(), "times": tr.times.numpy(), "spacing": spacing, "dt": tr.dt}


def cameras(exp: dict) -> list[Camera]:
    c = exp["cameras"]
    return hemisphere(c["count"], c["distance"], c["elevation_deg"], c["look_at"], c["width"], c["height"],
                      c["fov_deg"], c["distortion"])


def _supersampled(camera: Camera, factor: int) -> Camera:
    """The same camera with ``factor`` x ``factor`` pixels per pixel (pixel centres at integers, as in OpenCV)."""
    K = camera.K.copy()
    K[0, 0] *= factor
    K[1, 1] *= factor
    K[:2, 2] = factor * K[:2, 2] + (factor - 1) / 2
    return Camera(camera.width * factor, camera.height * factor, K, camera.dist, camera.c2w)


def _downsample(image: np.ndarray, camera: Camera) -> np.ndarray:
    return cv2.resize(image, (camera.width, camera.height), interpolation=cv2.INTER_AREA)


def board_poses(camera: Camera, board: LabBoard, rng: np.random.Generator) -> list[np.ndarray]:
    """Board-to-world transforms of ``board.views`` tilted boards filling about two thirds of the camera's view,
    shifted towards the image edges (a firm principal point) but always whole in the image (a board cut by the image
    border is not detected)."""
    width = (board.columns + 1) * board.square
    distance = width / (0.65 * camera.width / camera.K[0, 0])
    center = np.array([(board.columns - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square
    outline = np.array([[-1, -1, 0], [board.columns, -1, 0], [-1, board.rows, 0], [board.columns, board.rows, 0]],
                       float) * board.square
    poses = []
    while len(poses) < board.views:
        tilt = np.radians(rng.uniform(-40, 40, size=2))
        R_board, _ = cv2.Rodrigues(np.array([tilt[0], tilt[1], rng.uniform(-0.3, 0.3)]))
        shift = rng.uniform(-0.22, 0.22, size=2) * distance
        cam_from_board = np.eye(4)
        cam_from_board[:3, :3] = R_board
        cam_from_board[:3, 3] = np.array([shift[0], shift[1], distance]) - R_board @ center
        pose = camera.c2w @ cam_from_board
        uv, _ = camera.project(outline @ pose[:3, :3].T + pose[:3, 3])
        if uv.min() >= 2 and uv[:, 0].max() <= camera.width - 3 and uv[:, 1].max() <= camera.height - 3:
            poses.append(pose)
    return poses


def render_board_view(camera: Camera, board: LabBoard, pose: np.ndarray, rng: np.random.Generator,
                      noise: float = Scene.noise) -> np.ndarray:
    """The board at ``pose`` (board-to-world) in front of a plain wall, anti-aliased by 3x supersampling."""
    fine = _supersampled(camera, 3)
    origin, dirs = fine.pixel_rays()
    normal, point, axes = pose[:3, 2], pose[:3, 3], pose[:3, :2]
    denom = dirs @ normal
    facing = np.abs(denom) > 1e-9
    t = np.where(facing, ((point - origin) @ normal) / np.where(facing, denom, 1), -1)
    local = (origin - point) @ axes + t[..., None] * (dirs @ axes)  # board coordinates of the ray's hit
    spec = FloorBoard(board.columns, board.rows, board.square)
    grey, inside = board_texture(local[..., 0], local[..., 1], spec)
    image = _downsample((np.clip(np.where(inside & (t > 0), grey, 0.6), 0, 1) * 255).astype(np.float32), camera)
    return _uint8(image[..., None] + rng.normal(0.0, 255 * noise, (*image.shape, 3)))


def _write_png(path: Path, image: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), image[..., ::-1] if image.ndim == 3 else image)


def lab_view(camera: Camera, points: np.ndarray | None = None, spacing: float | None = None,
              board: FloorBoard | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A noise-free view rendered at twice the resolution and averaged down: image (float, 0-255) and true mask."""
    image, mask = render(_supersampled(camera, 2), points, spacing, board=board)
    return _downsample(image.astype(np.float32), camera), _downsampled_mask(mask, camera)


def lab_mask(camera: Camera, points: np.ndarray, spacing: float) -> np.ndarray:
    """``lab_view``'s true mask alone (no image drawn)."""
    return _downsampled_mask(splats(_supersampled(camera, 2), points, spacing)[1], camera)


def _downsampled_mask(mask: np.ndarray, camera: Camera) -> np.ndarray:
    """A mask rendered at twice the resolution, averaged down: the pixels at least half covered."""
    return _downsample(mask.astype(np.float32), camera) >= 0.5


def _uint8(image: np.ndarray) -> np.ndarray:
    return (np.clip(image, 0, 255) + 0.5).astype(np.uint8)


def _film_camera(cam_dir: Path, cam: Camera, truth: dict, board: LabBoard, fps: float, seed: list[int]) -> None:
    """One camera's frames, true masks, video, clean plate, checkerboard images and floor-board image."""
    rng = np.random.default_rng(seed)
    frames = []
    for f, points in enumerate(truth["positions"]):
        image, mask = lab_view(cam, points, truth["spacing"])
        image = _uint8(image + rng.normal(0.0, 255 * Scene.noise, image.shape))
        _write_png(cam_dir / "frames" / f"{f:03d}.png", image)
        _write_png(cam_dir / "masks" / f"{f:03d}.png", mask.astype(np.uint8) * 255)
        frames.append(image)
    imageio.mimwrite(cam_dir / "video.mp4", frames, fps=max(fps, 1.0), macro_block_size=1, quality=9)
    _write_png(cam_dir / "clean_plate.png", _uint8(lab_view(cam)[0]))
    for i, pose in enumerate(board_poses(cam, board, rng)):
        _write_png(cam_dir / "checkerboard" / f"{i:02d}.png", render_board_view(cam, board, pose, rng))
    floor_board = FloorBoard(board.columns, board.rows, board.square, board.ground_origin)
    _write_png(cam_dir / "ground_board.png", _uint8(lab_view(cam, board=floor_board)[0]))


def write_recordings(out_dir: str | Path, exp: dict, truth: dict, board: LabBoard = LabBoard(), seed: int = 0,
                     progress: bool = True, workers: int = 1) -> dict:
    """Render every camera's frames, masks, clean plate and calibration images into ``out_dir`` (atomically: a
    temporary folder moved into place), ``workers`` cameras at a time (each camera its own random stream, so the
    result does not depend on ``workers``). Returns the truth record for truth.json."""
    cams = cameras(exp)
    fps = (len(truth["times"]) - 1) / float(truth["times"][-1])

    def write(tmp: Path) -> None:
        jobs = [(tmp / f"cam{c:02d}", cam, truth, board, fps, [seed, c]) for c, cam in enumerate(cams)]
        with ProcessPoolExecutor(max_workers=workers) as pool:
            done = [pool.submit(_film_camera, *job) for job in jobs]
            for future in tqdm(as_completed(done), total=len(done), desc="render cameras", disable=not progress):
                future.result()
        summary = {f"cam{c:02d}": {"frames": len(truth["times"]), "fps": fps, "source": "virtual lab"}
                   for c in range(len(cams))}
        (tmp / "recording.json").write_text(json.dumps(summary, indent=2))

    write_atomic_dir(out_dir, write)
    return {"cameras": {f"cam{c:02d}": cam.record() for c, cam in enumerate(cams)},
            "board": {"columns": board.columns, "rows": board.rows, "square": board.square,
                      "ground_origin": [board.ground_origin[0], 0.0, board.ground_origin[1]]},
            "times": [float(t) for t in truth["times"]], "fps": fps}
