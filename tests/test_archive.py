"""A run's state carried to another machine: Snakemake, run on the restored copy, finds the finished jobs finished
and runs only what was left; the archive keeps modification times to the nanosecond and stores only what changed."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rheo.archive import INPUTS, MTIMES, ArchiveError, main, restore, save, status
from rheo.fit.search import EvaluationLog
from rheo.io import evaluations_path

SNAKEFILE = """
rule all:
    input: "results/c.txt"

rule a:
    input: "config/a.txt"
    output: "results/z_from_a.txt"
    shell: "cat {input} > {output} && echo ran a >> runs.log"

rule b:
    input: "results/z_from_a.txt"
    output: "results/b.txt"
    script: "stages/b.py"

rule c:
    input: "results/b.txt"
    output: "results/c.txt"
    shell: "cat {input} > {output} && echo c >> {output} && echo ran c >> runs.log"
"""

STAGE_B = """
from pathlib import Path
Path(snakemake.output[0]).write_text(Path(snakemake.input[0]).read_text() + "b\\n")
with open("runs.log", "a") as log:
    log.write("ran b\\n")
"""


def snakemake(workdir: Path, target: str = "all", *options: str, env: dict[str, str] | None = None) -> None:
    subprocess.run([sys.executable, "-m", "snakemake", "-j1", target, *options], cwd=workdir, check=True,
                   capture_output=True, env=env)


def half_run(tree: Path, snakefile: str = SNAKEFILE, inputs: tuple[str, ...] = ("config/a.txt",)) -> None:
    """A run of SNAKEFILE in ``tree`` stopped after jobs a and b (c not yet)."""
    for name, text in (("Snakefile", snakefile), ("stages/b.py", STAGE_B), *((name, "a\n") for name in inputs)):
        (tree / name).parent.mkdir(parents=True, exist_ok=True)
        (tree / name).write_text(text)
    snakemake(tree, "results/b.txt")


def fresh_checkout(tree: Path, copy: Path) -> None:
    """``tree``'s own files copied to ``copy``, without the run's outputs and Snakemake's records."""
    shutil.copytree(tree, copy, ignore=shutil.ignore_patterns("results", "runs.log", ".snakemake"))


def test_snakemake_resumes_on_a_restored_checkout_without_running_the_finished_jobs_again(tmp_path):
    first, second, archive = tmp_path / "first", tmp_path / "second", tmp_path / "archive"
    half_run(first)
    assert (first / "runs.log").read_text().split() == ["ran", "a", "ran", "b"]
    save(archive, ["results"], root=first, inputs=["config", "stages"])

    fresh_checkout(first, second)
    for name in ("config/a.txt", "stages/b.py"):  # as new as the checkout
        (second / name).touch()
    assert restore(archive, root=second) == {"restored": 2, "kept": 0, "inputs matched": 2, "inputs differing": 0}
    snakemake(second)

    assert (second / "runs.log").read_text().split() == ["ran", "c"]
    assert (second / "results/c.txt").read_text().split() == ["a", "b", "c"]


def test_an_input_that_differs_keeps_its_time_so_what_depends_on_it_runs_again(tmp_path):
    first, second, archive = tmp_path / "first", tmp_path / "second", tmp_path / "archive"
    half_run(first)
    save(archive, ["results"], root=first, inputs=["config", "stages"])
    fresh_checkout(first, second)
    (second / "config/a.txt").write_text("A\n")

    assert restore(archive, root=second)["inputs differing"] == 1
    snakemake(second)
    assert (second / "results/c.txt").read_text().split() == ["A", "b", "c"]


def test_with_snakemakes_records_a_run_resumes_where_an_input_outside_the_checkout_is_newer(tmp_path):
    first, second, archive, shared = tmp_path / "first", tmp_path / "second", tmp_path / "archive", tmp_path / "data"
    half_run(first, SNAKEFILE.replace("config/a.txt", "../data/a.txt"), inputs=("../data/a.txt",))
    save(archive, ["results", ".snakemake/metadata"], root=first, inputs=["stages"])

    fresh_checkout(first, second)
    (shared / "a.txt").touch()  # the data as new as the machine it lies on
    restore(archive, root=second)
    snakemake(second, "all", "--rerun-triggers", "params", "input", "software-env", "code")
    assert (second / "runs.log").read_text().split() == ["ran", "c"]


