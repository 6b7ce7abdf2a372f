"""A run killed in the middle of the fit (SIGKILL to Snakemake and its jobs) resumes, after --unlock, with
--rerun-incomplete from its stored evaluations: on the same cores to the same params.json, byte for byte, as a run
never interrupted; on fewer cores (one worker instead of two) to a fit as good within the fit's tolerance. Finished
stages are not run again. A run past its time limit is killed with its jobs."""

import json
import subprocess
import time
from pathlib import Path

import pytest

from tests.workflow.conftest import Workflow, scratch_workflow

TARGET = "results/tiny/fit/params.json"


def _killed_half_way(folder):
    """A scratch workflow whose fit was killed after its tenth stored evaluation, unlocked."""
    killed = scratch_workflow(folder)
    assert killed.run("results/tiny/fit/warmup.json").returncode == 0
    store = killed.root / "results/tiny/fit/params.evaluations.json"
    job = killed.start(TARGET)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and job.poll() is None:
        if store.is_file() and len(json.loads(store.read_text() or "{}").get("records", [])) >= 10:
            break
        time.sleep(0.2)
    assert job.poll() is None, "the fit ended before it could be killed"
    killed.kill(job)
    assert not (killed.root / TARGET).exists()
    assert "cannot be locked" in killed.run(TARGET).stderr  # a killed Snakemake leaves its lock
    assert killed.run(TARGET, "--unlock").returncode == 0
    return killed


@pytest.mark.slow
@pytest.mark.parametrize("cores", ["2", "1"])
def test_a_fit_killed_half_way_resumes_from_its_stored_evaluations(tmp_path, cores):
    whole = scratch_workflow(tmp_path / "whole")
    run = whole.run(TARGET)
    assert run.returncode == 0, run.stderr[-3000:]
    killed = _killed_half_way(tmp_path / "killed")
    warmup_time = (killed.root / "results/tiny/fit/warmup.json").stat().st_mtime_ns

    resumed = killed.run(TARGET, "--rerun-incomplete", "--cores", cores)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    log = (killed.root / "logs/tiny/fit.log").read_text()
    assert "replaying" in log and "; run of " in log  # the killed run, named in the new log
    assert (killed.root / "results/tiny/fit/warmup.json").stat().st_mtime_ns == warmup_time
    if cores == "2":
        assert (killed.root / TARGET).read_bytes() == (whole.root / TARGET).read_bytes()
    else:  # one worker searches one simplex at a time: another path, a fit as good within the tolerance
        expected, found = (json.loads((w.root / TARGET).read_text()) for w in (whole, killed))
        assert found["final_loss"] <= expected["final_loss"] * (1 + expected["tolerance"])
        for name, entry in expected["parameters"].items():
            low, high = entry["interval"]
            if entry["determined"]:
                assert low <= found["parameters"][name]["value"] <= high, name


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists and has not exited (a zombie has)."""
    stat = Path(f"/proc/{pid}/stat")
    return stat.exists() and stat.read_text().rsplit(")", 1)[1].split()[0] != "Z"


def test_a_run_past_its_time_is_killed_with_its_jobs(tmp_path):
    (tmp_path / "Snakefile").write_text('rule hang:\n    output: "never"\n'
                                        '    shell: "sleep 300 & echo $! > sleep.pid; wait; touch {output}"\n')
    with pytest.raises(subprocess.TimeoutExpired):
        Workflow(tmp_path).run("never", timeout=30)
    assert not _running(int((tmp_path / "sleep.pid").read_text()))

