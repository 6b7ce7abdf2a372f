"""Real recordings into the recordings layout: frames from a video file (mp4, mov, ... through imageio-ffmpeg) or an
image folder, over a frame range, resampled to a frame rate."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}


class IngestError(ValueError):
    """A recording that cannot be read as asked."""


def read_frames(source: str | Path, start: int = 0, stop: int | None = None, fps: float | None = None,
                source_fps: float | None = None) -> tuple[list[np.ndarray], float]:
    """RGB frames ``start`` (inclusive) to ``stop`` (exclusive) of a video file or image folder, keeping every
    frame or, with ``fps``, the frames nearest to a ``fps`` sampling. Returns the frames and their rate."""
    source = Path(source)
    if source.is_dir():
        files = sorted(p for p in source.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise IngestError(f"{source}: no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in this folder")
        rate = source_fps
        if rate is None:
            raise IngestError(f"{source}: an image folder needs source_fps (its frame rate)")
        reader = (imageio.imread(p) for p in files)
        total = len(files)
    elif source.is_file():
        try:
            video = imageio.get_reader(source, "ffmpeg")
            meta = video.get_meta_data()
        except Exception as err:  # imageio raises several types for unreadable files
            raise IngestError(f"{source}: not a readable video ({err})") from err
        rate = source_fps or meta.get("fps")
        total = video.count_frames()
        reader = iter(video)
    else:
        raise IngestError(f"{source}: no such video file or image folder")
    stop = total if stop is None else min(stop, total)
    if not 0 <= start < stop:
        raise IngestError(f"{source}: frame range [{start}, {stop}) is empty or outside the {total} frames")
    keep = list(range(start, stop))
    if fps is not None:
        if fps > rate + 1e-9:
            raise IngestError(f"{source}: requested {fps} fps is above the recording's {rate:g} fps")
        count = math.floor((stop - 1 - start) * fps / rate + 1e-9) + 1
        keep = sorted({start + round(k * rate / fps) for k in range(count)})
        rate = fps
    wanted = set(keep)
    frames = []
    for index, frame in enumerate(reader):
        if index >= stop:
            break
        if index in wanted:
            frame = np.asarray(frame)
            frames.append(frame[..., :3] if frame.ndim == 3 else np.repeat(frame[..., None], 3, axis=2))
    return frames, float(rate)


def write_camera(out_dir: Path, frames: list[np.ndarray], clean_plate: np.ndarray | None) -> None:
    """One camera's frames (and clean plate) in the recordings layout."""
    (out_dir / "frames").mkdir(parents=True, exist_ok=True)
    for k, frame in enumerate(frames):
        cv2.imwrite(str(out_dir / "frames" / f"{k:03d}.png"), frame[..., ::-1])
    if clean_plate is not None:
        if clean_plate.shape[:2] != frames[0].shape[:2]:
            raise IngestError(f"clean plate of size {clean_plate.shape[1]}x{clean_plate.shape[0]} differs from the "
                              f"frames' {frames[0].shape[1]}x{frames[0].shape[0]}")
        cv2.imwrite(str(out_dir / "clean_plate.png"), clean_plate[..., ::-1])