def test_times_are_kept_and_only_changed_files_are_copied(tmp_path):
    tree, archive, copy = tmp_path / "tree", tmp_path / "archive", tmp_path / "copy"
    (tree / "results/x").mkdir(parents=True)
    (tree / "results/x/evaluations.json").write_text('{"records": [1]}')
    (tree / "results/x/params.json").write_text("{}")
    (tree / "results/x/.params.json.123.tmp").write_text("half")  # a writer's temporary
    os.utime(tree / "results/x/params.json", ns=(1_700_000_000_123_456_789,) * 2)

    assert save(archive, ["results"], root=tree) == {"copied": 2, "kept": 0, "removed": 0, "inputs listed": 0,
                                                     "earlier logs set aside": 0}
    assert not (archive / "results/x/.params.json.123.tmp").exists()

    (tree / "results/x/evaluations.json").write_text('{"records": [1, 2]}')
    (tree / "results/x/params.json").unlink()
    assert save(archive, ["results"], root=tree) == {"copied": 1, "kept": 0, "removed": 1, "inputs listed": 0,
                                                     "earlier logs set aside": 0}

    (tree / "results/x/params.json").write_text("{}")
    os.utime(tree / "results/x/params.json", ns=(1_700_000_000_123_456_789,) * 2)
    save(archive, ["results"], root=tree)
    assert restore(archive, root=copy)["restored"] == 2
    for name in ("evaluations.json", "params.json"):
        original, restored = tree / "results/x" / name, copy / "results/x" / name
        assert restored.read_text() == original.read_text()
        assert restored.stat().st_mtime_ns == original.stat().st_mtime_ns


def test_restore_leaves_files_already_there_and_save_keeps_folders_not_named(tmp_path):
    tree, archive, copy = tmp_path / "tree", tmp_path / "archive", tmp_path / "copy"
    for folder in ("results", "logs"):
        (tree / folder).mkdir(parents=True)
        (tree / folder / "f.txt").write_text(folder)
    save(archive, ["results", "logs"], root=tree)
    (tree / "logs/f.txt").unlink()
    save(archive, ["results"], root=tree)  # logs not named: its file stays archived
    (copy / "results").mkdir(parents=True)
    (copy / "results/f.txt").write_text("newer, local")
    local = (copy / "results/f.txt").stat().st_mtime_ns

    assert restore(archive, root=copy) == {"restored": 1, "kept": 1, "inputs matched": 0, "inputs differing": 0}
    assert (copy / "results/f.txt").read_text() == "newer, local"
    assert (copy / "results/f.txt").stat().st_mtime_ns == local
    assert (copy / "logs/f.txt").read_text() == "logs"


def test_a_log_that_a_rerun_started_afresh_leaves_the_earlier_runs_log_archived_beside_it(tmp_path):
    tree, archive, copy = tmp_path / "tree", tmp_path / "archive", tmp_path / "copy"
    tree.mkdir()
    (tree / "Snakefile").write_text('rule a:\n    output: "results/a.txt"\n    log: "logs/a.log"\n'
                                    '    shell: "echo $RUN >> {log} && echo $RUN >> {log} && touch {output}"\n')
    run = {**os.environ, "RUN": "first"}
    snakemake(tree, "results/a.txt", env=run)
    save(archive, ["results", "logs"], root=tree)
    with (tree / "logs/a.log").open("a") as log:  # a log that grew since: no earlier run to keep
        log.write("first, more\n")
    assert save(archive, ["logs"], root=tree)["earlier logs set aside"] == 0

    run["RUN"] = "second"  # Snakemake empties the log of a job it runs again
    snakemake(tree, "results/a.txt", "-f", env=run)
    assert (tree / "logs/a.log").read_text().split() == ["second", "second"]
    assert save(archive, ["results", "logs"], root=tree)["earlier logs set aside"] == 1
    assert (archive / "logs/a.earlier-1.log").read_text().split() == ["first", "first", "first,", "more"]
    assert (archive / "logs/a.log").read_text().split() == ["second", "second"]

    (tree / "logs/a.log").unlink()  # the job's log gone from the tree: the earlier run's stays archived
    save(archive, ["logs"], root=tree)
    assert restore(archive, root=copy)["restored"] == 2
    assert (copy / "logs/a.earlier-1.log").read_text().split() == ["first", "first", "first,", "more"]


