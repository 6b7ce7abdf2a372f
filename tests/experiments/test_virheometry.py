"""The ViRheometry importer: the OpenGL camera against its definition, every real setup read and its camera checked
by projecting the initial cuboid onto the first silhouette, and clear errors for broken folders."""

import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from rheo.experiments.virheometry import Setup, SetupError, cuboid_overlap, opengl_camera, read_setup, setup_folders
from rheo.report.fit import interval_text

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "virheometry"
SETUPS = sorted(DATA.glob("ref_*"))


def _rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis]


def test_opengl_camera_looks_along_minus_z_with_y_up_and_the_vertical_field_of_view():
    eye = np.array([0.1, 0.2, 0.3])
    q = _rotation([1.0, 0.0, 0.0], -0.4)  # pitched down by 0.4 rad: looks along (0, -sin 0.4, -cos 0.4)
    camera = opengl_camera(eye, q, 30.0, 320, 240)
    forward = np.array([0.0, -np.sin(0.4), -np.cos(0.4)])
    up = np.array([0.0, np.cos(0.4), -np.sin(0.4)])
    uv, depth = camera.project(np.array([eye + 2.0 * forward]))
    assert uv[0] == pytest.approx([159.5, 119.5]) and depth[0] == pytest.approx(2.0)
    # a point 15 degrees above the axis (half the vertical field of view) lies on the top edge of the image
    top = eye + forward + np.tan(np.radians(15.0)) * up
    assert camera.project(top[None])[0][0] == pytest.approx([159.5, -0.5])
    # world +x is to the right in the image when the camera looks along -z
    assert camera.project((eye + 2.0 * forward + [0.1, 0, 0])[None])[0][0, 0] > 159.5


def test_every_published_setup_reads_and_its_camera_puts_the_cuboid_on_the_first_silhouette():
    assert len(SETUPS) == 24
    for folder in SETUPS:
        setup = read_setup(folder, scale=0.5)
        name = folder.name.split("_")
        assert setup.material == name[1] and setup.index == int(name[4])
        assert (setup.height, setup.width) == pytest.approx((float(name[2]) / 100, float(name[3]) / 100))
        assert 0.039 <= setup.depth <= 0.042 and 1000.0 <= setup.density <= 1250.0
        assert (setup.camera.width, setup.camera.height) == (480, 270) and len(setup.masks) == 8
        overlap = cuboid_overlap(setup)
        # frame 1 is taken when the gate is half open: the material has begun to leave the cuboid, which stays
        # covered
        assert overlap["cuboid_on_silhouette"] > 0.92, folder.name
        assert overlap["iou"] > 0.7, folder.name


def test_a_setup_survives_its_record():
    setup = read_setup(SETUPS[0], scale=0.25)
    again = Setup.from_record(json.loads(json.dumps(setup.record())), np.stack(setup.masks))
    assert again.record() == setup.record() and np.array_equal(np.stack(again.masks), np.stack(setup.masks))


def test_published_defects_are_repaired_and_said(caplog):
    sesame = read_setup(DATA / "ref_Sesame_2.0_2.9_2", scale=0.25)  # its <setup> swaps H and W
    assert (sesame.height, sesame.width) == pytest.approx((0.020, 0.029))
    sauce = read_setup(DATA / "ref_JapaneseThickenedWorcestershireSauce_2.0_3.0_2", scale=0.25)  # no root tag
    assert sauce.camera.c2w[:3, 3] == pytest.approx([0.0745150626, 0.1358546276, 0.2592631598])
    assert "disagrees with the cuboid" in caplog.text and "not valid XML" in caplog.text


@pytest.fixture
def setup_copy(tmp_path):
    return Path(shutil.copytree(DATA / "ref_Lotion_2.5_5.1_1", tmp_path / "ref_Lotion_2.5_5.1_1"))


@pytest.mark.parametrize("breakage, message", [
    (lambda d: (d / "settings.xml").unlink(), "settings.xml: missing"),
    (lambda d: (d / "settings.xml").write_text("<Optimizer><setup RHO='1.0'"), "settings.xml: not valid XML"),
    (lambda d: (d / "camera_params.xml").write_text("<setup3D><camera fov='36'/></setup3D>"),
     "camera_params.xml: no <camera eyepos"),
    (lambda d: (d / "config_03.png").unlink(), "config_03.png missing"),
    (lambda d: (d / "config_08.png").unlink(), "config_08.png missing"),
    (lambda d: cv2.imwrite(str(d / "config_04.png"), np.zeros((540, 960), np.uint8)),
     "config_04.png: the silhouette covers 100 % of the image"),
    (lambda d: (d / "settings.xml").write_text(re.sub(r'RHO="[^"]*"', 'RHO="-1"', (d / "settings.xml").read_text())),
     "settings.xml: <setup RHO=-1> is a density of -1000 kg/m^3"),
    (lambda d: (d / "config_02.png").write_bytes(b"not a png"), "config_02.png: not a readable image"),
    (lambda d: (d / "settings.xml").write_text((d / "settings.xml").read_text().replace("sticking", "glued", 1)),
     "boundary_behavior 'glued' unknown"),
])
def test_a_broken_folder_gives_one_clear_error_naming_the_file(setup_copy, breakage, message):
    breakage(setup_copy)
    with pytest.raises(SetupError, match=re.escape(message)):
        read_setup(setup_copy, scale=0.25)


def test_a_folder_not_named_like_a_setup_is_refused(tmp_path):
    with pytest.raises(SetupError, match="not a setup folder"):
        read_setup(tmp_path, scale=0.5)


def test_setup_folders_come_in_the_order_of_their_index(tmp_path):
    for name in ("ref_Paste_2_5_10", "ref_Paste_7_5_2", "ref_Paste_2_5_1", "ref_Paste_x_y_z", "ref_Pastel_2_5_3"):
        (tmp_path / name).mkdir()
    assert [p.name for p in setup_folders(tmp_path, "Paste")] == [
        "ref_Paste_2_5_1", "ref_Paste_7_5_2", "ref_Paste_2_5_10", "ref_Paste_x_y_z"]


def test_an_open_end_of_an_interval_is_marked():
    assert interval_text({"interval": [2.5, 8.0]}) == "[2.5, 8]"
    assert interval_text({"interval": [2.5, 8.0], "interval_open": [True, False]}) == "[<2.5, 8]"
    assert interval_text({"interval": [2.5, 8.0], "interval_open": [False, True]}) == "[2.5, >8]"
