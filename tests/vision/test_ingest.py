"""Ingest: frames from a video the test encodes itself, and from an image folder."""

import imageio.v2 as imageio
import numpy as np
import pytest

from rheo.vision.ingest import IngestError, read_frames


def _frame(k: int) -> np.ndarray:
    """A frame whose bright bar sits at a column that encodes the frame index."""
    image = np.full((64, 96, 3), 40, np.uint8)
    image[:, 4 * k:4 * k + 4] = 230
    return image


def test_video_frame_range_and_rate(tmp_path):
    path = tmp_path / "clip.mp4"
    imageio.mimwrite(path, [_frame(k) for k in range(20)], fps=30, macro_block_size=1, quality=10)
    frames, rate = read_frames(path, start=4, stop=16, fps=10)
    assert rate == 10 and len(frames) == 4
    for frame, k in zip(frames, [4, 7, 10, 13], strict=True):
        column = int(np.argmax(frame[32, :, 0].astype(int)))
        assert abs(column - (4 * k + 1.5)) <= 2.5  # the bar of source frame k
    all_frames, rate = read_frames(path)
    assert len(all_frames) == 20 and rate == pytest.approx(30)


def test_image_folder_and_errors(tmp_path):
    folder = tmp_path / "shots"
    folder.mkdir()
    for k in range(6):
        imageio.imwrite(folder / f"{k:02d}.png", _frame(k))
    frames, rate = read_frames(folder, start=1, stop=5, source_fps=60)
    assert len(frames) == 4 and rate == 60 and np.array_equal(frames[0], _frame(1))
    with pytest.raises(IngestError, match="needs source_fps"):
        read_frames(folder)
    with pytest.raises(IngestError, match=r"frame range \[7, 6\) is empty or outside the 6 frames"):
        read_frames(folder, start=7, source_fps=60)
    with pytest.raises(IngestError, match="no such video file or image folder"):
        read_frames(tmp_path / "missing.mp4")
    (tmp_path / "broken.mp4").write_bytes(b"not a video")
    with pytest.raises(IngestError, match=r"broken\.mp4: not a readable video"):
        read_frames(tmp_path / "broken.mp4")
    with pytest.raises(IngestError, match="requested 120 fps is above"):
        read_frames(folder, fps=120, source_fps=60)
