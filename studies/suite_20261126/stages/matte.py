"""matte: material masks and matted frames (white background) from every camera's frames and clean plate; where the
recordings carry true masks (the virtual lab), the IoU per view."""

from pathlib import Path

import cv2
import numpy as np
from tqdm.auto import tqdm

from rheo.io import write_atomic_dir, write_json_atomic
from rheo.report.figures import mask_overlays, save_figure
from rheo.stage import start_stage
from rheo.vision.matting import MatteSettings, iou, matte

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
settings = MatteSettings(**smk.params.settings)
recordings = Path(smk.input.recordings)
report = {"settings": smk.params.settings, "views": {}}
overlays = []


def write(out: Path) -> None:
    for cam_dir in tqdm(sorted(p for p in recordings.iterdir() if p.is_dir()), desc="matte"):
        plate = cv2.imread(str(cam_dir / "clean_plate.png"))
        if plate is None:
            raise FileNotFoundError(f"{cam_dir / 'clean_plate.png'}: missing or unreadable clean plate")
        ious = []
        frames = sorted((cam_dir / "frames").glob("*.png"))
        for k, frame_path in enumerate(frames):
            frame = cv2.imread(str(frame_path))
            mask = matte(frame[..., ::-1], plate[..., ::-1], settings)
            (out / cam_dir.name / "masks").mkdir(parents=True, exist_ok=True)
            (out / cam_dir.name / "matted").mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(out / cam_dir.name / "masks" / frame_path.name), mask.astype(np.uint8) * 255)
            cv2.imwrite(str(out / cam_dir.name / "matted" / frame_path.name), np.where(mask[..., None], frame, 255))
            truth_path = cam_dir / "masks" / frame_path.name
            if truth_path.is_file():
                ious.append(iou(mask, cv2.imread(str(truth_path), cv2.IMREAD_GRAYSCALE) > 127))
            if k in (0, len(frames) - 1) and len(overlays) < 8:
                overlays.append((f"{cam_dir.name} frame {k}", frame[..., ::-1], mask))
        view = {"frames": len(frames)}
        if ious:
            view.update(mean_iou=float(np.mean(ious)), min_iou=float(np.min(ious)))
            log.info("%s: mean IoU %.4f (min %.4f) over %d frames", cam_dir.name, view["mean_iou"], view["min_iou"],
                     len(frames))
        report["views"][cam_dir.name] = view


write_atomic_dir(smk.output.masks, write)
scored = [v["mean_iou"] for v in report["views"].values() if "mean_iou" in v]
if scored:
    report["mean_iou"] = float(np.mean(scored))
    log.info("mean IoU over all views: %.4f", report["mean_iou"])
write_json_atomic(smk.output.report, report)
save_figure(mask_overlays(overlays), smk.output.figure)
