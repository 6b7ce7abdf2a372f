"""A run's state carried to another machine: the files under some folders of a working tree (its outputs, and the
inputs and stage scripts Snakemake compares their times with), copied into an archive folder with their
modification times, and copied back with those times, so that Snakemake sees finished jobs as finished and an
interrupted stage replays its stored evaluations.

    python -m rheo.archive save ARCHIVE stages config/experiments/suite_7 results/concealed logs/concealed
    python -m rheo.archive restore ARCHIVE

The archive is a plain folder (the files under their paths, and ``mtimes.json``), so a version-control system
stores only the files that changed between two saves."""

from __future__ import annotations

import argparse
import filecmp
import os
import shutil
import sys
from pathlib import Path

from rheo.io import read_json, write_atomic, write_json_atomic

MTIMES = "mtimes.json"


class ArchiveError(Exception):
    """An archive that cannot be saved or restored, with the path and the reason."""


def _inside(relative: str, root: Path, what: str) -> str:
    if Path(relative).is_absolute() or ".." in Path(relative).parts:
        raise ArchiveError(f"{relative}: {what} outside {root}")
    return relative


def _files(root: Path, folders: list[str]) -> dict[str, Path]:
    """The files under ``folders`` (relative to ``root``) by relative path, without hidden files (the temporaries of
    a writer still at work)."""
    found = {}
    for folder in folders:
        base = root / _inside(folder, root, "a folder")
        if not base.is_dir():
            raise ArchiveError(f"{base}: no such folder")
        for path in base.rglob("*"):
            relative = path.relative_to(root)
            if path.is_file() and not any(part.startswith(".") for part in relative.parts):
                found[relative.as_posix()] = path
    return found


def _copy(source: Path, target: Path, mtime_ns: int) -> None:
    write_atomic(target, lambda p: shutil.copyfile(source, p))
    os.utime(target, ns=(mtime_ns, mtime_ns))


def save(archive: str | os.PathLike, folders: list[str], root: str | os.PathLike = ".") -> dict[str, int]:
    """Mirror the files under ``folders`` into ``archive`` with their modification times (files that left those
    folders leave the archive). Returns how many files were copied, kept and removed."""
    archive, root = Path(archive), Path(root)
    files = _files(root, folders)
    old = read_json(archive / MTIMES) if (archive / MTIMES).is_file() else {}
    mtimes, copied = {}, 0
    for relative, source in sorted(files.items()):
        mtimes[relative] = source.stat().st_mtime_ns
        target = archive / relative
        if not (target.is_file() and filecmp.cmp(source, target, shallow=False)):
            _copy(source, target, mtimes[relative])
            copied += 1
    removed = 0
    for relative in set(old) - set(mtimes):
        if any(relative.startswith(f"{Path(f).as_posix()}/") for f in folders):
            (archive / relative).unlink(missing_ok=True)
            removed += 1
        else:  # a folder not saved this time stays as it was
            mtimes[relative] = old[relative]
    write_json_atomic(archive / MTIMES, dict(sorted(mtimes.items())))
    return {"copied": copied, "kept": len(files) - copied, "removed": removed}


def restore(archive: str | os.PathLike, root: str | os.PathLike = ".") -> dict[str, int]:
    """Copy the archived files that ``root`` lacks into it with their modification times. A file already there
    takes the archived time where its content is the same (a run's inputs in a fresh checkout, as new as the
    checkout) and is left as it is where it differs, so that Snakemake reruns what depends on it. Returns how many
    files were restored, matched and kept."""
    archive, root = Path(archive), Path(root)
    if not (archive / MTIMES).is_file():
        raise ArchiveError(f"{archive}: no {MTIMES}, not an archive that rheo.archive saved")
    mtimes = read_json(archive / MTIMES)
    if not isinstance(mtimes, dict) or not all(isinstance(t, int) for t in mtimes.values()):
        raise ArchiveError(f"{archive / MTIMES}: expected file paths with their modification times (ns)")
    counts = {"restored": 0, "matched": 0, "kept": 0}
    for relative, mtime_ns in mtimes.items():
        source = archive / _inside(relative, root, f"a file of {archive / MTIMES}")
        if not source.is_file():
            raise ArchiveError(f"{source}: listed in {archive / MTIMES} but missing")
        target = root / relative
        if not target.exists():
            _copy(source, target, mtime_ns)
            counts["restored"] += 1
        elif target.is_file() and filecmp.cmp(source, target, shallow=False):
            os.utime(target, ns=(mtime_ns, mtime_ns))
            counts["matched"] += 1
        else:
            counts["kept"] += 1
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rheo.archive", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    saving = commands.add_parser("save", help="mirror folders of the working tree into an archive")
    saving.add_argument("archive")
    saving.add_argument("folders", nargs="+", help="folders relative to --root")
    restoring = commands.add_parser("restore", help="copy an archive's files into the working tree where it lacks them")
    restoring.add_argument("archive")
    for command in (saving, restoring):
        command.add_argument("--root", default=".", help="the working tree (default: here)")
    args = parser.parse_args(argv)
    try:
        counts = (save(args.archive, args.folders, args.root) if args.command == "save"
                  else restore(args.archive, args.root))
    except ArchiveError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(", ".join(f"{count} {what}" for what, count in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
