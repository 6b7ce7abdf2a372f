"""calibrate: per camera, intrinsics and distortion from its checkerboard images and its pose from the image of the
board lying on the floor; writes cameras.json (world frame: y up, floor at y = 0) and a figure of the frusta."""

import glob
from pathlib import Path

import cv2
import numpy as np

from rheo.io import write_json_atomic
from rheo.report.figures import camera_frusta, save_figure
from rheo.stage import setup_logging
from rheo.vision.calibration import Board, calibrate_intrinsics, camera_record, ground_pose, read_gray
from rheo.vision.cameras import Camera
from rheo.vision.matting import iou
from rheo.vision.silhouette import refine_pose, silhouette_mask

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = setup_logging(smk.log[0])
cfg = smk.params.calibration
board = Board(**cfg["board"])
cameras = {}
for name, cam in cfg["cameras"].items():
    images = sorted(glob.glob(cam["images"]))
    intr = calibrate_intrinsics(images, board, fix_aspect_ratio=cfg["fix_aspect_ratio"], min_views=cfg["min_views"])
    c2w, pose_rms, sigma = ground_pose(read_gray(cam["ground_image"]), board, intr.K, intr.dist,
                                       origin=cam["ground_origin"], source=cam["ground_image"])
    log.info("camera %s: fx=%.2f fy=%.2f cx=%.2f cy=%.2f, RMS %.3f px over %d images (%d skipped), ground-board "
             "RMS %.3f px (1 sigma: %.3f deg, %.2g m), centre at %s m", name, intr.K[0, 0], intr.K[1, 1],
             intr.K[0, 2], intr.K[1, 2],
             intr.rms_px, len(intr.per_view_rms_px), len(intr.skipped), pose_rms, sigma["rotation_deg"],
             sigma["center_m"], c2w[:3, 3].round(4).tolist())
    cameras[name] = camera_record(intr, c2w, pose_rms, sigma)
    if cfg["silhouette_refinement"]:
        # the proxy's silhouette against the material's mask in this camera's first frame
        proxy = np.load(smk.input.proxy)
        mask = cv2.imread(str(Path(smk.input.matte) / name / "masks" / "000.png"), cv2.IMREAD_GRAYSCALE) > 127
        camera = Camera(intr.width, intr.height, intr.K, intr.dist, c2w)
        points, spacing = proxy["positions"], float(proxy["spacing"])
        before = iou(silhouette_mask(camera, points, spacing), mask)
        refined, info = refine_pose(camera, points, spacing, mask)
        camera.c2w = refined
        after = iou(silhouette_mask(camera, points, spacing), mask)
        log.info("camera %s: silhouette refinement moved the pose by %.4f m, IoU %.3f -> %.3f", name,
                 float(np.linalg.norm(refined[:3, 3] - c2w[:3, 3])), before, after)
        cameras[name].update(c2w=refined.tolist(), silhouette_iou_before=before, silhouette_iou_after=after,
                             silhouette_fit=info)
write_json_atomic(smk.output.cameras, {"world": "y up, floor at y = 0, metres; camera axes OpenCV",
                                       "board": cfg["board"], "cameras": cameras})
corners = board.object_points()
floor_points = corners[:, [0, 2, 1]]  # the ground board's corners on the floor, (x, 0, z)
save_figure(camera_frusta(cameras, floor_points + cfg["cameras"][next(iter(cameras))]["ground_origin"],
                          "cameras and the ground board"), smk.output.figure)
