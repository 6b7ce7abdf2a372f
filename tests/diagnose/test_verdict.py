"""The diagnosis' verdict: a named effect and the mismatch that remains after it; where none is named, the open
candidate, a drag free where and when it acts, said in words where it pays for its four parameters."""

import numpy as np
import pytest

from rheo.diagnose.candidates import CANDIDATES, OPEN_DRAG, Law
from rheo.diagnose.dam_break import Diagnosis, open_drag_words, refit_point
from rheo.diagnose.residuals import REGIONS, Location
from rheo.diagnose.selection import Refit

EVIDENCE = 6.0  # diagnose.evidence's default


def test_the_open_drag_is_the_search_vectors_last_four_entries():
    law = Law(n=1.0, open=True)
    assert law.names == ("tau_y", "K", *OPEN_DRAG)
    values, effects = law.unpack(np.r_[np.log([20.0, 2.0]), 0.0, 4.0, -1.0, 0.5])
    assert values == pytest.approx({"tau_y": 20.0, "K": 2.0, "n": 1.0})
    assert effects.physics.open_drag == (0.0, 4.0, -1.0, 0.5)
    assert Law(n=1.0).unpack(np.log([20.0, 2.0]))[1].physics.open_drag == (0.0, 0.0, 0.0, 0.0)


def test_the_words_name_the_terms_of_at_least_half_the_strongest_rate():
    assert open_drag_words(np.array([0.5, 6.0, -3.0, 1.0])) == (
        "holds the material back near the floor, late in the recording (+6 1/s); "
        "drives the flow above the floor, early in the recording (-3 1/s)")
    assert open_drag_words(np.zeros(4)) == "nowhere"


FRAMES = 20


def _lagging_front(last: int) -> dict[str, Location]:
    """A setup whose simulated front lags behind the recording's in the ``last`` frames."""
    missing = np.zeros((FRAMES, len(REGIONS)))
    missing[-last:, REGIONS.index("front")] = 100.0
    return {"setup_1": Location(np.zeros_like(missing), missing, [str(k + 1) for k in range(FRAMES)])}


def _base() -> Refit:
    """A base fit 1 px from the recording on each of the 20 frames, with two parameters."""
    return Refit("base", np.log([20.0, 2.0]), 1.0, 1.0, np.ones(FRAMES), 2)


def _diagnosis(open_distances: np.ndarray) -> Diagnosis:
    """No candidate named; the base fit's distances 1 px on 20 frames, the open drag's refit ``open_distances``."""
    base = _base()
    opened = Refit("open", np.r_[np.log([20.0, 2.0]), 0.0, 5.0, 0.0, 0.0], float(open_distances.mean()), 1.0,
                   open_distances, 6)
    return Diagnosis(Law(n=1.0), base, [], None, {}, {}, _lagging_front(5), EVIDENCE, opened)


def test_a_named_effect_comes_with_the_mismatch_that_remains_after_it():
    base = _base()
    sliding = Refit("floor_friction", np.r_[np.log([20.0, 2.0]), np.log(0.3)], 0.5, 0.5, np.full(FRAMES, 0.5), 3)
    diagnosis = Diagnosis(Law(n=1.0), base, [sliding], sliding, {}, {}, _lagging_front(15), EVIDENCE,
                          remains=_lagging_front(3))
    record = diagnosis.record()
    assert record["chosen"] == "floor_friction" and record["open"] is None
    assert record["verdict"] == ("floor friction (the material slides on the floor); the mismatch that remains after "
                                 f"it (setup_1: {_lagging_front(3)['setup_1'].words()})")
    assert "late" in record["verdict"] and record["mismatch_after"]["setup_1"]["by_region"]["front"] == 1.0


