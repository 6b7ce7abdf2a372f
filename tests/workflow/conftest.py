"""A scratch copy of the workflow (Snakefile, rules, schemas, stages, configs) to run Snakemake in."""

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


class Workflow:
    def __init__(self, root: Path) -> None:
        self.root = root

        self.env = {**os.environ, "PYTHONPATH": str(REPO)}

    def command(self, *args: str) -> list[str]:
        executable = shutil.which("snakemake") or str(Path(sys.executable).parent / "snakemake")
        return [executable, *args, "-j2"]

    def run(self, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
        """Snakemake to its end, in a process group of its own: past ``timeout`` s the group is killed, the jobs
        with it (not left running beside the next test), and ``TimeoutExpired`` raised."""
        with self.start(*args, output=subprocess.PIPE) as job:
            try:
                stdout, stderr = job.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.kill(job)
                raise
        return subprocess.CompletedProcess(job.args, job.returncode, stdout, stderr)

    def start(self, *args: str, output: int = subprocess.DEVNULL) -> subprocess.Popen:
        """Snakemake in the background, in a process group of its own that ``kill`` ends with all its jobs; its
        stdout and stderr (text) to ``output``."""
        return subprocess.Popen(self.command(*args), cwd=self.root, env=self.env, start_new_session=True,
                                stdout=output, stderr=output, text=True)

    @staticmethod
    def kill(job: subprocess.Popen) -> None:
        os.killpg(job.pid, signal.SIGKILL)
        job.wait()


def scratch_workflow(folder: Path) -> Workflow:
    """A copy of the workflow in ``folder``/repo, with ../shared beside it as beside the repository."""
    root = folder / "repo"
    root.mkdir(parents=True)
    for item in ("Snakefile", "workflow", "stages", "config", "examples"):
        src = REPO / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, root / item)
    (folder / "shared").symlink_to(REPO.parent / "shared")
    return Workflow(root)


@pytest.fixture
def workflow(tmp_path) -> Workflow:
    return scratch_workflow(tmp_path)
