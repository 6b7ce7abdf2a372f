"""Hostile and clumsy input through Snakemake: every bad file or value is one clear sentence naming the file and the
key (or a warning with both counts), before anything long runs; one bad experiment breaks only its own targets; a
second run on the same folder is refused by the lock."""

import re
import shutil
import subprocess
import time

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
import warp as wp
import yaml

BAD = "config/experiments/bad.yaml"


def _tiny(workflow) -> dict:
    return yaml.safe_load((workflow.root / "config/experiments/tiny.yaml").read_text())


def _set(exp: dict, key: str, value) -> dict:
    *sections, last = key.split(".")
    node = exp
    for section in sections:
        node = node.setdefault(section, {})
    node[last] = value
    return exp


def _output(run: subprocess.CompletedProcess) -> str:
    return run.stdout + run.stderr


def _refused(run: subprocess.CompletedProcess, *parts: str) -> str:
    """The output of a run that failed with one message holding every part, without a schema dump or a banner."""
    out = _output(run)
    assert run.returncode != 0, out[-2000:]
    assert all(part in out for part in parts), out[-3000:]
    assert "Failed validating" not in out and "ffmpeg version" not in out and "Traceback (most recent" not in out
    return out


# (experiment key, value as written in YAML, what the message says after the file's name)
BAD_VALUES = [
    ("material.tau_y", ".nan", "material.tau_y: nan is not a finite number"),
    ("material.density", ".inf", "material.density: inf is not a finite number"),
    ("simulation.domain_size", "-.inf", "simulation.domain_size: -inf is not a finite number"),
    ("simulation.gravity", "[0, .nan, 0]", "simulation.gravity[1]: nan is not a finite number"),
    ("proxy.spacing", ".nan", "proxy.spacing: nan is not a finite number"),
    ("fit.tolerance", ".nan", "fit.tolerance: nan is not a finite number"),
    ("fit.warmup.box", ".inf", "fit.warmup.box: inf is not a finite number"),
    ("fit.initial_guess.tau_y", ".nan", "fit.initial_guess.tau_y: nan is not a finite number"),
    ("material.density", "1.0", "material.density (density (kg/m^3): foams to metal pastes): 1.0 must be at least 50"),
    ("material.lam", "-5000", "material.lam (Lame lambda (Pa)): -5000 must be at least 0"),
    ("simulation.duration", ".nan", "simulation.duration: nan is not a finite number"),
    ("proxy.position", "[.nan, 0, 0.5]", "proxy.position[0]: nan is not a finite number"),
    ("simulation.resolution", "300", "simulation.resolution (grid cells per axis for the fit): 300 must be at most"),
    ("simulation.substeps", "1e8", "simulation.substeps: 100000000 must be at most 100000"),
    ("simulation.frames", "1e7", "simulation.frames (frames recorded over the duration (first frame at t = 0)): "
                                 "10000000 must be at most 10000"),
    ("cameras.width", "1e7", "cameras.width (image width (px)): 10000000 must be at most 8192"),
    ("proxy.shape", "pyramid", "proxy.shape (primitive or mesh): 'pyramid' is not one of truncated_cone, spheroid"),
    ("cameras.widht", "640", "cameras (virtual-lab cameras on a hemisphere looking at the object): 'widht' (did you "
                             "mean 'width'?) is not a key here"),
]


@pytest.mark.parametrize("key, written, message", BAD_VALUES, ids=[row[0] for row in BAD_VALUES])
def test_a_bad_experiment_value_is_named_before_the_run(workflow, key, written, message):
    exp = _set(_tiny(workflow), key, "PLACEHOLDER")
    exp["name"] = "bad"
    (workflow.root / BAD).write_text(yaml.safe_dump(exp).replace("PLACEHOLDER", written))
    _refused(workflow.run("-n", "results/bad/fit/params.json"), f"{BAD}: {message}")


@pytest.mark.parametrize("content, message", [
    ("name: bad\nkind: virtual\n  x: [1,\n", "not valid YAML (line 3, column 4): mapping values are not allowed"),
    ("- name: bad\n- kind: virtual\n", "expected a mapping of keys (key: value lines), found list"),
    ("name: bad\nkind: virtual\nkind: real\n", "line 3: the key 'kind' is given twice"),
], ids=["syntax", "list", "duplicate"])
def test_a_broken_experiment_file_breaks_only_its_own_targets(workflow, content, message):
    (workflow.root / BAD).write_text(content)
    _refused(workflow.run("-n", "results/bad/recordings"), f"{BAD}: {message}")
    other = workflow.run("-n", "results/tiny/fit/params.json")
    assert other.returncode == 0, _output(other)[-2000:]


