"""The concealed-effect rules in a scratch copy of the workflow, on a coarse lab, a coarser fit and a small search: two
cases filmed in the scene's two channels, fitted jointly with the Bingham model, diagnosed and summed up."""

import json

import pytest

from rheo.experiments.concealed import anonymous

HUNG_S = 1800  # a run this long has hung (a guard, not a speed target: the benchmarks time the stages)


def quick_config(fit: str, diagnose: str) -> str:
    """A coarse lab, a coarser fit and short searches; ``fit`` and ``diagnose``: more of their settings."""
    return ("virheometry: {simulation: {max_offset: 0.05, cells_per_height: 4, cells_across: 4}}\n"
            "concealed:\n  cases: cases\n  scene: {frames: 4}\n  lab: {cells_per_height: 5, cells_across: 5}\n"
            f"  fit: {{stress_evaluations: 2, evaluations: 2, starts: 1, rounds: 1, {fit}}}\n"
            f"diagnose: {{rung_evaluations: 2, refit_evaluations: 2, {diagnose}}}\n")


def test_two_concealed_cases_are_filmed_fitted_diagnosed_and_summed_up(workflow):
    cases = workflow.root / "cases"
    cases.mkdir()
    (cases / "suite.json").write_text('{"seed": 5, "count": 2}')  # as if drawn (rheo.experiments.suite)
    (cases / "plain.yaml").write_text("name: plain\neffects: []\n")
    (cases / "sliding.yaml").write_text("name: sliding\neffects: [{effect: floor_friction, magnitude: 0.3}]\n"
                                        "release_s: 0.025\n")
    (workflow.root / "quick.yaml").write_text(quick_config(
        "shares: [0.3, 0.7], mu: null",
        "candidates: [floor_friction, gravity_tilt], open_evaluations: 8, held_out_every: 3, forecast_share: 0.25"))
    run = workflow.run("results/concealed/summary.html", "--configfile", "quick.yaml", timeout=HUNG_S)
    assert run.returncode == 0, run.stderr[-3000:]
    result = workflow.root / "results/concealed"
    truth = json.loads((result / "sliding/truth.json").read_text())
    assert truth["effect"] == "floor_friction" and truth["n"] == 1.0 and truth["release_s"] == 0.025
    fit = json.loads((result / "sliding/fit/params.json").read_text())
    # the fit searched the release: the first frame's time after it, found within a frame interval
    assert all(abs(s["first_frame_after_release_s"] - 0.025) < 1 / 24 for s in fit["setups"].values())
    assert fit["n"]["fixed"] and fit["n"]["value"] == 1.0
    assert len(fit["setups"]) == 2  # the scene's two channels, fitted jointly
    for setup in fit["setups"].values():
        # frame 3 held out between fitted ones, frame 4 (the last quarter) as a prediction
        assert len(setup["boundary_distance_px"]) == 4 and setup["held_out_loss_px"] > 0
        assert setup["forecast_loss_px"] == setup["boundary_distance_px"][3]
    diagnosis = json.loads((result / "sliding/diagnosis/diagnosis.json").read_text())
    assert {c["effect"] for c in diagnosis["candidates"]} == {"floor_friction", "gravity_tilt"}
    # a sticky-walled channel leaves adhesion nothing to act on; it was not asked for here anyway
    assert diagnosis["chosen"] in (None, "floor_friction", "gravity_tilt")
    plain = json.loads((result / "plain/diagnosis/diagnosis.json").read_text())
    if plain["chosen"] is None:  # never "nothing missing": what remains, where and when
        assert plain["verdict"].startswith(f"no candidate explains the mismatch that remains ({anonymous('plain')}_")
        assert "frames" in plain["verdict"]
    for record, name in ((plain, "plain"), (diagnosis, "sliding")):
        report = (result / name / "diagnosis/report.html").read_text()
        if record["chosen"] is None:  # the open drag, fitted from the base law without drag, ends no worse
            assert record["open"]["loss_px"] <= record["base"]["loss_px"] and "An open drag" in report
            assert set(record["open"]["values"]) >= {"drag_floor_early", "drag_bulk_late"}
        else:  # a second effect, or one no candidate models, may remain: the verdict says where and when
            assert record["open"] is None and "An open drag" not in report
            assert "the mismatch that remains after it" in record["verdict"] and record["mismatch_after"]
            # named only after the base model, refitted from the winner's law, fell short of it by the evidence
            named, = (c for c in record["candidates"] if c["effect"] == record["chosen"])
            assert named["delta_criterion"] < min(0.0, record["recheck"]["delta_criterion"]) - record["evidence"]
    # a tilt of 0 is the base model itself, and every profile starts there: no refit ends worse than the base fit
    tilt, = (c for c in diagnosis["candidates"] if c["effect"] == "gravity_tilt")
    assert tilt["loss_px"] <= diagnosis["base"]["loss_px"]
    # the profile holds the tilt at 0, then climbs either way; its lowest point is the refit
    profile = dict(tilt["profile"])
    assert profile[0.0] == pytest.approx(diagnosis["base"]["loss_px"]) and min(profile) < 0 < max(profile)
    for candidate in diagnosis["candidates"]:  # a finalist's refit from its profile's best can only go lower
        assert candidate["loss_px"] <= min(loss for _, loss in candidate["profile"])
    oracle = json.loads((result / "sliding/oracle.json").read_text())
    assert oracle["loss_px"] == pytest.approx(sum(s["loss_px"] for s in oracle["setups"].values()) / 2)
    assert oracle["held_out_loss_px"] > 0 and oracle["forecast_loss_px"] > 0
    # the recordings carry a label that says nothing of the case
    assert set(diagnosis["mismatch"]) == {f"{anonymous('sliding')}_1", f"{anonymous('sliding')}_2"}
    assert all("frames" in mismatch["words"] for mismatch in diagnosis["mismatch"].values())
    report = (result / "sliding/diagnosis/report.html").read_text()
    assert report.count("What the model leaves out") == 1 and "the law refitted there" in report
    summary = (result / "summary.html").read_text()
    assert "Confusion table" in summary and "sliding" in summary and "plain" in summary
    assert "base fit / truth in the fit" in summary and "last frames (a prediction)" in summary
    assert "shear modulus, fit / lab (Pa)" in summary
    scores = json.loads((result / "summary.json").read_text())
    assert scores["cases"] == 2 and scores["with_effect"] == 1 and scores["null"] == 1
    assert scores["top1"] == (diagnosis["chosen"] == "floor_friction")
    assert [c["case"] for c in scores["by_case"]] == ["plain", "sliding"] and scores["code_version"]
    # the modulus the fit held (the config's, as asked by mu: null) beside the lab's
    assert [c["shear_modulus_Pa"] for c in scores["by_case"]] == [[300.0, truth["mu_Pa"]]] * 2
    assert scores["suite"] == {"seed": 5, "count": 2}  # as the folder's suite.json says
    assert scores["open_drag_fitted"] == sum(d["open"] is not None for d in (plain, diagnosis))
    assert not list(result.glob("*/*/*.evaluations.json"))


