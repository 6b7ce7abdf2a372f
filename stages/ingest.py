"""ingest: a real recording (video file or image folder per camera) into the recordings layout."""

import json
from pathlib import Path

import imageio.v2 as imageio

from rheo.io import write_atomic_dir
from rheo.stage import setup_logging
from rheo.vision.ingest import read_frames, write_camera

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
cameras = smk.params.recording["cameras"]


def write(out: Path) -> None:
    summary = {}
    for name, cam in cameras.items():
        frames, rate = read_frames(cam["source"], cam["start_frame"], cam["stop_frame"], cam["fps"],
                                   cam["source_fps"])
        plate = imageio.imread(cam["clean_plate"])[..., :3] if cam["clean_plate"] else None
        write_camera(out / name, frames, plate)
        summary[name] = {"frames": len(frames), "fps": rate, "source": cam["source"]}
        log.info("%s: %d frames at %g fps from %s", name, len(frames), rate, cam["source"])
    (out / "recording.json").write_text(json.dumps(summary, indent=2))


write_atomic_dir(smk.output.recordings, write)
