"""The convergence study: Richardson extrapolation against sequences of known order and limit, the study's summary
on constructed rows, and a small study of a real recording that resumes from its stored simulations."""

import dataclasses
import json
from argparse import ArgumentTypeError
from pathlib import Path

import numpy as np
import pytest

from rheo.experiments.rheometer import log_rms_error, read_flow_curve
from rheo.experiments.virheometry import read_setup
from rheo.fit import convergence
from rheo.fit.convergence import (
    EvaluationStore,
    StudyRecords,
    code_text,
    engine_fingerprint,
    grid,
    law,
    modulus,
    observed_order,
    rheometer_law,
    richardson,
    run,
    study_cases,
    summarize,
)
from rheo.fit.dam_break import OFFSET_STEP

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"
CURVES = sorted(str(p) for p in (SHARED / "rheometer").glob("Lotion_*.csv"))
SIMULATION = {"cells_per_height": 6, "cells_across": 8, "particles_per_cell": 2, "mu": 300.0, "lam": 1.0e4,
              "max_offset": 0.15, "cfl": 0.8}


@pytest.mark.parametrize("order", [0.7, 1.0, 2.0])
def test_richardson_recovers_the_order_and_limit_of_a_power_law_on_uneven_grids(order):
    h = np.array([0.0067, 0.005, 0.004, 0.00286])
    q = 0.31 - 4.0 * h**order
    fit = richardson(h, q)
    assert fit["order"] == pytest.approx(order, rel=1e-6)
    assert fit["limit"] == pytest.approx(0.31, rel=1e-9)
    assert fit["finest_error"] == pytest.approx(4.0 * h[-1] ** order / 0.31, rel=1e-6)


def test_values_that_do_not_converge_monotonically_have_no_order():
    assert observed_order([4.0, 2.0, 1.0], [1.0, 1.2, 1.1]) is None  # the differences change sign
    assert observed_order([4.0, 2.0, 1.0], [1.0, 1.0, 1.1]) is None
    assert richardson([2.0, 1.0], [1.0, 1.1]) == {"order": None, "limit": None, "finest_error": None}


def _row(setup: str, law_label: str, h: float, cfl: float, loss: float, outflow: float, grids: list[str]) -> dict:
    return {"setup": setup, "law": law_label, "h_m": h, "cfl": cfl, "grids": grids, "loss_px": loss,
            "outflow": [0.5 * outflow, outflow], "front_m": [0.01, 0.02 * outflow], "times_s": [0.04, 0.08]}


def test_summary_gives_limits_the_default_grids_error_the_winner_and_the_steps_effect():
    rows = []
    for h, grids in [(0.004, ["8x3"]), (0.002, ["16x3", "12x14"]), (0.001, ["32x3"])]:
        for cfl, slower in [(0.4, 1.0), (0.8, 0.99)]:
            rows.append(_row("a", "thin", h, cfl, 0.01 + 5 * h, slower * (0.3 - 10 * h), grids))
            rows.append(_row("a", "plain", h, cfl, 0.02 + h, slower * (0.3 - 10 * h), grids))
    summary = summarize(rows, {"a": 0.002})
    entry = next(e for e in summary["convergence"] if (e["law"], e["cfl"]) == ("thin", 0.4))
    outflow = entry["quantities"]["outflow"]
    assert outflow["order"] == pytest.approx(1.0) and outflow["limit"] == pytest.approx(0.3)
    assert outflow["default_error"] == pytest.approx(0.02 / 0.3)
    winners = {(c["grid"], c["cfl"]): c["winner"] for c in summary["contests"]}
    # thin loses 0.030 at h 0.004 against plain's 0.024, then wins as the cell shrinks
    assert winners[("8x3", 0.4)] == "plain" and winners[("16x3", 0.4)] == winners[("32x3", 0.8)] == "thin"
    assert winners[("12x14", 0.4)] == "thin"  # the default grid gives this setup the 16x3 cell
    step = next(s for s in summary["time_steps"] if (s["law"], s["h_m"]) == ("thin", 0.001))
    assert step["cfl"] == [0.4, 0.8] and step["outflow"] == pytest.approx(0.01)


def test_the_rheometer_law_fits_every_lotion_curve_and_is_shear_thinning():
    tau_y, K, n = rheometer_law(CURVES, (0.3, 30.0))
    assert 0.3 < n < 0.6 and tau_y > 0 and K > 0
    for path in CURVES:
        assert log_rms_error(tau_y, K, n, read_flow_curve(path).within((0.3, 30.0))) < 0.05


