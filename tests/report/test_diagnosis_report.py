"""The diagnosis page's verdict: where no candidate is named, the one that came closest, with what its refit did to
the held-out frames."""

from rheo.report.diagnosis import closest_text, section


def candidate(effect: str, change: float, between: float | None, last: float | None) -> dict:
    return {"effect": effect, "title": effect.replace("_", " "), "decoy": False, "delta_criterion": change,
            "loss_px": 0.01, "held_out_loss_px": between, "forecast_loss_px": last, "values": {"tau_y_Pa": 10.0}}


def record(candidates: list[dict], chosen: str | None = None) -> dict:
    base = {"loss_px": 0.02, "held_out_loss_px": 0.04, "forecast_loss_px": 0.05, "values": {"tau_y_Pa": 12.0}}
    return {"chosen": chosen, "verdict": "no candidate explains the mismatch that remains", "magnitude": None,
            "evidence": 6.0, "criterion": "BIC", "mismatch": {}, "open": None, "base": base, "candidates": candidates,
            "loss_before_after_px": {"fitted": [0.02, 0.02], "held_out": [0.04, 0.04], "forecast": [0.05, 0.05]}}


def test_the_candidate_of_lowest_criterion_is_said_with_its_held_out_changes():
    diagnosis = record([candidate("air_drag", -1.0, 0.05, 0.05), candidate("floor_friction", -3.4, 0.03, 0.06),
                        candidate("thixotropy", 2.0, 0.01, 0.01)])
    # floor friction: 0.03 against the base fit's 0.04 between fitted frames, 0.06 against 0.05 on the last ones
    expected = ("<p>Closest to being named: floor friction, criterion -3.4 (named below -6); its refit's held-out "
                "loss between fitted frames -25 %, last frames +20 %.</p>")
    assert closest_text(diagnosis) == expected
    assert expected in section(diagnosis)


def test_held_out_frames_that_are_not_there_are_left_out_and_a_named_effect_needs_no_closest():
    assert closest_text(record([candidate("floor_friction", -2.0, None, None)])) == (
        "<p>Closest to being named: floor friction, criterion -2.0 (named below -6).</p>")
    assert closest_text(record([candidate("floor_friction", 0.5, 0.03, 0.04)])) == (
        "<p>No candidate lowers the criterion.</p>")
    assert closest_text(record([candidate("floor_friction", -8.0, 0.03, 0.04)], chosen="floor_friction")) == ""
    assert closest_text(record([])) == ""


def test_a_name_the_recheck_withdrew_is_closest_below_the_rechecks_criterion():
    diagnosis = record([candidate("thixotropy", -24.7, 0.03, 0.04)])
    diagnosis["recheck"] = {"delta_criterion": -26.2, "loss_px": 0.0104, "held_out_loss_px": 0.031,
                            "forecast_loss_px": 0.041, "values": {"tau_y_Pa": 23.5}}
    assert closest_text(diagnosis).startswith("<p>Closest to being named: thixotropy, criterion -24.7 (named below "
                                              "-32.2); ")
    html = section(diagnosis)
    assert "<td>base model, refitted from the winner&#x27;s law</td><td>-26.20</td><td>0.0104</td>" in html
    assert "and below the base model refitted from its law." in html
    assert "refitted from" not in section(record([candidate("thixotropy", -2.0, 0.03, 0.04)]))
