"""A resumed diagnosis goes through its stored points: the base fit's shear-rate band, on which the refits' points
depend, is stored with the base fit's record."""

import json

import numpy as np

from rheo.diagnose.dam_break import stored_base
from rheo.fit.dam_break import Comparison
from rheo.fit.search import EvaluationLog


def comparison(shear_rates: np.ndarray, loss: float) -> Comparison:
    frames = 4
    return Comparison(loss=loss, held_out_loss=np.nan, forecast_loss=1.5 * loss, offset=0.0,
                      distances=np.full(frames, loss), iou=np.ones(frames), outflow_iou=np.ones(frames),
                      shear_rates=shear_rates, silhouettes=np.zeros((frames, 2, 2), bool),
                      fitted=np.ones(frames, bool))


def test_a_resumed_diagnosis_keeps_the_band_its_base_fit_was_stored_with(tmp_path):
    x_base = np.log([10.0, 1.0])
    rng = np.random.default_rng(0)
    first = [comparison(rng.uniform(0.5, 20.0, 200), 0.02), comparison(rng.uniform(1.0, 30.0, 200), 0.04)]
    record, band = stored_base(EvaluationLog(tmp_path / "log.json", "key"), x_base, first)
    rates = np.concatenate([c.shear_rates for c in first])
    assert band == [np.percentile(rates, 5), np.percentile(rates, 95)]
    assert record["loss"] == 0.03 and record["forecast_loss"] == 0.045
    assert json.loads((tmp_path / "log.json").read_text())["records"][0]["shear_rate_band"] == band
    # the base fit simulated again on another machine: its flow reaches slightly other shear rates
    again = [comparison(c.shear_rates * 1.001, c.loss * 1.01) for c in first]
    resumed = EvaluationLog(tmp_path / "log.json", "key")
    record, band_again = stored_base(resumed, x_base, again)
    assert band_again == band and record["loss"] == 0.03  # the stored ones, to the last digit
    assert len(resumed.records) == 1
    # a log stored without a band (before it was kept) gives the band of the flow simulated now
    fresh = EvaluationLog(tmp_path / "other.json", "key")
    fresh.evaluate_many(lambda _: [{"loss": 0.03}], [x_base], "base")
    assert stored_base(fresh, x_base, again)[1] == np.percentile(rates * 1.001, [5, 95]).tolist()
