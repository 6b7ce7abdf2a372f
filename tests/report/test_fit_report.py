"""The fit report: the parameter table's errors against the truth, coloured only where the fit recovered the value;
the training figure's best so far and phase lines."""

import matplotlib.pyplot as plt
import numpy as np

from rheo.report.fit import headline, parameter_rows, training_figure


def entry(value: float, truth: float, held: bool = False) -> dict:
    return {"value": value, "interval": [value / 2, value * 2], "interval_open": [held, False], "determined": not held,
            "held_at_initial_guess": held, "initial": 1.0, "truth": truth, "error": value / truth - 1}


def test_errors_are_judged_only_for_recovered_parameters():
    header, rows, classes = parameter_rows({"mu": entry(1050.0, 1000.0), "lam": entry(1500.0, 1000.0),
                                            "eta": entry(1.0, 1.0, held=True)})
    assert classes == ["good", "bad", ""]
    assert rows[0][header.index("error")] == "+5.0%" and rows[1][header.index("error")] == "+50.0%"
    assert "held at the guess" in rows[2][header.index("recovered")]
    assert rows[2][header.index("error")] == "not recovered"  # the guess was the truth: no 0 % error shown
    assert rows[2][header.index("tolerance interval")] == "[<0.5, 2]"


def test_the_best_so_far_starts_again_with_the_full_phase_and_side_by_side_searches_are_one_phase():
    """The warm-up's losses (fewer frames) are lower than any of the full phase's: its best must not stand for the
    full phase's."""
    rows = [("survey", 0.3, 0.3, 10.0), ("survey", 0.1, 0.1, 20.0), ("start 1", 0.5, 0.5, 30.0),
            ("start 2", 0.4, 0.4, 40.0), ("start 1", 0.45, 0.4, 50.0), ("surface", 0.2, 0.2, 60.0)]
    history = [{"phase": phase, "loss": loss, "best_loss": best, "mu": mu} for phase, loss, best, mu in rows]
    fig = training_figure(history, ["mu"], {})
    loss_axes, mu_axes = fig.axes[0], fig.axes[2]
    best = loss_axes.get_lines()[1].get_ydata()
    assert np.allclose(best, [0.3, 0.1, 0.5, 0.4, 0.4, 0.2])
    assert np.allclose(mu_axes.get_lines()[1].get_ydata(), [10.0, 20.0, 30.0, 40.0, 40.0, 60.0])
    changes = [line.get_xdata()[0] for line in loss_axes.get_lines()[2:]]
    assert changes == [2, 5]  # survey | starts | surface
    plt.close(fig)


def test_a_real_recordings_table_has_no_truth_and_the_headline_says_what_is_not_determined():
    fitted = {name: {**entry(value, 1.0), "determined": name != "K"} for name, value in
              [("mu", 746.0), ("lam", 1205.0), ("tau_y", 36.42), ("K", 0.0575), ("n", 1.129)]}
    for p in fitted.values():
        del p["truth"], p["error"]
    header, rows, _ = parameter_rows(fitted)
    assert "truth" not in header and "error" not in header and len(rows[0]) == len(header)
    text = headline(fitted)
    assert "τ_y = 36.4 Pa [18.2, 72.8]" in text and "K = 0.0575 Pa s^n" in text and "n = 1.13 [0.565, 2.26]" in text
    assert "does not determine K" in text