def test_a_study_of_a_real_recording_refines_the_flow_and_resumes_from_its_store(tmp_path, monkeypatch):
    setup = read_setup(SHARED / "virheometry" / "ref_Lotion_2.5_5.1_1", scale=0.5)
    laws = {"rheometer": rheometer_law(CURVES, (0.3, 30.0))}
    # 4 and 5 cells over the 2.5 cm height give the same cell (the 4 cm depth in 8 cells): simulated once
    cases = study_cases([setup], laws, [4, 5, 7], [0.8], (SIMULATION["cells_per_height"], SIMULATION["cells_across"]))
    assert [c.grids for c in cases] == [("4x3", "5x3"), ("7x3",), ("6x8",)]
    store = EvaluationStore(tmp_path / "study.evaluations.json", engine_fingerprint())
    rows = run(cases, SIMULATION, 0.5, store, workers=1)
    coarse, fine, default = rows
    assert coarse["h_m"] > default["h_m"] > fine["h_m"]
    assert coarse["recorded_outflow_px"] == fine["recorded_outflow_px"] and coarse["recorded_outflow_px"][-1] > 0
    # a coarse grid holds the material back along the sticky floor and walls: refined, more of it flows
    assert coarse["outflow"][-1] < default["outflow"][-1] < fine["outflow"][-1]
    assert coarse["outflow_px"][-1] < fine["outflow_px"][-1] <= fine["recorded_outflow_px"][-1]
    assert fine["loss_px"] < coarse["loss_px"]
    assert np.all(np.diff(fine["front_m"]) >= 0) and fine["times_s"][0] == pytest.approx(1 / 24)

    def never(*args):
        raise AssertionError("a stored simulation was run again")

    monkeypatch.setattr(convergence, "measure", never)
    resumed = run(cases, SIMULATION, 0.5, EvaluationStore(store.path, store.fingerprint), workers=1)
    assert resumed == rows
    # a law that another machine's SciPy fits a few parts in 1e8 apart is the same study
    def nudged(share: float) -> list:
        return [dataclasses.replace(c, law=tuple(v * (1 + share) for v in c.law)) for c in cases]

    assert len(run(nudged(3e-8), SIMULATION, 0.5, EvaluationStore(store.path, store.fingerprint), workers=1)) == 3
    with pytest.raises(AssertionError, match="run again"):  # another law is another study
        run(nudged(1e-4), SIMULATION, 0.5, EvaluationStore(store.path, store.fingerprint), workers=1)
    with pytest.raises(AssertionError, match="run again"):  # another engine's records are not reused
        run(cases[:1], SIMULATION, 0.5, EvaluationStore(store.path, "another engine"), workers=1)


def test_every_simulation_setting_given_is_part_of_a_stored_records_key(tmp_path):
    store = EvaluationStore(tmp_path / "study.evaluations.json", "engine")
    case = study_cases([read_setup(SHARED / "virheometry" / "ref_Lotion_2.5_5.1_1", scale=0.5)],
                       {"given": (10.0, 1.0, 1.0)}, [5], [0.8], (6, 8))[0]
    sticky = store.key(case, SIMULATION)
    assert store.key(case, {**SIMULATION, "wall_slip": None}) == sticky
    assert store.key(case, {**SIMULATION, "wall_slip": 1e4}) != sticky
    assert store.key(case, {**SIMULATION, "lam": 1e5}) != sticky
    assert store.key(case, {**SIMULATION, "cfl": 0.2}) == sticky  # the case's own step, not the config's
    # a recording read at another frame rate is another study, its frames compared that far apart
    thirty = dataclasses.replace(case, fps=30.0)
    assert store.key(thirty, SIMULATION) != sticky
    compared = convergence.Targets(0.5)[json.dumps([thirty.folder, thirty.fps, thirty.simulation(SIMULATION)])]
    assert compared.args[0].frame_steps * OFFSET_STEP == pytest.approx(1 / 30)


def test_studies_sharing_a_store_keep_each_others_simulations(tmp_path):
    path = tmp_path / "shared.evaluations.json"
    coarse, fine = study_cases([read_setup(SHARED / "virheometry" / "ref_Lotion_2.5_5.1_1", scale=0.5)],
                               {"given": (10.0, 1.0, 1.0)}, [4, 7], [0.8], (6, 8))[:2]
    first, second = EvaluationStore(path, "engine"), EvaluationStore(path, "engine")  # both opened on no file
    first.put(coarse, SIMULATION, {"loss_px": 1.0})
    second.put(fine, SIMULATION, {"loss_px": 2.0})
    later = EvaluationStore(path, "engine")
    assert later.get(coarse, SIMULATION) == {"loss_px": 1.0} and later.get(fine, SIMULATION) == {"loss_px": 2.0}
    assert second.get(coarse, SIMULATION) == {"loss_px": 1.0}  # merged at its write


