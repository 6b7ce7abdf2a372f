"""Evaluations spread over worker processes give the values a single process gives, in order."""

import os
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from rheo.fit.parallel import Evaluator


def _square_sum(offset: float, x: np.ndarray) -> float:
    return float(np.sum((x - offset) ** 2))


def _objectives(offset: float) -> dict:
    return {"bowl": partial(_square_sum, offset), "process": lambda x: float(os.getpid())}


def test_workers_return_the_values_of_one_process_in_order():
    points = [np.array([i, -i], float) for i in range(6)]
    tasks = [("bowl", p) for p in points]
    with Evaluator(partial(_objectives, 1.0), workers=1) as local:
        expected = local.map(tasks)
        assert local.map([("process", points[0])]) == [float(os.getpid())]
    with Evaluator(partial(_objectives, 1.0), workers=2) as pool:
        assert pool.map(tasks) == expected == [_square_sum(1.0, p) for p in points]
        processes = set(pool.map([("process", p) for p in points]))
    assert float(os.getpid()) not in processes


def _threads(x: np.ndarray) -> float:
    import torch

    product = torch.ones(600, 600) @ torch.ones(600, 600)  # a parallel operation where threads are allowed
    return float(torch.get_num_threads()) + float(product[0, 0]) - 600.0


def _thread_objectives() -> dict:
    return {"threads": _threads}


def test_workers_forked_after_the_parent_ran_threads_run_on_one_thread_and_do_not_hang():
    """A worker forked from a process whose torch ran OpenMP threads hangs in its first parallel operation unless its
    threads are set anew; each worker runs on one thread (two workers on two cores)."""
    script = textwrap.dedent("""
        import numpy as np, torch
        from rheo.fit.parallel import Evaluator
        from tests.fit.test_parallel import _thread_objectives
        torch.set_num_threads(2)
        torch.ones(600, 600) @ torch.ones(600, 600)
        with Evaluator(_thread_objectives, workers=2) as pool:
            print(pool.map([("threads", np.zeros(1))] * 4))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[2])
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1] == "[1.0, 1.0, 1.0, 1.0]"


class _Overlap:
    """An objective that counts how many calls are inside it at once."""

    def __init__(self) -> None:
        self.inside, self.most = 0, 0
        self.lock = threading.Lock()

    def __call__(self, x: np.ndarray) -> float:
        with self.lock:
            self.inside += 1
            self.most = max(self.most, self.inside)
        time.sleep(0.02)
        with self.lock:
            self.inside -= 1
        return float(x[0])


def test_in_process_evaluations_asked_for_from_threads_run_one_at_a_time():
    overlap = _Overlap()
    with Evaluator(lambda: {"slow": overlap}, workers=1) as local, ThreadPoolExecutor(4) as threads:
        values = list(threads.map(lambda i: local.map([("slow", np.array([float(i)]))] * 3), range(8)))
    assert values == [[float(i)] * 3 for i in range(8)]
    assert overlap.most == 1
