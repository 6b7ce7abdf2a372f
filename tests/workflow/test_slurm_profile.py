"""The SLURM profile against a real single-node Slurm (Debian's slurm-wlm and munge, started here): jobs are
submitted with the memory, time limit and CPUs their rules declare, and their outputs come back. Needs root, the
daemons (apt-get install slurm-wlm munge) and the executor plugin (pip install snakemake-executor-plugin-slurm);
skipped otherwise."""

import importlib.util
import os
import re
import shutil
import socket
import subprocess
import time
from pathlib import Path

import pytest

SLURM_CONF = Path("/etc/slurm/slurm.conf")
CONFIG = """# written by rheo's test of the SLURM profile
ClusterName=rheotest
SlurmctldHost={host}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
MpiDefault=none
ReturnToService=2
StateSaveLocation={state}/state
SlurmdSpoolDir={state}/spool
SlurmctldPidFile={state}/slurmctld.pid
SlurmdPidFile={state}/slurmd.pid
SlurmctldLogFile={state}/slurmctld.log
SlurmdLogFile={state}/slurmd.log
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
MinJobAge=600
NodeName={host} CPUs={cpus} RealMemory={memory} State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
"""


def _can_run_slurm() -> bool:
    tools = ("munged", "slurmctld", "slurmd", "sbatch", "scontrol")
    ours = not SLURM_CONF.exists() or SLURM_CONF.read_text().startswith("# written by rheo's test")
    plugin = importlib.util.find_spec("snakemake_executor_plugin_slurm") is not None
    return os.geteuid() == 0 and all(shutil.which(t) for t in tools) and ours and plugin


@pytest.fixture
def slurm(tmp_path):
    state = tmp_path / "slurm"
    for sub in ("state", "spool"):
        (state / sub).mkdir(parents=True)
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2**20 // 2
    SLURM_CONF.parent.mkdir(parents=True, exist_ok=True)
    SLURM_CONF.write_text(CONFIG.format(host=socket.gethostname(), state=state, cpus=os.cpu_count(), memory=memory))
    for folder in ("/run/munge", "/var/log/munge", "/var/lib/munge"):
        Path(folder).mkdir(parents=True, exist_ok=True)
    if not subprocess.run(["pgrep", "-x", "munged"], capture_output=True).stdout:
        subprocess.run(["munged", "--force"], check=True, capture_output=True)
    subprocess.run(["slurmctld"], check=True)
    subprocess.run(["slurmd"], check=True)
    deadline = time.monotonic() + 60
    while "idle" not in subprocess.run(["sinfo", "-h", "-o", "%t"], capture_output=True, text=True).stdout:
        assert time.monotonic() < deadline, (state / "slurmctld.log").read_text()[-2000:]
        time.sleep(1)
    yield
    for pid_file in ("slurmd.pid", "slurmctld.pid"):
        if (state / pid_file).is_file():
            subprocess.run(["kill", (state / pid_file).read_text().strip()], check=False)
    SLURM_CONF.unlink(missing_ok=True)


def _job(job_id: str) -> dict[str, str]:
    text = subprocess.run(["scontrol", "show", "job", job_id], capture_output=True, text=True, check=True).stdout
    return dict(re.findall(r"(\w+)=(\S+)", text))


@pytest.mark.slow
@pytest.mark.skipif(not _can_run_slurm(), reason="needs root and slurm-wlm with munge installed")
def test_the_slurm_profile_submits_jobs_with_their_rules_resources(workflow, slurm):
    # this cluster keeps no accounting, so the jobs' states come from squeue (completed ones kept for MinJobAge)
    run = workflow.run("results/tiny/recordings", "results/tiny/proxy/particles.npz", "--profile",
                       "workflow/profiles/slurm", "--slurm-status-command", "squeue", "--set-threads", "synthesize=2")
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    submitted = dict(re.findall(r"SLURM jobid (\d+) \(log: \S+/rule_(\w+)/", out))
    jobs = {rule: _job(job_id) for job_id, rule in submitted.items()}
    assert set(jobs) == {"synthesize", "proxy"}
    # proxy: mem_mb 1000, runtime 5; synthesize: 800 + 500 MB per worker, two workers, runtime 30
    assert jobs["proxy"]["MinMemoryNode"] == "1000M" and jobs["proxy"]["TimeLimit"] == "00:05:00"
    assert jobs["synthesize"]["MinMemoryNode"] == "1800M" and jobs["synthesize"]["TimeLimit"] == "00:30:00"
    assert jobs["synthesize"]["NumCPUs"] == "2"
    assert all(job["JobState"] == "COMPLETED" for job in jobs.values())
    assert (workflow.root / "results/tiny/recordings/recording.json").is_file()