def test_a_studys_records_replay_with_the_same_engine_and_keep_those_of_others(tmp_path, monkeypatch):
    path = tmp_path / "losses.json"
    records = StudyRecords(path)
    records["a"] = {"loss_px": 1.0}
    records.save()
    assert StudyRecords(path) == {"a": {"loss_px": 1.0}}
    monkeypatch.setattr(convergence, "engine_fingerprint", lambda: "another engine")
    other = StudyRecords(path)
    assert other == {}  # nothing replays under another engine
    other["a"] = {"loss_px": 2.0}
    other.save()
    monkeypatch.undo()
    assert StudyRecords(path) == {"a": {"loss_px": 1.0}}  # the first engine's records are kept beside


def run_command_line(monkeypatch, tmp_path: Path, extra_args: list[list[str]]) -> list[tuple[dict, Path]]:
    """The command line on Lotion's short setup once per list of extra arguments, its simulations stubbed: the
    settings and the store each run was given."""
    given = []

    def keep(cases, simulation, scale, store, workers):
        given.append((simulation, store.path))
        return []

    monkeypatch.setattr(convergence, "run", keep)
    monkeypatch.setattr(convergence, "summarize", lambda rows, default_h: {})
    argv = ["--material", "Lotion", "--setups", "ref_Lotion_2.5_5.1_1", "--grids", "8",
            "--out", str(tmp_path / "a.json")]
    for extra in extra_args:
        convergence.main([*argv, *extra])
    return given


def test_the_command_line_uses_the_store_given_or_the_one_beside_its_output(tmp_path, monkeypatch):
    given = run_command_line(monkeypatch, tmp_path, [[], ["--store", str(tmp_path / "shared.json")]])
    used = [store for _, store in given]
    assert used == [tmp_path / "a.evaluations.json", tmp_path / "shared.json"]


def test_the_moduli_given_replace_the_configs_in_every_simulation(tmp_path, monkeypatch):
    given = run_command_line(monkeypatch, tmp_path, [[], ["--mu", "1e3"], ["--mu", "50", "--lam", "2e5"]])
    simulated = [simulation for simulation, _ in given]
    default = simulated[0]
    assert simulated[1] == {**default, "mu": 1e3}
    assert simulated[2] == {**default, "mu": 50.0, "lam": 2e5}


def test_the_engine_text_leaves_out_comments_and_docstrings_only():
    source = 'def f(x):\n    """Doc, mu <= 1 \u00b5."""\n    y = "# kept"  # dropped \u2264\n\n    return x + y\n'
    assert code_text(source) == 'def f(x):\n    y = "# kept"\n    return x + y'
    assert code_text(source.replace("Doc", "A new doc").replace("dropped", "new comment")) == code_text(source)
    assert code_text(source.replace("x + y", "y + x")) != code_text(source)


def test_grids_laws_and_moduli_are_parsed_or_refused_with_the_text():
    assert grid("12") == 12 and law("4.5,7,0.47") == (4.5, 7.0, 0.47)
    with pytest.raises(ArgumentTypeError, match="'12x14'"):
        grid("12x14")
    with pytest.raises(ArgumentTypeError, match="at least 3"):
        grid("2")
    with pytest.raises(ArgumentTypeError, match=r"'4\.5,7'"):
        law("4.5,7")
    assert modulus("1e5") == 1e5
    for text in ("0", "-1e4", "nan", "inf", "stiff"):
        with pytest.raises(ArgumentTypeError, match=f"'{text}'"):
            modulus(text)


def test_a_setup_the_material_lacks_is_refused_with_the_setups_it_has(tmp_path, capsys):
    out = tmp_path / "study.json"
    with pytest.raises(SystemExit):
        convergence.main(["--material", "Lotion", "--setups", "ref_Lotion_9.9_9.9_1", "--grids", "8",
                          "--out", str(out)])
    error = capsys.readouterr().err
    assert "ref_Lotion_9.9_9.9_1" in error and "ref_Lotion_7.0_7.0_2" in error and not out.exists()
