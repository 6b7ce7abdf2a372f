"""ingest: a real recording (video file or image folder per camera) into the recordings layout, and a contact sheet
of what was taken (first, middle and last frame, and the clean plate) per camera."""

import json
from pathlib import Path

import imageio.v2 as imageio

from rheo.io import write_atomic_dir
from rheo.report.figures import contact_sheet, save_figure
from rheo.stage import start_stage
from rheo.vision.ingest import read_frames, write_camera

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
cameras = smk.params.recording["cameras"]
sheet = {}


def write(out: Path) -> None:
    summary = {}
    for name, cam in cameras.items():
        frames, rate = read_frames(cam["source"], cam["start_frame"], cam["stop_frame"], cam["fps"],
                                   cam["source_fps"])
        plate = imageio.imread(cam["clean_plate"])[..., :3] if cam["clean_plate"] else None
        write_camera(out / name, frames, plate, cam["clean_plate"])
        summary[name] = {"frames": len(frames), "fps": rate, "source": cam["source"]}
        log.info("%s: %d frames at %g fps from %s", name, len(frames), rate, cam["source"])
        picks = sorted({0, len(frames) // 2, len(frames) - 1})
        sheet[name] = [(f"frame {k} (t = {k / rate:.3g} s)", frames[k]) for k in picks]
        if plate is not None:
            sheet[name].append(("clean plate", plate))
    (out / "recording.json").write_text(json.dumps(summary, indent=2))


write_atomic_dir(smk.output.recordings, write)
save_figure(contact_sheet(sheet), smk.output.figure)
