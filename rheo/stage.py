"""Helpers for the thin stage scripts: logging into the Snakemake log file."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import subprocess
import sys
import traceback
from pathlib import Path

import rheo
from rheo.io import file_sha256
from rheo.physics.device import set_default_device


def setup_logging(log_file: str | Path | None) -> logging.Logger:
    """Log INFO and above to ``log_file`` (if given) and to stderr; return the stage's logger. An error of rheo's
    own (bad input, an unstable simulation) ends the stage with its one sentence, the traceback going to the log
    file only (and to stderr too with RHEO_DEBUG=1)."""
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if log_file:
        Path(log_file).parent.mkdir(parents=True, exist_ok=True)
        handlers.append(logging.FileHandler(log_file, mode="w"))
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s: %(message)s",
                        handlers=handlers, force=True)
    log = logging.getLogger("rheo.stage")

    def report(kind: type[BaseException], error: BaseException, trace) -> None:
        if not kind.__module__.startswith("rheo.") or os.environ.get("RHEO_DEBUG"):
            sys.__excepthook__(kind, error, trace)
        log.error("%s", error)
        if log_file:
            with open(log_file, "a") as f:
                f.write("".join(traceback.format_exception(kind, error, trace)))

    sys.excepthook = report
    return log


def start_stage(smk) -> logging.Logger:
    """A stage's start: logging into its Snakemake log file, simulations on the configured device."""
    log = setup_logging(smk.log[0])
    set_default_device(smk.config["simulation"]["device"])
    return log


def code_version() -> str:
    """The package's version and, in a git checkout, its commit (with "+changes" when the tree differs from it)."""
    root = Path(rheo.__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return rheo.__version__
    return f"{rheo.__version__} ({commit}{'+changes' if dirty else ''})"


def inputs_key(settings: object, paths: list[str | Path]) -> str:
    """A fingerprint of a stage's settings and input files (the path and content of every file under each path):
    a checkpoint is resumed only under the same key, also in a copy of the tree whose files are newer."""
    hasher = hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode())
    for path in map(Path, paths):
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for f in files:
            hasher.update(f"{f}:{file_sha256(f)}".encode())
    return hasher.hexdigest()
