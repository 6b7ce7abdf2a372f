"""calibrate: per camera, intrinsics and distortion from its checkerboard images; then the poses of all cameras that
see the same board lying on the floor, adjusted together with the board's corners; writes cameras.json (world frame:
y up, floor at y = 0) and a figure of the frusta."""

import glob
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np

from rheo.io import read_json, write_json_atomic
from rheo.report.figures import camera_frusta, save_figure
from rheo.stage import start_stage
from rheo.vision.calibration import (
    Board,
    adjust_ground_views,
    calibrate_intrinsics,
    camera_record,
    locate_ground_board,
    pose_errors,
    pose_sigma,
    read_gray,
    world_pose,
)
from rheo.vision.cameras import Camera
from rheo.vision.matting import iou
from rheo.vision.silhouette import refine_pose, silhouette_mask

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
cfg = smk.params.calibration
board = Board(**cfg["board"])
intrinsics, views, boards = {}, {}, defaultdict(list)
for name, cam in cfg["cameras"].items():
    intr = calibrate_intrinsics(sorted(glob.glob(cam["images"])), board, fix_aspect_ratio=cfg["fix_aspect_ratio"],
                                min_views=cfg["min_views"], camera=f"camera {name}")
    log.info("camera %s: fx=%.2f fy=%.2f cx=%.2f cy=%.2f, RMS %.3f px over %d images (%d skipped)", name,
             intr.K[0, 0], intr.K[1, 1], intr.K[0, 2], intr.K[1, 2], intr.rms_px, len(intr.per_view_rms_px),
             len(intr.skipped))
    intrinsics[name] = intr
    views[name] = locate_ground_board(read_gray(cam["ground_image"]), board, intr.K, intr.dist, cam["ground_image"])
    boards[tuple(cam["ground_origin"])].append(name)

cameras, ground_boards = {}, []
for origin, names in boards.items():  # cameras that see the same board are adjusted together
    adjusted = adjust_ground_views([views[n] for n in names], board, tolerance=cfg["board_tolerance"])
    log.info("ground board at %s: %d cameras adjusted together, pixel noise %.3f px", list(origin), len(names),
             adjusted.pixel_sigma)
    ground_boards.append({"origin": list(origin), "cameras": names, "pixel_sigma": adjusted.pixel_sigma,
                          "corners_board_frame": adjusted.board_points.tolist()})
    for name, view, covariance, rms in zip(names, adjusted.views, adjusted.covariances, adjusted.rms_px,
                                           strict=True):
        c2w, sigma = world_pose(view, origin), pose_sigma(view, covariance)
        log.info("camera %s: ground-board RMS %.3f px, 1 sigma %.3f deg and %.2g m, centre at %s m", name, rms,
                 sigma["rotation_deg"], sigma["center_m"], c2w[:3, 3].round(4).tolist())
        cameras[name] = camera_record(intrinsics[name], c2w, rms, sigma)

if cfg["silhouette_refinement"]:
    proxy = np.load(smk.input.proxy)
    points, spacing = proxy["positions"], float(proxy["spacing"])
    for name, record in cameras.items():
        # the proxy's silhouette against the material's mask in this camera's first frame
        mask = cv2.imread(str(Path(smk.input.matte) / name / "masks" / "000.png"), cv2.IMREAD_GRAYSCALE) > 127
        camera = Camera.from_record(record)
        before = iou(silhouette_mask(camera, points, spacing), mask)
        board_pose = camera.c2w
        refined, info = refine_pose(camera, points, spacing, mask)
        moved = float(np.linalg.norm(refined[:3, 3] - board_pose[:3, 3]))
        camera.c2w = refined
        after = iou(silhouette_mask(camera, points, spacing), mask)
        if after < before:  # the board's pose already agrees better with the mask: keep it
            refined, after = board_pose, before
        log.info("camera %s: silhouette refinement moved the pose by %.4f m, IoU %.3f -> %.3f%s", name, moved, before,
                 after, "" if refined is not board_pose else " (no better: the board's pose is kept)")
        record.update(c2w=refined.tolist(), silhouette_iou_before=before, silhouette_iou_after=after,
                      silhouette_fit=info)

result = {"world": "y up, floor at y = 0, metres; camera axes OpenCV", "board": cfg["board"],
          "ground_boards": ground_boards, "cameras": cameras}
if hasattr(smk.input, "truth"):  # the virtual lab: errors against the cameras that rendered the recordings
    truth = read_json(smk.input.truth)
    b = truth["board"]
    board_centre = np.add(b["ground_origin"], [0.5 * (b["columns"] - 1) * b["square"], 0.0,
                                               0.5 * (b["rows"] - 1) * b["square"]])
    for name, record in cameras.items():
        record["errors_vs_truth"] = pose_errors(record, truth["cameras"][name], look_at=board_centre)
    result["worst_errors_vs_truth"] = {key: max(abs(r["errors_vs_truth"][key]) for r in cameras.values())
                                       for key in next(iter(cameras.values()))["errors_vs_truth"]}
    log.info("worst over %d cameras against the truth (relative, degrees): %s", len(cameras),
             {k: round(v, 5) for k, v in result["worst_errors_vs_truth"].items()})
write_json_atomic(smk.output.cameras, result)
floor_points = board.object_points()[:, [0, 2, 1]]  # a ground board's corners on the floor, (x, 0, z)
save_figure(camera_frusta(cameras, np.concatenate([floor_points + b["origin"] for b in ground_boards]),
                          "cameras and the ground board"), smk.output.figure)
