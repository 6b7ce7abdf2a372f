"""Atomic writes (a file appears complete under its final name or not at all), JSON, file fingerprints and the
file where a stage stores its evaluations."""

from __future__ import annotations

import glob
import hashlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

_EVALUATIONS_SUFFIX = ".evaluations.json"  # a stage's stored evaluations, beside its .json output


def _temporary_prefix(path: Path) -> str:
    return f".{path.name}.{os.getpid()}."


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)  # a signal that checks the process exists (PermissionError: it does, another user's)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


def remove_stale_temporaries(path: Path) -> None:
    """Remove the temporaries beside ``path`` that a killed writer left (their process no longer runs)."""
    if not path.parent.is_dir():
        return
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.*"):
        pid = tmp.name[len(path.name) + 2 :].split(".", 1)[0]
        if not pid.isdigit() or _running(int(pid)):
            continue
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            tmp.unlink(missing_ok=True)


def write_atomic(path: str | os.PathLike, write: Callable[[Path], None]) -> None:
    """Call ``write`` on a temporary path beside ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(prefix=_temporary_prefix(path), suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json_atomic(path: str | os.PathLike, data) -> None:
    write_atomic(path, lambda p: p.write_text(json.dumps(data, indent=2) + "\n"))


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    write_atomic(path, lambda p: p.write_text(text))


def json_number(value: float) -> float | None:
    """``value`` for a JSON file: null where it is NaN (a loss over no frame)."""
    return None if math.isnan(value) else value


def read_json(path: str | os.PathLike):
    with open(path) as f:
        return json.load(f)


def write_atomic_dir(path: str | os.PathLike, write: Callable[[Path], None]) -> None:
    """Fill a temporary folder beside ``path`` with ``write``, then move it into place (replacing ``path``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    tmp = Path(tempfile.mkdtemp(prefix=_temporary_prefix(path), dir=path.parent))
    try:
        write(tmp)
        if path.exists():
            shutil.rmtree(path)
        os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def file_sha256(path: str | os.PathLike) -> str:
    """The sha256 of a file's bytes (hex)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def evaluations_path(output: str | os.PathLike) -> Path:
    """The file beside ``output`` where the stage that makes it stores its evaluations (to resume from)."""
    return Path(output).with_suffix(_EVALUATIONS_SUFFIX)


def evaluated_output(store: str) -> str | None:
    """The output whose stage stores its evaluations in the file ``store`` (the inverse of ``evaluations_path``);
    None where ``store`` is not such a file."""
    return store.removesuffix(_EVALUATIONS_SUFFIX) + ".json" if store.endswith(_EVALUATIONS_SUFFIX) else None
