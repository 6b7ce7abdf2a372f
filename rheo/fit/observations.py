"""What the fit compares against: every camera's matted frames and masks, its pixel rays, and the frame times; and
random ray batches drawn from them."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import torch
from scipy import ndimage

from rheo.vision.cameras import Camera


class ObservationError(ValueError):
    """Recordings, masks or cameras that do not fit together."""


@dataclass
class View:
    """One camera: its rays (origin (3,), unit directions (H*W, 3)), matted frames on white (F, H*W, 3, uint8), masks
    (F, H*W, bool), and the pixels worth sampling (``focus``: around where the material is in any frame)."""

    name: str
    camera: Camera
    origin: np.ndarray
    dirs: np.ndarray
    images: np.ndarray
    masks: np.ndarray
    focus: np.ndarray


@dataclass
class Observations:
    views: list[View]
    times: np.ndarray  # (F,) seconds from the first frame

    @property
    def frames(self) -> int:
        return len(self.times)


def _read(path: Path, flags: int) -> np.ndarray:
    image = cv2.imread(str(path), flags)
    if image is None:
        raise ObservationError(f"{path}: missing or unreadable")
    return image


def load(recordings: str | Path, matte: str | Path, cameras_file: str | Path, frames: int | None = None,
         focus_margin_px: int = 12) -> Observations:
    """The matted frames (white background) and masks of every calibrated camera, the first ``frames`` of them."""
    recordings, matte = Path(recordings), Path(matte)
    with open(cameras_file) as f:
        cameras = json.load(f)["cameras"]
    with open(recordings / "recording.json") as f:
        recording = json.load(f)
    rates = {rec["fps"] for rec in recording.values()}
    if len(rates) != 1:
        raise ObservationError(f"{recordings / 'recording.json'}: cameras at different frame rates {sorted(rates)}")
    views = []
    for name, record in cameras.items():
        camera = Camera.from_record(record)
        mask_paths = sorted((matte / name / "masks").glob("*.png"))[:frames]
        if not mask_paths:
            raise ObservationError(f"{matte / name / 'masks'}: no masks for camera {name}")
        masks = np.stack([_read(p, cv2.IMREAD_GRAYSCALE) > 127 for p in mask_paths])
        images = np.stack([_read(matte / name / "matted" / p.name, cv2.IMREAD_COLOR)[..., ::-1] for p in mask_paths])
        if images.shape[1:3] != (camera.height, camera.width):
            raise ObservationError(f"{matte / name}: frames of {images.shape[2]}x{images.shape[1]} px, but the "
                                   f"camera is calibrated for {camera.width}x{camera.height}")
        origin, dirs = camera.pixel_rays()
        focus = ndimage.binary_dilation(masks.any(axis=0), iterations=focus_margin_px)
        views.append(View(name, camera, origin, dirs.reshape(-1, 3).astype(np.float32),
                          images.reshape(len(images), -1, 3), masks.reshape(len(masks), -1),
                          np.flatnonzero(focus.ravel())))
    counts = {len(v.masks) for v in views}
    if len(counts) != 1:
        raise ObservationError(f"{matte}: cameras with different numbers of frames {sorted(counts)}")
    fps = rates.pop()
    return Observations(views, np.arange(counts.pop()) / fps)


@dataclass
class RayBatch:
    """Rays of one frame from several views: origins, directions (R, 3), target colours (R, 3) in [0, 1] and
    masks (R,)."""

    origins: torch.Tensor
    dirs: torch.Tensor
    colours: torch.Tensor
    masks: torch.Tensor


def sample_rays(obs: Observations, frame: int, rays_per_view: int, rng: np.random.Generator,
                focus_fraction: float = 0.75, dtype=torch.float32) -> RayBatch:
    """``rays_per_view`` random pixels of ``frame`` in every view: most from around the material, the rest from
    anywhere in the image (so that material where none was filmed is seen)."""
    origins, dirs, colours, masks = [], [], [], []
    for view in obs.views:
        focused = round(focus_fraction * rays_per_view)
        pixels = np.r_[rng.choice(view.focus, focused), rng.integers(0, len(view.dirs), rays_per_view - focused)]
        origins.append(np.broadcast_to(view.origin, (len(pixels), 3)))
        dirs.append(view.dirs[pixels])
        colours.append(view.images[frame, pixels])
        masks.append(view.masks[frame, pixels])
    return RayBatch(torch.as_tensor(np.concatenate(origins), dtype=dtype),
                    torch.as_tensor(np.concatenate(dirs), dtype=dtype),
                    torch.as_tensor(np.concatenate(colours) / 255.0, dtype=dtype),
                    torch.as_tensor(np.concatenate(masks), dtype=dtype))
