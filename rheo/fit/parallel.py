"""Loss evaluations on several cores.

Warp's CPU kernels run on one core, so independent simulations (the points of a survey, the setups of a joint fit) are
spread over worker processes, one per core. Each worker builds its objectives once (loading observations, compiling
kernels) and keeps them; a task names the objective and the point. A worker's OpenMP and BLAS (torch's, numpy's) run
on one thread: with a pool of threads each, the workers' threads contend for the cores (docs/performance.md), and a
forked worker whose parent had run torch's OpenMP threads hangs in its first parallel operation. (OpenCV's threads are
left as they are: setting them in a forked worker hangs.) On a GPU the simulations run one after the other in the
calling process.
"""

from __future__ import annotations

import logging
import multiprocessing
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import torch
from threadpoolctl import threadpool_limits

from rheo.physics.device import resolve_device

logger = logging.getLogger(__name__)

Objective = Callable[[np.ndarray], object]
_objectives: dict[str, Objective] = {}


def _start(build: Callable[[], dict[str, Objective]]) -> None:
    global _objectives
    threadpool_limits(1)  # numpy's BLAS
    torch.set_num_threads(1)  # torch's OpenMP and MKL
    _objectives = build()


def _run(name: str, x: np.ndarray) -> object:
    return _objectives[name](x)


class Evaluator:
    """Named objectives evaluated in ``workers`` processes (in this process, one call at a time, when ``workers`` is
    1). ``build`` must be picklable (a module-level function or a functools.partial of one) and return the objectives
    by name (a mapping, which may build an objective when it is first asked for); their values must be picklable."""

    def __init__(self, build: Callable[[], dict[str, Objective]], workers: int) -> None:
        if workers > 1 and resolve_device() != "cpu":
            logger.info("simulations run on the GPU, one at a time (a forked worker cannot use CUDA)")
            workers = 1
        self.workers = workers
        if workers > 1:
            # forked, not spawned: a spawned worker would run the calling script (a Snakemake stage) again
            method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
            self._pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(method),
                                             initializer=_start, initargs=(build,))
        else:
            self._pool = None
            self._local = build()
            # searches run side by side in threads; two must not load a simulator's kernels at once
            self._local_lock = threading.Lock()

    def map(self, tasks: Sequence[tuple[str, np.ndarray]]) -> list:
        """The value of every (objective name, point), in order."""
        if self._pool is None:
            with self._local_lock:
                return [self._local[name](x) for name, x in tasks]
        futures = [self._pool.submit(_run, name, np.asarray(x)) for name, x in tasks]
        return [f.result() for f in futures]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