def test_an_estimate_over_the_limits_is_refused_with_how_to_raise_them(workflow):
    exp = _set(_set(_tiny(workflow), "simulation.resolution", 200), "simulation.substeps", 2000)
    (workflow.root / BAD).write_text(yaml.safe_dump({**exp, "name": "bad"}))
    _refused(workflow.run("-n", "results/bad/recordings"), f"{BAD}: would take about",
             "above the limit of 24 h", "--config 'limits={hours:")
    _refused(workflow.run("-n", "results/tiny/recordings", "--config", "limits={memory_gb: 0.001}"),
             "config/experiments/tiny.yaml: would need about", "above the limit of 0.001 GB")


@pytest.mark.parametrize("override, message", [
    ("virheometry={scale: .nan}", "virheometry.scale: '.nan' is not a number"),
    ("virheometry={scale: 1e-6}", "virheometry.scale: 1e-06 must be at least 0.1"),
    ("limits={hours: -1}", "limits.hours (total time on the CPU (h)): -1.0 must be above 0"),
    ("simulation={device: gpu}", "simulation.device: 'gpu' is not one of auto, cpu, cuda"),
])
def test_a_bad_workflow_setting_is_named(workflow, override, message):
    _refused(workflow.run("-n", "results/tiny/recordings", "--config", override),
             f"config/config.yaml (with --config): {message}")


@pytest.mark.skipif(wp.get_cuda_device_count() > 0, reason="this machine has a CUDA GPU")
def test_a_gpu_asked_for_where_there_is_none_is_one_sentence(workflow):
    _refused(workflow.run("results/tiny/recordings", "--config", "simulation={device: cuda}"),
             "simulation.device is cuda, but Warp sees no CUDA GPU on this machine")


def test_a_duplicate_key_in_the_workflow_config_is_named(workflow):
    path = workflow.root / "config/config.yaml"
    path.write_text(path.read_text() + "\nvirheometry: {}\n")
    _refused(workflow.run("-n", "results/tiny/recordings"), "config/config.yaml: line",
             "the key 'virheometry' is given twice")


def _video(path, frames: int = 60, faststart: bool = True) -> None:
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 255, (64, 80, 3), dtype=np.uint8) for _ in range(frames)]
    options = ["-movflags", "+faststart"] if faststart else None
    imageio.mimwrite(path, images, fps=24, macro_block_size=1, output_params=options)


def _recording(workflow, source, **camera) -> None:
    exp = {"name": "clip", "kind": "real", "recording": {"cameras": {"phone": {"source": str(source), **camera}}}}
    (workflow.root / "config/experiments/clip.yaml").write_text(yaml.safe_dump(exp))


def test_a_video_cut_short_and_a_stop_frame_past_its_end_are_warned_with_both_counts(workflow, tmp_path):
    whole = tmp_path / "whole.mp4"
    _video(whole)
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    _recording(workflow, cut, stop_frame=1000)
    run = workflow.run("results/clip/recordings")
    out = _output(run)
    assert run.returncode == 0, out[-3000:]
    decoded = int(out.split("but only ")[1].split()[0])
    assert 10 < decoded < 60
    assert f"{cut}: its container says 60 frames (2.5 s at 24 fps) but only {decoded} can be decoded" in out
    assert f"{cut}: stop_frame 1000 is beyond its {decoded} frames" in out
    assert "WARNING" in (workflow.root / "logs/clip/ingest.log").read_text()


def test_an_unreadable_video_is_one_sentence_without_ffmpegs_banner(workflow, tmp_path):
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"not a video" * 100)
    _recording(workflow, broken)
    out = _refused(workflow.run("results/clip/recordings"), f"{broken}: not a readable video (")
    assert not (workflow.root / "results/clip/recordings").exists()
    assert "Traceback" in (workflow.root / "logs/clip/ingest.log").read_text()  # kept for a bug report
    assert out.count("not a readable video") <= 2  # the sentence, and at most its echo in the log's tail


