"""The test suite. Its two processes run side by side on two cores, so each, and every stage it starts, simulates on
one thread (set before any test module loads torch)."""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
