"""Atomic writes: a writer killed half-way leaves a hidden temporary that the next write of the same path removes,
while a temporary of a writer still running is left alone."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from rheo.io import write_atomic_dir, write_json_atomic

ROOT = Path(__file__).resolve().parents[1]

KILLED_WRITER = """
import sys, time
from pathlib import Path
from rheo.io import write_atomic_dir

def write(tmp: Path) -> None:
    (tmp / "half.txt").write_text("half")
    print("writing", flush=True)
    time.sleep(60)

write_atomic_dir(sys.argv[1], write)
"""


def test_a_killed_writers_temporary_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "recordings"
    writer = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(target)], stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert writer.stdout.readline().strip() == "writing"
    left = [p.name for p in tmp_path.iterdir()]
    writer.send_signal(signal.SIGKILL)
    writer.wait()
    assert len(left) == 1 and left[0].startswith(".recordings.") and not target.exists()

    alive = tmp_path / f".recordings.{os.getpid()}.running"  # a writer that still runs: this process
    alive.mkdir()
    write_atomic_dir(target, lambda tmp: (tmp / "whole.txt").write_text("whole"))
    assert sorted(p.name for p in tmp_path.iterdir()) == [alive.name, "recordings"]
    assert [p.name for p in target.iterdir()] == ["whole.txt"]


def test_a_file_is_replaced_whole_and_no_temporary_remains(tmp_path):
    path = tmp_path / "params.json"
    write_json_atomic(path, {"a": 1})
    stale = tmp_path / ".params.json.999999999.x.json"  # no process has this id
    stale.write_text("{")
    time.sleep(0.01)
    write_json_atomic(path, {"a": 2})
    assert path.read_text().strip().endswith("}") and sorted(p.name for p in tmp_path.iterdir()) == ["params.json"]