def test_a_case_of_another_shear_modulus_is_fitted_and_diagnosed_with_the_modulus_free_by_default(workflow):
    cases = workflow.root / "cases"
    cases.mkdir()
    (cases / "soft.yaml").write_text("name: soft\neffects: []\nelastic: {mu: 120.0, lam: 10000.0}\n")
    (workflow.root / "quick.yaml").write_text(quick_config("shares: [0.5], moduli: [100.0, 300.0]",
                                                           "candidates: [air_drag], open_evaluations: 0"))
    run = workflow.run("results/concealed/soft/diagnosis/diagnosis.json", "--configfile", "quick.yaml",
                       timeout=HUNG_S)
    assert run.returncode == 0, run.stderr[-3000:]
    result = workflow.root / "results/concealed/soft"
    fit = json.loads((result / "fit/params.json").read_text())
    mu = fit["mu_Pa"]
    assert 30.0 <= mu["value"] <= 3000.0 and mu["interval"][0] <= mu["value"] <= mu["interval"][1]
    assert fit["elastic_constants_Pa"]["mu"] == mu["value"] and fit["elastic_constants_Pa"]["lam"] == 1e4
    history = (result / "fit/history.csv").read_text().splitlines()
    assert history[0] == "phase,evaluation,loss_px,tau_y,K,mu"
    assert len({line.split(",")[-1] for line in history[1:]}) > 3  # the survey spans the modulus too
    diagnosis = json.loads((result / "diagnosis/diagnosis.json").read_text())
    assert diagnosis["base"]["values"]["mu_Pa"] == pytest.approx(mu["value"])
    drag, = diagnosis["candidates"]
    assert drag["parameters"] == 4 and 30.0 <= drag["values"]["mu_Pa"] <= 3000.0