def test_an_image_folder_of_mixed_sizes_names_the_odd_file_at_ingest(workflow, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(4):
        cv2.imwrite(str(folder / f"{k:02d}.png"), np.zeros((48 if k != 2 else 50, 64, 3), np.uint8))
    _recording(workflow, folder, source_fps=24)
    _refused(workflow.run("results/clip/recordings"),
             f"{folder}/02.png: 64x50 pixels, unlike the folder's first frame 00.png (64x48)")


def _calibration(workflow, images: str, ground: str) -> None:
    exp = {"name": "calib", "kind": "real",
           "calibration": {"board": {"columns": 9, "rows": 6, "square": 0.025},
                           "cameras": {"left": {"images": images, "ground_image": ground}}}}
    (workflow.root / "config/experiments/calib.yaml").write_text(yaml.safe_dump(exp))


def test_a_checkerboard_pattern_that_matches_nothing_is_named(workflow, tmp_path):
    ground = tmp_path / "ground.png"
    cv2.imwrite(str(ground), np.full((48, 64), 127, np.uint8))
    _calibration(workflow, str(tmp_path / "board_*.jpg"), str(ground))
    _refused(workflow.run("-n", "results/calib/calibration/cameras.json"),
             f"config/experiments/calib.yaml: calibration.cameras.left.images: the pattern '{tmp_path}/board_*.jpg' "
             "matches no file")


def test_photos_without_a_board_name_the_camera(workflow, tmp_path):
    for k in range(3):
        cv2.imwrite(str(tmp_path / f"board_{k}.png"), np.full((48, 64), 127, np.uint8))
    _calibration(workflow, str(tmp_path / "board_*.png"), str(tmp_path / "board_0.png"))
    _refused(workflow.run("results/calib/calibration/cameras.json"),
             "camera left: only 0 of 3 images", "show the 9x6 board (inner corners); at least 3 are needed")


SETUP = "ref_Lotion_2.5_5.1_1"


@pytest.mark.parametrize("breakage, message", [
    (lambda d: (d / "settings.xml").write_text(re.sub(r'RHO="[^"]*"', 'RHO="-1"', (d / "settings.xml").read_text())),
     "settings.xml: <setup RHO=-1> is a density of -1000 kg/m^3"),
    (lambda d: cv2.imwrite(str(d / "config_05.png"), np.zeros((1080, 1920), np.uint8)),
     "config_05.png: the silhouette covers 100 % of the image"),
    (lambda d: (d / "config_08.png").unlink(), "config_08.png missing"),
], ids=["density", "black silhouette", "last frame"])
def test_a_broken_virheometry_folder_is_named_at_import(workflow, tmp_path, breakage, message):
    data = tmp_path / "virheometry"
    shutil.copytree(workflow.root.parent / "shared/data/virheometry" / SETUP, data / SETUP)
    breakage(data / SETUP)
    target = f"results/virheometry/setups/{SETUP}/setup.json"
    _refused(workflow.run(target, "--config", f"virheometry={{data: {data}}}"), f"{data / SETUP}", message)
    assert not (workflow.root / target).exists()


def test_a_second_run_on_the_same_folder_is_refused_by_the_lock(workflow):
    # the first run goes on to the fit (tens of seconds), so it still holds its lock when the second one, asking for
    # the same fit, starts (a second run with nothing left to do would not look at the lock)
    target = "results/tiny/fit/params.json"
    first = workflow.start(target)
    try:
        locks = workflow.root / ".snakemake/locks"
        deadline = time.monotonic() + 60
        while not (locks.is_dir() and any(locks.iterdir())) and time.monotonic() < deadline:
            time.sleep(0.2)
        second = workflow.run(target)
        assert second.returncode != 0 and "cannot be locked" in _output(second)
    finally:
        workflow.kill(first)


def test_a_synthesize_killed_half_way_leaves_no_hidden_folder_after_the_next_run(workflow):
    results = workflow.root / "results/tiny"
    job = workflow.start("results/tiny/recordings")
    deadline = time.monotonic() + 120
    while not list(results.glob(".recordings.*")) and time.monotonic() < deadline and job.poll() is None:
        time.sleep(0.1)
    workflow.kill(job)
    assert list(results.glob(".recordings.*")) and not (results / "recordings").exists()
    workflow.run("--unlock")
    run = workflow.run("results/tiny/recordings", "--rerun-incomplete")
    assert run.returncode == 0, _output(run)[-2000:]
    assert (results / "recordings/recording.json").is_file() and not list(results.glob(".recordings.*"))
