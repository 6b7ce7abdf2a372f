"""A run's state carried to another machine: the files under some folders of a working tree (its outputs),
copied into an archive folder with their modification times, and the fingerprints and times of its inputs (the
files and stage scripts Snakemake compares those times with, which a checkout of the run's commit holds), so
that, restored with those times, Snakemake sees finished jobs as finished and an interrupted stage replays its
stored evaluations.

    python -m rheo.archive save ARCHIVE results/concealed logs/concealed --inputs stages config/experiments/suite_7
    python -m rheo.archive restore ARCHIVE
    python -m rheo.archive status ARCHIVE '*/fit/params.json'

The archive is a plain folder (the files under their paths, ``mtimes.json`` and ``inputs.json``), so a
version-control system stores only the files that changed between two saves. A log that a rerun started afresh
(Snakemake empties a job's log when it starts the job again) does not replace the archived one: that is kept
beside it as ``NAME.earlier-K.log``."""

from __future__ import annotations

import argparse
import filecmp
import os
import re
import shutil
import sys
import time
from collections.abc import Callable, Sequence
from fnmatch import fnmatch
from pathlib import Path

from rheo.io import evaluated_output, file_sha256, read_json, write_atomic, write_json_atomic

MTIMES = "mtimes.json"  # archived file: its modification time (ns)
INPUTS = "inputs.json"  # input file: its modification time (ns) and sha256
EARLIER_LOG = re.compile(r"\.earlier-\d+\.log$")  # an archived log of an earlier run of the same job


class ArchiveError(Exception):
    """An archive that cannot be saved or restored, with the path and the reason."""


def _inside(relative: str, root: Path, what: str) -> str:
    if Path(relative).is_absolute() or ".." in Path(relative).parts:
        raise ArchiveError(f"{relative}: {what} outside {root}")
    return relative


def _files(root: Path, folders: Sequence[str]) -> dict[str, Path]:
    """The files under ``folders`` (relative to ``root``) by relative path, without hidden files inside them (the
    temporaries of a writer still at work); a folder named may be hidden (Snakemake's ``.snakemake/metadata``)."""
    found = {}
    for folder in folders:
        base = root / _inside(folder, root, "a folder")
        if not base.is_dir():
            raise ArchiveError(f"{base}: no such folder")
        for path in base.rglob("*"):
            if path.is_file() and not any(part.startswith(".") for part in path.relative_to(base).parts):
                found[path.relative_to(root).as_posix()] = path
    return found


def _copy(source: Path, target: Path, mtime_ns: int) -> None:
    write_atomic(target, lambda p: shutil.copyfile(source, p))
    os.utime(target, ns=(mtime_ns, mtime_ns))


def _continues(source: Path, target: Path) -> bool:
    """Whether ``source`` begins with the whole of ``target`` (a log that grew since it was archived)."""
    size = target.stat().st_size
    if source.stat().st_size < size:
        return False
    with source.open("rb") as new, target.open("rb") as old:
        return new.read(size) == old.read()


def _set_aside(target: Path) -> Path:
    """Rename an archived log to the first free ``NAME.earlier-K.log`` beside it."""
    k = 1
    while (earlier := target.with_name(f"{target.stem}.earlier-{k}.log")).exists():
        k += 1
    target.rename(earlier)
    return earlier


def save(archive: str | os.PathLike, folders: Sequence[str], root: str | os.PathLike = ".",
         inputs: Sequence[str] = ()) -> dict[str, int]:
    """Mirror the files under ``folders`` into ``archive`` with their modification times (files that left those
    folders leave the archive, except logs of earlier runs), and list the files under ``inputs`` by time and
    fingerprint. Returns how many files were copied, kept, removed and listed, and how many logs were set aside."""
    archive, root = Path(archive), Path(root)
    files = _files(root, folders)
    old = read_json(archive / MTIMES) if (archive / MTIMES).is_file() else {}
    mtimes, copied, set_aside = {}, 0, 0
    for relative, source in sorted(files.items()):
        mtimes[relative] = source.stat().st_mtime_ns
        target = archive / relative
        if not (target.is_file() and filecmp.cmp(source, target, shallow=False)):
            if target.suffix == ".log" and target.is_file() and not _continues(source, target):
                archived_ns = target.stat().st_mtime_ns
                mtimes[_set_aside(target).relative_to(archive).as_posix()] = archived_ns
                set_aside += 1
            _copy(source, target, mtimes[relative])
            copied += 1
    removed = 0
    for relative in set(old) - set(mtimes):
        if not EARLIER_LOG.search(relative) and any(relative.startswith(f"{Path(f).as_posix()}/") for f in folders):
            (archive / relative).unlink(missing_ok=True)
            removed += 1
        else:  # a folder not saved this time stays as it was
            mtimes[relative] = old[relative]
    write_json_atomic(archive / MTIMES, dict(sorted(mtimes.items())))
    listed = {relative: {"mtime_ns": path.stat().st_mtime_ns, "sha256": file_sha256(path)}
              for relative, path in sorted(_files(root, inputs).items())}
    if inputs or not (archive / INPUTS).is_file():  # a save without inputs keeps the earlier listing
        write_json_atomic(archive / INPUTS, listed)
    return {"copied": copied, "kept": len(files) - copied, "removed": removed, "inputs listed": len(listed),
            "earlier logs set aside": set_aside}


