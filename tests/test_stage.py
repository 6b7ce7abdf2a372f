"""The key under which a stage's stored evaluations are resumed."""

import os
import shutil

import pytest

from rheo.stage import inputs_key

SETTINGS = {"tolerance": 0.08, "grid": [12, 14]}


def _tree(root, masks: bytes = b"\x00\x01" * 64) -> None:
    (root / "setups" / "a").mkdir(parents=True)
    (root / "setups" / "a" / "setup.json").write_text('{"height": 0.02}')
    (root / "setups" / "a" / "masks.npz").write_bytes(masks)


def _key(root, settings=SETTINGS) -> str:
    """The key as a stage computes it: paths relative to the run's folder."""
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(root)
        return inputs_key(settings, ["setups/a/setup.json", "setups"])


def test_key_survives_a_copy_with_new_times(tmp_path):
    _tree(tmp_path / "run")
    shutil.copytree(tmp_path / "run", tmp_path / "copy", copy_function=shutil.copyfile)  # times not copied
    os.utime(tmp_path / "copy" / "setups" / "a" / "masks.npz", ns=(1, 1))
    assert _key(tmp_path / "run") == _key(tmp_path / "copy")


def test_key_changes_with_content_or_settings(tmp_path):
    _tree(tmp_path / "run")
    _tree(tmp_path / "other", masks=b"\x00\x01" * 63 + b"\x00\x00")
    before = _key(tmp_path / "run")
    assert before != _key(tmp_path / "other")
    assert before != _key(tmp_path / "run", {**SETTINGS, "tolerance": 0.1})
    (tmp_path / "run" / "setups" / "a" / "extra.json").write_text("{}")  # a new file under a folder input
    assert _key(tmp_path / "run") != before