def test_an_open_drag_that_pays_for_its_rates_says_where_and_when_it_acts():
    # SSE 20 -> 5 on 20 frames: the criterion drops by 20 ln 4 = 27.7 for 4 ln 20 = 12.0 more: it explains
    explained = _diagnosis(np.full(20, 0.5))
    assert explained.open_explains
    verdict = explained.unexplained()
    assert verdict.startswith("no candidate explains the mismatch that remains (setup_1: ")
    assert verdict.endswith("; an open drag explains part of it (1 to 0.5 px): it holds the material back near the "
                            "floor, late in the recording (+5 1/s)")
    record = explained.record()
    assert record["open"]["explains"] and record["open"]["values"]["drag_floor_late"] == 5.0
    assert record["chosen"] is None and record["verdict"] == verdict
    # SSE 20 -> 12.8: a drop of 8.9, less than the 12.0 its rates cost and the evidence: it does not
    unexplained = _diagnosis(np.full(20, 0.8))
    assert not unexplained.open_explains and "open drag" not in unexplained.unexplained()
    assert not unexplained.record()["open"]["explains"]


def test_a_winning_decoy_is_said_not_named():
    base = _base()

    def tilted(distance: float) -> Refit:
        return Refit("gravity_tilt", np.r_[np.log([20.0, 2.0]), 5.0], distance, distance, np.full(FRAMES, distance), 3)

    # SSE 20 -> 5 on 20 frames: the criterion drops by 20 ln 4 - ln 20 = 24.7
    paying = Diagnosis(Law(n=1.0), base, [tilted(0.5)], None, {}, {}, _lagging_front(5), EVIDENCE).record()
    assert paying["chosen"] is None
    assert paying["verdict"].endswith("; gravity tilted along the channel (decoy) fits it better than every effect "
                                      "(criterion -24.7), so no effect's gain can be told from that of a change that "
                                      "is no physics of the material")
    # SSE 20 -> 16.2: a drop of 1.2, short of the evidence: the decoy is not mentioned
    short = Diagnosis(Law(n=1.0), base, [tilted(0.9)], None, {}, {}, _lagging_front(5), EVIDENCE).record()
    assert "decoy" not in short["verdict"]


def test_a_name_the_recheck_withdrew_is_said_with_both_criteria():
    base = _base()
    thixotropy = Refit("thixotropy", np.r_[np.log([23.7, 2.0]), np.log(0.012)], 0.5, 0.5, np.full(FRAMES, 0.5), 3)
    recheck = Refit("base", np.log([23.5, 2.0]), 0.52, 0.52, np.full(FRAMES, 0.52), 2)
    # SSE 20 -> 5: thixotropy -24.7 against the base fit; the recheck 20 ln 0.2704 = -26.2 without a parameter more
    record = Diagnosis(Law(n=1.0), base, [thixotropy], None, {}, {}, _lagging_front(5), EVIDENCE,
                       recheck=recheck).record()
    assert record["chosen"] is None and record["recheck"]["delta_criterion"] == pytest.approx(20 * np.log(0.2704))
    assert record["recheck"]["values"] == pytest.approx({"tau_y_Pa": 23.5, "K_Pa_s_n": 2.0, "n": 1.0})
    # the diagnosis ends with the base model's better law
    assert record["refit"]["values"] == record["recheck"]["values"]
    assert record["loss_before_after_px"]["fitted"] == [1.0, 0.52]
    assert record["verdict"].endswith(
        "; thixotropy (the yield stress falls as the material is sheared) fitted better (criterion -24.7) with a law "
        "the base fit had missed, and the base model refitted from that law comes within the evidence of it "
        "(criterion -26.2)")


LAWS = {"bingham_fitted_modulus": Law(n=1.0, fitted_modulus=True), "flow_index": Law(n=None)}


# a fitted flow index leaves no shear thinning to add
@pytest.mark.parametrize(("law_name", "effect"), [(name, effect) for name in LAWS for effect in sorted(CANDIDATES)
                                                  if (name, effect) != ("flow_index", "shear_thinning")])
def test_a_refit_is_found_again_from_the_values_its_record_keeps(law_name, effect):
    law = LAWS[law_name]
    low, high = CANDIDATES[effect].bounds
    material = {"tau_y": 17.0, "K": 1.3, "n": 0.6, "mu": 240.0}
    x = np.r_[np.log([material[name] for name in law.material_names]), low + 0.37 * (high - low)]
    refit = Refit(effect, x, 1.0, 1.0, np.ones(FRAMES), len(x))
    values = Diagnosis(law, _base(), [refit], None, {}, {}, _lagging_front(5), EVIDENCE).values(refit)
    assert refit_point(law, effect, values) == pytest.approx(x, rel=1e-12, abs=1e-12)