def test_status_counts_the_outputs_made_and_the_evaluations_an_unfinished_stage_replays(tmp_path, capsys):
    tree, archive = tmp_path / "tree", tmp_path / "archive"
    for case, evaluated, finished in (("a", 3, True), ("b", 5, False), ("c", 2, False)):
        fit = tree / "results" / case / "fit"
        fit.mkdir(parents=True)
        log = EvaluationLog(evaluations_path(fit / "params.json"), key="settings")
        for k in range(evaluated):
            log.evaluate(lambda x: float(x @ x), np.array([k, 1.0]), phase="search")
        if finished:
            (fit / "params.json").write_text("{}")
    os.utime(tree / "results/c/fit/params.evaluations.json", ns=(1_800_000_000_000_000_000,) * 2)  # the newest
    save(archive, ["results"], root=tree)
    (tree / "results/b/fit/params.json").write_text("{}")  # finished after the save: not in the archive

    found = status(archive, ["*/fit/params.json", "*/truth.json"])
    assert found["files"] == 4
    assert found["newest"] == "2027-01-15 08:00"  # 1.8e9 s after 1970-01-01 00:00 UTC
    assert found["matching"] == {"*/fit/params.json": 1, "*/truth.json": 0}
    assert {output: stored["evaluations"] for output, stored in found["unfinished"].items()} == {
        "results/b/fit/params.json": 5, "results/c/fit/params.json": 2}

    assert main(["status", str(archive), "*/fit/params.json"]) == 0
    assert "results/b/fit/params.json: 5 evaluations in 0 min" in capsys.readouterr().out
    (archive / "results/c/fit/params.evaluations.json").write_text("[]")
    assert main(["status", str(archive)]) == 1
    assert "results/c/fit/params.evaluations.json: expected stored evaluations" in capsys.readouterr().err


def test_bad_input_gets_one_error_naming_the_path(tmp_path, capsys):
    with pytest.raises(ArchiveError, match="no such folder"):
        save(tmp_path / "archive", ["results"], root=tmp_path)
    with pytest.raises(ArchiveError, match="outside"):
        save(tmp_path / "archive", ["../elsewhere"], root=tmp_path)
    (tmp_path / "archive").mkdir()
    assert main(["restore", str(tmp_path / "archive")]) == 1
    assert f"{tmp_path / 'archive'}: no {MTIMES}" in capsys.readouterr().err
    (tmp_path / "archive" / MTIMES).write_text(json.dumps({"../../etc/x": 1}))
    with pytest.raises(ArchiveError, match="outside"):
        restore(tmp_path / "archive", root=tmp_path / "tree")
    (tmp_path / "archive" / MTIMES).write_text(json.dumps({"results/x": "yesterday"}))
    with pytest.raises(ArchiveError, match="modification times"):
        restore(tmp_path / "archive", root=tmp_path / "tree")
    (tmp_path / "archive" / MTIMES).write_text("{}")
    (tmp_path / "archive" / INPUTS).write_text(json.dumps({"stages/b.py": 5}))
    with pytest.raises(ArchiveError, match=f"{INPUTS}: expected"):
        restore(tmp_path / "archive", root=tmp_path / "tree")


def test_every_stored_run_holds_the_files_it_lists():
    studies = Path(__file__).resolve().parents[1] / "studies"
    for listing in sorted(studies.glob("*/mtimes.json")):
        missing = [name for name in json.loads(listing.read_text()) if not (listing.parent / name).is_file()]
        assert not missing, f"{listing.parent.name}: {len(missing)} listed files missing, e.g. {missing[:3]}"