def _listing(path: Path, valid: Callable[[object], bool], what: str) -> dict:
    listing = read_json(path) if path.is_file() else {}
    if not isinstance(listing, dict) or not all(valid(v) for v in listing.values()):
        raise ArchiveError(f"{path}: expected file paths with {what}")
    return listing


def restore(archive: str | os.PathLike, root: str | os.PathLike = ".") -> dict[str, int]:
    """Copy the archived files that ``root`` lacks into it with their modification times (files already there are
    left as they are), and give the listed inputs whose content is the same their listed times; an input that
    differs keeps its own, so that Snakemake reruns what depends on it. Returns how many files were restored and
    kept, and how many inputs matched and differed."""
    archive, root = Path(archive), Path(root)
    if not (archive / MTIMES).is_file():
        raise ArchiveError(f"{archive}: no {MTIMES}, not an archive that rheo.archive saved")
    mtimes = _listing(archive / MTIMES, lambda t: isinstance(t, int), "their modification times (ns)")
    inputs = _listing(archive / INPUTS, lambda v: isinstance(v, dict) and isinstance(v.get("mtime_ns"), int),
                      "their modification times (ns) and sha256")
    counts = {"restored": 0, "kept": 0, "inputs matched": 0, "inputs differing": 0}
    for relative, mtime_ns in mtimes.items():
        source = archive / _inside(relative, root, f"a file of {archive / MTIMES}")
        if not source.is_file():
            raise ArchiveError(f"{source}: listed in {archive / MTIMES} but missing")
        target = root / relative
        if target.exists():
            counts["kept"] += 1
        else:
            _copy(source, target, mtime_ns)
            counts["restored"] += 1
    for relative, listed in inputs.items():
        target = root / _inside(relative, root, f"a file of {archive / INPUTS}")
        if target.is_file() and file_sha256(target) == listed["sha256"]:
            os.utime(target, ns=(listed["mtime_ns"], listed["mtime_ns"]))
            counts["inputs matched"] += 1
        else:
            counts["inputs differing"] += 1
    return counts


def status(archive: str | os.PathLike, patterns: Sequence[str] = ()) -> dict:
    """What ``archive`` holds: its files, the newest one's modification time (UTC), how many files match each of
    ``patterns`` (globs on the path), and, for each stage whose output is not archived but whose stored evaluations
    are, how many evaluations a resumed stage replays and the minutes they took."""
    archive = Path(archive)
    if not (archive / MTIMES).is_file():
        raise ArchiveError(f"{archive}: no {MTIMES}, not an archive that rheo.archive saved")
    mtimes = _listing(archive / MTIMES, lambda t: isinstance(t, int), "their modification times (ns)")
    unfinished = {}
    for relative in sorted(mtimes):
        output = evaluated_output(relative)
        if output is not None and output not in mtimes:
            stored = read_json(archive / relative)
            if not isinstance(stored, dict):  # a search's log keeps its records under "records", a grid's by point
                raise ArchiveError(f"{archive / relative}: expected stored evaluations")
            seconds = stored.get("runtime_s", stored.get("seconds"))
            unfinished[output] = {"evaluations": len(stored.get("records", stored)),
                                  "minutes": None if seconds is None else round(seconds / 60)}
    newest = max(mtimes.values(), default=None)
    return {"files": len(mtimes),
            "newest": None if newest is None else time.strftime("%Y-%m-%d %H:%M", time.gmtime(newest / 1e9)),
            "matching": {pattern: sum(fnmatch(relative, pattern) for relative in mtimes) for pattern in patterns},
            "unfinished": unfinished}


def _report(archive: str, found: dict) -> str:
    lines = [f"{archive}: {found['files']} files, the newest modified {found['newest']} UTC"]
    lines += [f"{pattern}: {count}" for pattern, count in found["matching"].items()]
    if found["unfinished"]:
        lines.append("stages unfinished, with the evaluations a resumed stage replays:")
        for output, stored in found["unfinished"].items():
            took = "" if stored["minutes"] is None else f" in {stored['minutes']} min"
            count = stored["evaluations"]
            lines.append(f"  {output}: {count} evaluation{'' if count == 1 else 's'}{took}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rheo.archive", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    saving = commands.add_parser("save", help="mirror folders of the working tree into an archive")
    saving.add_argument("archive")
    saving.add_argument("folders", nargs="+", help="folders whose files are copied, relative to --root")
    saving.add_argument("--inputs", nargs="+", default=[], help="folders whose files are listed, relative to --root")
    restoring = commands.add_parser("restore", help="copy an archive's files into the working tree where it lacks them")
    restoring.add_argument("archive")
    for command in (saving, restoring):
        command.add_argument("--root", default=".", help="the working tree (default: here)")
    reporting = commands.add_parser("status", help="what an archive holds and what a resumed run replays")
    reporting.add_argument("archive")
    reporting.add_argument("patterns", nargs="*", help="globs on the archived paths whose files are counted")
    args = parser.parse_args(argv)
    try:
        if args.command == "status":
            print(_report(args.archive, status(args.archive, args.patterns)))
            return 0
        counts = (save(args.archive, args.folders, args.root, args.inputs) if args.command == "save"
                  else restore(args.archive, args.root))
    except ArchiveError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(", ".join(f"{count} {what}" for what, count in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
