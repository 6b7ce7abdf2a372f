"""The comparison of recovered laws with a material's rheometer curves: a row per law, a column per curve, the
errors computed over the shear-rate band only; the diagnoses' table of what each candidate did."""

from pathlib import Path

import numpy as np

from rheo.experiments.rheometer import read_flow_curve
from rheo.report.virheometry import candidates_table, rheometer_comparison
from tests.conftest import table_cells

RHEOMETER = Path(__file__).resolve().parents[3] / "shared/data/rheometer"


def test_every_law_is_a_row_with_its_error_against_every_curve_over_the_band():
    curves = [read_flow_curve(p) for p in sorted(RHEOMETER.glob("Lotion_*.csv"))]
    laws = {"bingham": (14.8, 0.79, 1.0), "shear_thinning": (7.0, 5.3, 0.53)}
    band = (0.5, 20.0)
    table, errors = rheometer_comparison(laws, curves, band)
    rows = table.split("<tr>")[2:]
    assert len(curves) == 4 and len(rows) == len(laws)
    for (label, (tau_y, K, n)), row in zip(laws.items(), rows, strict=True):
        cells = table_cells(row)
        assert cells[:4] == [label.replace("_", " "), f"{tau_y:.3g}", f"{K:.3g}", f"{n:.3g}"]  # an effect in words
        for curve, cell in zip(curves, cells[4:], strict=True):
            inside = (curve.shear_rate >= band[0]) & (curve.shear_rate <= band[1])
            law = tau_y + K * curve.shear_rate[inside] ** n
            expected = np.sqrt(np.mean(np.log10(law / curve.stress[inside]) ** 2))
            assert abs(errors[curve.name][label] - expected) < 1e-12
            assert cell == f"{expected:.3f}"
    # the rheometer's own Herschel-Bulkley fit lies closer to its curves than the Bingham line does
    assert all(e["shear_thinning"] < e["bingham"] for e in errors.values())
    # a band that holds none of a curve's points gives no error rather than one over the wrong points
    _, outside = rheometer_comparison(laws, curves, (1e4, 2e4))
    assert all(np.isnan(v) for e in outside.values() for v in e.values())


def test_the_candidates_last_row_counts_the_materials_whose_last_frames_a_refit_predicts_1_percent_better():
    def diagnosis(last: list[float | None]) -> dict:
        fit = {"values": {"tau_y_Pa": 10.0, "K_Pa_s_n": 1.0, "n": 1.0}, "held_out_loss_px": 0.02}
        return {"base": {**fit, "forecast_loss_px": 0.04},
                "candidates": [{**fit, "effect": effect, "delta_criterion": 1.0, "forecast_loss_px": loss}
                               for effect, loss in zip(("air_drag", "thixotropy"), last, strict=True)]}

    # last frames 0.04 px in the base fit: 0.0392 is 2 % better, 0.0399 only 0.25 %, 0.0412 3 % worse
    table = candidates_table({"a": diagnosis([0.0392, 0.0399]), "b": diagnosis([0.0412, None])}, {})
    rows = table.split("<tr>")[2:]
    assert table_cells(rows[0]) == ["a", "n 1.00", "+1.0; between +0 %, last -2 %; n 1.00",
                                    "+1.0; between +0 %, last -0 %; n 1.00"]
    assert table_cells(rows[1])[3] == "+1.0; between +0 %; n 1.00"  # no last frames to compare
    assert table_cells(rows[2]) == ["last frames predicted 1 % better or more", "", "1 of 2", "0 of 1"]
