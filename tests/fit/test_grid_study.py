"""The grid study on a real recording: a coarse grid holds the dam break back, so the rheometer's law of Lotion flows
farther and comes closer to the recording as the grid is refined."""

from argparse import ArgumentTypeError
from pathlib import Path

import numpy as np
import pytest

from rheo.experiments.rheometer import log_rms_error, read_flow_curve
from rheo.experiments.virheometry import read_setup
from rheo.fit.grid_study import grid, law, rheometer_law, study

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"
CURVES = sorted(str(p) for p in (SHARED / "rheometer").glob("Lotion_*.csv"))
SIMULATION = {"cells_per_height": 8, "cells_across": 10, "particles_per_cell": 2, "mu": 300.0, "lam": 1.0e4,
              "max_offset": 0.15, "cfl": 0.4}


def test_the_rheometer_law_fits_every_lotion_curve_and_is_shear_thinning():
    tau_y, K, n = rheometer_law(CURVES, (0.3, 30.0))
    assert 0.3 < n < 0.6 and tau_y > 0 and K > 0
    for path in CURVES:
        assert log_rms_error(tau_y, K, n, read_flow_curve(path).within((0.3, 30.0))) < 0.05


def test_a_finer_grid_lets_the_rheometer_law_flow_farther_toward_the_recording():
    setup = read_setup(SHARED / "virheometry" / "ref_Lotion_2.5_5.1_1", scale=0.5)
    rows = study([setup], SIMULATION, {"rheometer": rheometer_law(CURVES, (0.3, 30.0))}, [(4, 4), (6, 6)], [0.4])
    coarse, finer = rows
    assert [coarse["grid"], finer["grid"]] == ["4x4", "6x6"] and coarse["cfl"] == finer["cfl"] == 0.4
    assert finer["resolution"] > coarse["resolution"]
    assert coarse["recorded_last_outflow_px"] == finer["recorded_last_outflow_px"] > 0
    assert coarse["last_outflow_px"] < finer["last_outflow_px"] < finer["recorded_last_outflow_px"]
    assert finer["loss_px"] < coarse["loss_px"]
    assert np.isfinite([coarse["seconds"], finer["seconds"]]).all()


def test_grids_and_laws_are_parsed_or_refused_with_the_text():
    assert grid("12x14") == (12, 14) and law("4.5,7,0.47") == (4.5, 7.0, 0.47)
    with pytest.raises(ArgumentTypeError, match="'12-14'"):
        grid("12-14")
    with pytest.raises(ArgumentTypeError, match=r"'4\.5,7'"):
        law("4.5,7")
