"""The fit report's parameter table: errors against the truth, coloured only where the fit recovered the value."""

from rheo.report.fit import parameter_rows


def entry(value: float, truth: float, held: bool = False) -> dict:
    return {"value": value, "ci95": [value / 2, value * 2], "ci95_open": [held, False], "determined": not held,
            "held_at_initial_guess": held, "initial": 1.0, "truth": truth, "error": value / truth - 1}


def test_errors_are_judged_only_for_recovered_parameters():
    header, rows, classes = parameter_rows({"mu": entry(1050.0, 1000.0), "lam": entry(1500.0, 1000.0),
                                            "eta": entry(1.0, 1.0, held=True)})
    assert classes == ["good", "bad", ""]
    assert rows[0][header.index("error")] == "+5.0%" and rows[1][header.index("error")] == "+50.0%"
    assert "held at the guess" in rows[2][header.index("recovered")]
    assert rows[2][header.index("95 % interval")] == "[<0.5, 2]"
