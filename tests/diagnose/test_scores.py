"""The concealed benchmark's scores, counted by hand on five made-up cases."""

import json

import pytest

from rheo.diagnose.scores import case_table, main, suite_scores, targets, truth_label

CANDIDATES = ["floor_friction", "thixotropy", "gravity_tilt"]


def _case(concealed: list[str], named: str, held: float | None, last: float | None, bias: list[float],
          shown: bool | None, open_drag: dict | None = None) -> dict:
    return {"concealed": [{"effect": e, "magnitude": 1.0} for e in concealed], "named": named,
            "held_out_change_pct": held, "forecast_change_pct": last, "core_bias_pct": bias, "shown": shown,
            "open_drag": open_drag, "runtime_min": 10.0}


RECORDS = [dict(record, case=f"c{i}") for i, record in enumerate([
    _case(["floor_friction"], "floor_friction", -50.0, -40.0, [20.0, 5.0], True),  # right, shown
    _case(["thixotropy", "floor_friction"], "floor_friction", -10.0, None, [30.0, 35.0], True),  # the second: right
    _case(["thixotropy"], "gravity_tilt", -35.0, -31.0, [10.0, 8.0], False),  # a wrong name, not shown
    _case([], "none", None, None, [0.0, 0.0], None, {"explains": True}),  # null, nothing named
    _case(["camera_roll"], "thixotropy", -60.0, -20.0, [0.0, 0.0], None, None),  # outside: a false alarm
])]


def test_the_scores_count_each_kind_of_case_as_counted_by_hand():
    scores = suite_scores(RECORDS, CANDIDATES)
    assert (scores["cases"], scores["with_effect"], scores["null"], scores["outside"]) == (5, 3, 1, 1)
    assert (scores["top1"], scores["shown"], scores["shown_named"]) == (2, 2, 2)
    assert (scores["wrong_names"], scores["false_alarms"]) == (1, 1)
    # named in four cases; held out between frames down >= 30 % in three, the last frames in two
    assert (scores["named"], scores["held_out_down_30pct"], scores["forecast_down_30pct"]) == (4, 3, 2)
    assert scores["core_bias_mean_pct"] == pytest.approx([20.0, 16.0]) and scores["core_bias_reduced"] == 2
    assert (scores["open_drag_fitted"], scores["open_drag_explains"], scores["runtime_min"]) == (1, 1, 50.0)
    assert [truth_label(r, CANDIDATES) for r in RECORDS] == ["floor_friction", "thixotropy", "thixotropy", "none",
                                                             "outside"]


def test_each_target_says_whether_it_holds():
    met = [holds for _, _, holds in targets(suite_scores(RECORDS, CANDIDATES))]
    # top-1 on shown 2 of 2; a false alarm; held out 3 of 4 and 2 of 4 named; mean bias 20 -> 16 %
    assert met == [True, False, False, False, True]
    nothing = [holds for _, _, holds in targets(suite_scores(RECORDS[3:4], CANDIDATES))]
    assert nothing == [None, True, None, None, None]


def test_the_command_scores_a_stored_summary_with_its_candidates(tmp_path, capsys):
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"code_version": "abc", "suite": {"seed": 3}, "by_case": RECORDS}))
    out = tmp_path / "scores.json"
    main([str(summary), "--candidates", *CANDIDATES, "--out", str(out)])
    assert "NOT met" in capsys.readouterr().out
    stored = json.loads(out.read_text())
    assert stored["scores"]["top1"] == 2 and stored["suite"] == {"seed": 3}
    assert [t["met"] for t in stored["targets"]] == [True, False, False, False, True]
    # without --candidates the configuration's defaults, among which thixotropy, floor friction and the tilt
    main([str(summary), "--out", str(out)])
    assert json.loads(out.read_text())["scores"] == stored["scores"]


def test_the_cases_table_has_a_row_per_case_as_stored():
    table = case_table(RECORDS).splitlines()
    assert len(table) == 2 + len(RECORDS) and table[1] == "|---|---|---|---|---|---|---|"
    assert table[3] == "| c1 | thixotropy 1, floor_friction 1 | yes | floor_friction | -10 % | - | 30.0 -> 35.0 |"
    assert table[5] == "| c3 | none | - | none | - | - | 0.0 -> 0.0 |"
    with_modulus = case_table([dict(RECORDS[0], shear_modulus_Pa=[300.0, 146.0])]).splitlines()
    assert with_modulus[0].endswith("| shear modulus, fit / lab (Pa) |") and with_modulus[2].endswith("| 300 / 146 |")


def test_a_file_that_is_no_summary_gets_one_error_naming_it(tmp_path, capsys):
    bad = tmp_path / "summary.json"
    bad.write_text("{}")
    with pytest.raises(SystemExit):
        main([str(bad)])
    assert f"{bad}: not a concealed benchmark's summary.json" in capsys.readouterr().err
