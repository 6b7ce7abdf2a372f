"""Evaluations spread over worker processes give the values a single process gives, in order."""

import os
from functools import partial

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
