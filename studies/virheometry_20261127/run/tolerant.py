"""Stored evaluations replayed within a tolerance: a point asked for within TOLERANCE (log units, largest coordinate)
of one stored in the same phase gets that one's value. At the run's commit a diagnosis' refit points depend on the
base fit's shear-rate band, which each simulation of the base fit (a GPU's, another machine's) gives a little
otherwise, so a resumed diagnosis asks for points 1e-6 to 1.3e-4 from its stored ones; distinct points of a search
lie 1e-3 or more apart."""

import numpy as np

from rheo.fit import search

TOLERANCE = 5e-4
matched: list[float] = []  # the distance of each point replayed within the tolerance
_exact = search.EvaluationLog.evaluate_many


def evaluate_many(self, objective, points, phase):
    with self._lock:
        for x in points:
            key = self._point_key(phase, x)
            if key not in self._index:
                near = [(float(np.max(np.abs(np.subtract(r["x"], x)))), i) for i, r in enumerate(self.records)
                        if r["phase"] == phase and len(r["x"]) == len(x)]
                if near and min(near)[0] < TOLERANCE:
                    distance, i = min(near)
                    self._index[key] = self.records[i]
                    matched.append(distance)
    return _exact(self, objective, points, phase)


search.EvaluationLog.evaluate_many = evaluate_many
