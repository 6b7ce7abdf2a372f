"""Real recordings into the recordings layout: frames from a video file (mp4, mov, ... through imageio-ffmpeg) or an
image folder, over a frame range, resampled to a frame rate."""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}


class IngestError(ValueError):
    """A recording that cannot be read as asked."""


def read_frames(source: str | Path, start: int = 0, stop: int | None = None, fps: float | None = None,
                source_fps: float | None = None) -> tuple[list[np.ndarray], float]:
    """RGB frames ``start`` (inclusive) to ``stop`` (exclusive) of a video file or image folder, keeping every
    frame or, with ``fps``, the frames nearest to a ``fps`` sampling. Returns the frames and their rate. A video
    shorter than its container says, or a ``stop`` beyond the last frame, is logged as a warning."""
    source = Path(source)
    if source.is_dir():
        files = sorted(p for p in source.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise IngestError(f"{source}: no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in this folder")
        rate = source_fps
        if rate is None:
            raise IngestError(f"{source}: an image folder needs source_fps (its frame rate)")
        reader = _folder_frames(files)
        total = len(files)
    elif source.is_file():
        try:
            video = imageio.get_reader(source, "ffmpeg")
            meta = video.get_meta_data()
            total = video.count_frames()
        except Exception as err:  # imageio raises several types for unreadable files
            raise IngestError(f"{source}: not a readable video ({_last_line(err)})") from None
        rate = source_fps or meta.get("fps")
        _warn_if_cut_short(source, total, meta)
        reader = iter(video)
    else:
        raise IngestError(f"{source}: no such video file or image folder")
    if stop is not None and stop > total:
        log.warning("%s: stop_frame %d is beyond its %d frames; ingesting to the last one", source, stop, total)
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
    if len(frames) < len(keep):
        log.warning("%s: %d of the %d frames asked for could be decoded", source, len(frames), len(keep))
    return frames, float(rate)


def _folder_frames(files: list[Path]) -> Iterator[np.ndarray]:
    """The images of a folder in order, all of the first one's size."""
    size = None
    for path in files:
        try:
            image = imageio.imread(path)
        except Exception as err:  # imageio raises several types for unreadable files
            raise IngestError(f"{path}: not a readable image ({_last_line(err)})") from None
        if size is None:
            size = image.shape[:2]
        elif image.shape[:2] != size:
            raise IngestError(f"{path}: {image.shape[1]}x{image.shape[0]} pixels, unlike the folder's first frame "
                              f"{files[0].name} ({size[1]}x{size[0]}); a recording's frames must share one size")
        yield image


def _warn_if_cut_short(source: Path, decoded: int, meta: dict) -> None:
    """Warn when the container's duration promises more frames than can be decoded (a file cut short)."""
    duration, rate = meta.get("duration"), meta.get("fps")
    if not duration or not rate or not math.isfinite(duration * rate):
        return
    promised = round(duration * rate)
    if decoded < promised - 1:
        log.warning("%s: its container says %d frames (%.3g s at %g fps) but only %d can be decoded; the file may "
                    "be cut short", source, promised, duration, rate, decoded)


def _last_line(err: Exception) -> str:
    """The last line of a reader's complaint (ffmpeg's, without its banner)."""
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[-1] if lines else type(err).__name__


def write_camera(out_dir: Path, frames: list[np.ndarray], clean_plate: np.ndarray | None,
                 clean_plate_path: str | None = None) -> None:
    """One camera's frames (and clean plate, read from ``clean_plate_path``) in the recordings layout."""
    (out_dir / "frames").mkdir(parents=True, exist_ok=True)
    for k, frame in enumerate(frames):
        cv2.imwrite(str(out_dir / "frames" / f"{k:03d}.png"), frame[..., ::-1])
    if clean_plate is not None:
        if clean_plate.shape[:2] != frames[0].shape[:2]:
            raise IngestError(f"{clean_plate_path or 'clean plate'}: {clean_plate.shape[1]}x{clean_plate.shape[0]} "
                              f"pixels, unlike the frames' {frames[0].shape[1]}x{frames[0].shape[0]}")
        cv2.imwrite(str(out_dir / "clean_plate.png"), clean_plate[..., ::-1])
