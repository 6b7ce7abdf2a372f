"""Run stage scripts as Snakemake would (from job specs) side by side until a deadline; pack their outputs."""
import json
import os
import re
import runpy
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

MAX_RUNNING = int(os.environ.get("MAX_RUNNING", "20"))

def one(spec: dict) -> None:
    smk = SimpleNamespace(input=SimpleNamespace(**spec["input"]), output=SimpleNamespace(**spec["output"]),
                          params=SimpleNamespace(**spec["params"]), log=spec["log"], threads=spec["threads"],
                          config=spec["config"], wildcards=SimpleNamespace())
    unlink = Path.unlink  # keep the evaluation log of a finished fit: it is replayed where the run goes on
    Path.unlink = lambda self, *a, **k: None if self.name.endswith(".evaluations.json") else unlink(self, *a, **k)
    for path in spec["output"].values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    runpy.run_path(spec["script"], init_globals={"snakemake": smk}, run_name="__main__")


def main(jobs_file: str, deadline_s: float, out: str, first_wait_s: float) -> None:
    start = time.time()
    jobs = json.loads(Path(jobs_file).read_text())
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    Path("stderr").mkdir(exist_ok=True)
    procs = {}

    def launch(i: int) -> None:
        spec = jobs[i]
        err = open(Path("stderr", f"{spec['name']}.txt"), "w")  # noqa: SIM115  (the child process writes it)
        procs[spec["name"]] = subprocess.Popen([sys.executable, __file__, "--one", jobs_file, str(i)], env=env,
                                               stdout=err, stderr=subprocess.STDOUT)

    launch(0)  # the first compiles the kernels; the others load them from the cache
    first_log = Path(jobs[0]["log"][0])
    while time.time() - start < first_wait_s:
        if first_log.is_file() and re.search(r"evaluation 1\b", first_log.read_text()):  # a fit's or a diagnosis'
            break
        if procs[jobs[0]["name"]].poll() is not None:
            break
        time.sleep(2)
    print(f"first job ready after {time.time() - start:.0f} s", flush=True)
    relaunches = {spec["name"]: 0 for spec in jobs}
    names = set(relaunches)
    while time.time() - start < deadline_s:
        for i, spec in enumerate(jobs):  # a job starts once the one it needs has finished
            after = spec.get("after")
            ready = after is None or after not in names or (after in procs and procs[after].poll() == 0)
            running = sum(p.poll() is None for p in procs.values())
            if spec["name"] not in procs and ready and running < MAX_RUNNING:
                launch(i)
        time.sleep(5)
        for i, spec in enumerate(jobs):  # a crashed job goes on from its stored evaluations
            name = spec["name"]
            if (name in procs and procs[name].poll() not in (None, 0) and relaunches[name] < 8
                    and time.time() - start < deadline_s - 60):
                relaunches[name] += 1
                print(f"{name} exit {procs[name].returncode}: relaunch {relaunches[name]}", flush=True)
                os.rename(Path("stderr", f"{name}.txt"), Path("stderr", f"{name}.{relaunches[name]}.txt"))
                launch(i)
        if len(procs) == len(jobs) and all(p.poll() is not None for p in procs.values()):
            break
    for p in procs.values():
        if p.poll() is None:
            p.terminate()
    time.sleep(3)
    for name, p in procs.items():
        if p.poll() is None:
            p.kill()
        print(name, "exit", p.returncode, flush=True)
    # GNU tar's POSIX format keeps modification times to the nanosecond, which the evaluations' keys hold at the
    # run's commit (an output of one job, a fit's params.json, is the input of the next)
    folders = {Path(next(iter(spec["output"].values()))).parent for spec in jobs}
    packed = [str(f) for f in sorted(folders) if f.is_dir()]
    packed += [spec["log"][0] for spec in jobs if Path(spec["log"][0]).is_file()] + ["stderr"]
    subprocess.run(["tar", "--format=posix", "-cf", str(Path(out, "fits.tar")), *packed], check=True)
    print(f"done after {time.time() - start:.0f} s", flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "--one":
        one(json.loads(Path(sys.argv[2]).read_text())[int(sys.argv[3])])
    else:
        main(sys.argv[1], float(sys.argv[2]), sys.argv[3], float(sys.argv[4]))
