"""The real dam-break rules in a scratch copy of the workflow: one setup imported, one setup and a material fitted
with a small search and the material's page written, the summary's plan over all twelve materials, and its table from
twelve given fits, and the fits' page without the diagnoses."""

import csv
import glob
import json
import re
import shutil

import numpy as np
import pytest

from rheo.experiments.rheometer import log_rms_error, read_flow_curve
from tests.conftest import table_cells


def test_a_setup_is_imported_and_fitted(workflow):
    (workflow.root / "quick.yaml").write_text(
        "virheometry:\n  simulation: {cells_per_height: 4, cells_across: 4, max_offset: 0.05}\n"
        "  fit: {shares: [0.5], evaluations: 2, starts: 1, rounds: 1, flow_index_searches: [0.7, 1.0],\n"
        "        flow_index_evaluations: 2, stress_evaluations: 2}\n")
    run = workflow.run("results/virheometry/Carbonara/fit_setup2/params.json",
                       "results/virheometry/Carbonara/report.html", "--configfile", "quick.yaml")
    assert run.returncode == 0, run.stderr[-3000:]
    # the material's page leads with its law and the flow curve, which is also a figure of its own
    page = (workflow.root / "results/virheometry/Carbonara/report.html").read_text()
    assert page.index("Recovered law") < page.index("<h2>Flow curve") < page.index("<h2>Flow index") \
        < page.index("<h2>Setups")
    assert "Elastic constants: mu 300 Pa (held), lam 1e+04 Pa (held)" in page
    assert (workflow.root / "results/virheometry/Carbonara/flow_curve.png").stat().st_size > 10_000
    setup = json.loads((workflow.root / "results/virheometry/setups/ref_Carbonara_2.0_2.5_2/setup.json").read_text())
    assert setup["units"].startswith("SI") and setup["height"] == 0.02 and setup["frames"] == 8
    assert setup["camera_check"]["cuboid_on_silhouette"] > 0.95
    fit = json.loads((workflow.root / "results/virheometry/Carbonara/fit_setup2/params.json").read_text())
    for key in ("tau_y_Pa", "K_Pa_s_n", "n"):
        low, high = fit[key]["interval"]
        assert low <= fit[key]["value"] <= high and isinstance(fit[key]["determined"], bool)
        assert not (any(fit[key]["interval_open"]) and fit[key]["determined"])  # an open interval bounds nothing
    # n's profile: the best loss at each searched index, none below the estimate's; n's interval holds every index
    # whose best law lies within the tolerance
    profile = fit["flow_index_profile"]
    assert profile["n"] == [0.7, 1.0] and min(profile["loss_px"]) >= fit["loss_px"]
    for n, loss in zip(profile["n"], profile["loss_px"], strict=True):
        if loss <= (1.0 + fit["tolerance"]) * fit["loss_px"]:
            assert fit["n"]["interval"][0] <= n <= fit["n"]["interval"][1]
    spread = fit["within_tolerance"]
    assert spread["evaluations"] >= 1 and isinstance(spread["ridge"], bool)
    for key in ("tau_y_Pa", "K_Pa_s_n", "n"):
        assert spread[key][0] <= fit[key]["value"] <= spread[key][1]
    (name, result), = fit["setups"].items()
    assert name == "ref_Carbonara_2.0_2.5_2" and len(result["silhouette_iou"]) == 8
    assert 0.0 <= result["first_frame_after_release_s"] <= 0.05
    assert (workflow.root / "results/virheometry/Carbonara/fit_setup2/frames.png").stat().st_size > 0
    with open(workflow.root / "results/virheometry/Carbonara/fit_setup2/history.csv") as f:
        phases = {row["phase"] for row in csv.DictReader(f)}
    assert {"stress", "n 0.7", "n 1"} <= phases  # the stress search and the searches at each flow index ran
    assert not list((workflow.root / "results/virheometry/Carbonara/fit_setup2").glob("*.evaluations.json"))


def test_a_fit_searches_the_shear_modulus_beside_the_flow_index_when_given_a_box(workflow):
    run = workflow.run("results/virheometry/Carbonara/fit_setup2/params.json", "--config",
                       "virheometry={simulation: {cells_per_height: 4, cells_across: 4, max_offset: 0.05}, "
                       "fit: {rounds: 1, flow_index_searches: [0.7, 1.0], flow_index_evaluations: 5, "
                       "stress_evaluations: 2, mu: [30.0, 3000.0]}}")
    assert run.returncode == 0, run.stderr[-3000:]
    fit = json.loads((workflow.root / "results/virheometry/Carbonara/fit_setup2/params.json").read_text())
    mu = fit["mu_Pa"]
    assert 30.0 <= mu["interval"][0] <= mu["value"] <= mu["interval"][1] <= 3000.0
    assert fit["elastic_constants_Pa"]["mu"] == mu["value"] and fit["n"]["interval"][0] < fit["n"]["interval"][1]
    with open(workflow.root / "results/virheometry/Carbonara/fit_setup2/history.csv") as f:
        rows = list(csv.DictReader(f))
    # the stress search holds the modulus at the simulation's 300 Pa; the flow-index searches move it
    assert [float(r["mu"]) for r in rows if r["phase"] == "stress"] == pytest.approx([300.0, 300.0])
    assert len({r["mu"] for r in rows if r["phase"] == "n 1"}) > 1


def test_the_recordings_frame_rate_is_a_setting(workflow):
    target = "results/virheometry/setups/ref_Carbonara_2.0_2.5_2/setup.json"
    run = workflow.run(target, "--config", "virheometry={fps: 30.0}")
    assert run.returncode == 0, run.stderr[-3000:]
    assert json.loads((workflow.root / target).read_text())["fps"] == 30.0
    # frames that do not lie a whole number of the fit's 1/240 s steps apart are refused, naming the setup
    other = target.replace("Carbonara_2.0_2.5_2", "Carbonara_3.7_6.4_1")
    run = workflow.run(other, "--config", "virheometry={fps: 25.0}")
    assert run.returncode != 0
    assert "ref_Carbonara_3.7_6.4_1 (virheometry.fps): 25 fps puts its frames 9.6 steps" in run.stdout + run.stderr
    # the convergence study reads the recordings at the stated rate too
    run = workflow.run("results/virheometry/Lotion/convergence.json", "-n", "--config", "virheometry={fps: 30.0}")
    assert run.returncode == 0, run.stderr[-3000:]


def test_the_summary_plans_a_joint_fit_and_a_page_per_material_and_an_import_per_setup(workflow):
    run = workflow.run("-n", "results/virheometry/summary.html")
    assert run.returncode == 0, run.stderr[-3000:]
    counts = {}
    for line in run.stdout.splitlines():  # the job-stats table: rule, count
        parts = line.split()
        if len(parts) == 2 and parts[0].startswith("virheometry_") and parts[1].isdigit():
            counts[parts[0]] = int(parts[1])
    # Lotion's page also fits each of its setups alone (virheometry.single_setup_fits); each material's diagnosis
    # starts from a Bingham fit on the frames it does not hold out
    assert counts == {"virheometry_fit": 26, "virheometry_import": 24, "virheometry_report": 12,
                      "virheometry_diagnose": 12, "virheometry_summary": 1}


# the laws (tau_y, K, n) of the base fit and of each candidate's refit in the diagnoses the summary reads
CANDIDATE_LAWS = {"base": (14.8, 0.79, 1.0), "floor_friction": (12.0, 1.1, 1.0), "shear_thinning": (7.0, 5.3, 0.53)}
# and their held-out losses (between fitted frames; last frames) on the materials that hold frames out (all but the
# last three)
HELD_OUT = {"base": (0.02, 0.04), "floor_friction": (0.015, 0.05), "shear_thinning": (0.021, 0.03)}


def held_out(fit: str, i: int) -> dict:
    """The held-out losses (px) of a fit on the i-th material."""
    between, last = HELD_OUT[fit]
    return {"held_out_loss_px": None if i > 8 else between, "forecast_loss_px": None if i > 8 else last * (1 + i / 10)}


# laws (tau_y, K, n) of three flow indices whose flow curves all pass through 20 Pa at 5 1/s
LAWS_THROUGH_20_PA_AT_5 = [[3.0, 17.0 / 5.0**0.5, 0.5], [14.0, 6.0 / 5.0, 1.0], [9.0, 11.0 / 5.0**0.8, 0.8]]


def power_law_between(curve, rate: float, low: float, high: float) -> float:
    """A flow curve's stress at ``rate`` on the power law through its points at the rates ``low`` and ``high``."""
    at_low, at_high = (curve.stress[curve.shear_rate == r][0] for r in (low, high))
    return at_low * (rate / low) ** (np.log(at_high / at_low) / np.log(high / low))


def test_the_summary_tables_every_materials_fit_and_links_its_page(workflow):
    materials = sorted({p.name.split("_")[1] for p in (workflow.root.parent / "shared/data/virheometry").glob("ref_*")})
    for i, material in enumerate(materials):
        fit_dir = workflow.root / f"results/virheometry/{material}/fit"
        fit_dir.mkdir(parents=True)
        law = {key: {"value": value * (1 + i), "interval": [value, value * (2 + i)], "determined": i % 2 == 0,
                     "interval_open": [False, i == 3]} for key, value in (("tau_y_Pa", 10.0), ("K_Pa_s_n", 1.0))}
        law["n"] = {"value": 0.5 + 0.05 * i, "interval": [0.4, 1.5], "determined": True,
                    "interval_open": [False, False]}
        (fit_dir / "params.json").write_text(json.dumps({
            **law, "setups": {"a": {"silhouette_iou": [0.9, 0.96]}, "b": {"silhouette_iou": [0.98]}},
            "shear_rate_band_per_s": [0.1 * (i + 1), 20.0],
            "within_tolerance": {"ridge": i == 5, "laws": LAWS_THROUGH_20_PA_AT_5[:3 if i % 2 == 0 else 2]},
            "runtime_s": 60.0 * (i + 1)}))
        (fit_dir.parent / "report.html").write_text(f"<html>{material}</html>")
        (fit_dir.parent / "diagnosis").mkdir()
        refit = {"floor_friction": 0.03} if i == 0 else {}  # the chosen candidate's, by its name
        (fit_dir.parent / "diagnosis/diagnosis.json").write_text(json.dumps({
            "verdict": f"verdict {i}", "chosen": "floor_friction" if i == 0 else None, "runtime_s": 600.0 * (i + 1),
            "evidence": 6.0,
            "loss_before_after_px": {"held_out": [0.02, 0.01 if i == 0 else 0.02], "forecast": [0.04, 0.04]},
            "flow_curve_rms_log10": {"band_per_s": [0.5, 20.0],
                                     "by_curve": {"a": {"base fit": 0.1, **refit}, "b": {"base fit": 0.2, **refit}}},
            "base": {"values": dict(zip(("tau_y_Pa", "K_Pa_s_n", "n"), CANDIDATE_LAWS["base"], strict=True)),
                     **held_out("base", i)},
            "candidates": [{"effect": effect, "delta_criterion": change, **held_out(effect, i),
                            "values": dict(zip(("tau_y_Pa", "K_Pa_s_n", "n"), CANDIDATE_LAWS[effect], strict=True))}
                           for effect, change in ((("floor_friction", -8.0),) if i % 2 == 0 else ())
                           + (("shear_thinning", 1.5),)]}))
    run = workflow.run("results/virheometry/summary.html", "--allowed-rules", "virheometry_summary")
    assert run.returncode == 0, run.stderr[-3000:]
    page = (workflow.root / "results/virheometry/summary.html").read_text()
    rows = page.split("</table>")[0].split("<tr>")[2:]  # the first table's, after the header
    assert len(materials) == 12 and len(rows) == 12
    for i, (material, row) in enumerate(zip(materials, rows, strict=True)):
        cells = table_cells(row)
        assert cells[0] == material
        for cell, value in zip(cells[1:3], (10.0, 1.0), strict=True):  # open ends marked, undetermined starred
            assert cell == (f"{value * (1 + i):.3g} [{value:.3g}, {'>' if i == 3 else ''}{value * (2 + i):.3g}]"
                            + ("" if i % 2 == 0 else " *"))
        assert cells[3] == f"{0.5 + 0.05 * i:.3g} [0.4, 1.5]"
        assert cells[4] == "0.930, 0.980"  # the mean IoU of each setup
        assert cells[5] == f"{0.1 * (i + 1):.2g}-20"
        # against the rheometer's curves over the band, where the material has some (Lotion's four)
        law = (10.0 * (1 + i), 1.0 * (1 + i), 0.5 + 0.05 * i)
        curves = [read_flow_curve(p) for p in sorted(glob.glob(
            str(workflow.root.parent / f"shared/data/rheometer/{material}_*.csv")))]
        assert len(curves) == (4 if material == "Lotion" else 0)
        assert cells[6] == (", ".join(f"{log_rms_error(*law, c.within((0.1 * (i + 1), 20.0))):.3f}" for c in curves)
                            or "-")
        # where the laws within the tolerance agree best: three flow indices through 20 Pa at 5 1/s; two say nothing
        if i % 2:
            assert cells[7] == "-"
        else:
            low, high, rate, rheometer = re.fullmatch(
                r"(\S+)-(\S+) Pa at (\S+) 1/s, 3 laws(?: \(rheometer (\S+)-\S+ Pa\))?", cells[7]).groups()
            assert [float(low), float(high), float(rate)] == pytest.approx([20.0, 20.0, 5.0], rel=0.03)
            if curves:  # the lowest of the curves there, on the power law through their points at 3.98 and 6.31 1/s
                assert float(rheometer) == pytest.approx(min(power_law_between(c, 5.0, 3.98, 6.31) for c in curves),
                                                         rel=0.01)
        assert cells[8] == ("yes" if i == 5 else "no") and cells[9] == f"{i + 1:.1f}"  # ridge, runtime (min)
        # the diagnosis: verdict, held-out losses (before / after where the refit changed them), the refit's error
        # against the rheometer, runtime (min)
        assert cells[10:] == [f"verdict {i}", "0.02 / 0.01; 0.04" if i == 0 else "0.02; 0.04",
                             "0.030, 0.030" if i == 0 else "-", f"{10 * (i + 1)}"]
        assert f"<a href='{material}/report.html'>{material}</a>" in page
        assert f"<a href='{material}/diagnosis/report.html'>{material}</a>" in page
    assert page.count("<img") == 1  # the flow curves of all materials in one plot
    # what each candidate did: the change of criterion, the refit's n and, for Lotion, its worst rheometer error
    candidates = page.split("What each candidate effect did")[1].split("</table>")[0].split("<tr>")
    assert table_cells(candidates[1].replace("<th>", "<td>").replace("</th>", "</td>")) == [
        "material", "base fit", "floor friction", "shear thinning"]
    for i, (material, row) in enumerate(zip(materials, candidates[2:-1], strict=True)):
        def law_text(effect: str, material: str = material) -> str:
            curves = [read_flow_curve(p) for p in sorted(glob.glob(
                str(workflow.root.parent / f"shared/data/rheometer/{material}_*.csv")))]
            worst = max((log_rms_error(*CANDIDATE_LAWS[effect], c.within((0.5, 20.0))) for c in curves), default=None)
            return f"n {CANDIDATE_LAWS[effect][2]:.2f}" + ("" if worst is None else f", RMS {worst:.3f}")

        # held-out changes against the base fit's 0.02 px (between) and 0.04 (1 + i / 10) px (last frames)
        changes = {"floor_friction": "between -25 %, last +25 %; ", "shear_thinning": "between +5 %, last -25 %; "}
        if i > 8:
            changes = dict.fromkeys(changes, "")
        assert table_cells(row) == [material, law_text("base"),
                                    f"-8.0; {changes['floor_friction']}{law_text('floor_friction')}"
                                    if i % 2 == 0 else "-",
                                    f"+1.5; {changes['shear_thinning']}{law_text('shear_thinning')}"]
    assert "RMS" in candidates[2 + materials.index("Lotion")]
    # of the materials with frames held out, those whose last frames a refit predicts better: shear thinning's on all
    # nine, floor friction's on none of the five it was tried on
    assert table_cells(candidates[-1]) == ["last frames predicted 1 % better or more", "", "0 of 5", "9 of 9"]
    # the fits' page: the same table without the diagnoses, which it does not wait for
    shutil.rmtree(workflow.root / "results/virheometry/Lotion/diagnosis")
    run = workflow.run("results/virheometry/fits.html", "--allowed-rules", "virheometry_fits")
    assert run.returncode == 0, run.stderr[-3000:]
    fits = (workflow.root / "results/virheometry/fits.html").read_text()
    assert [table_cells(r) for r in fits.split("<tr>")[2:]] == [table_cells(r)[:10] for r in rows]
    assert "diagnosis" not in fits
    assert fits.count("<img") == 1 and "<a href='Lotion/report.html'>Lotion</a>" in fits


def test_the_convergence_study_writes_its_page_and_resumes_from_its_store(workflow):
    (workflow.root / "quick.yaml").write_text(
        "virheometry:\n  simulation: {cells_per_height: 4, cells_across: 4}\n"
        "  convergence: {grids: [4, 7, 9], cfls: [0.8]}\n")
    target = "results/virheometry/Lotion/convergence.html"
    run = workflow.run(target, "--configfile", "quick.yaml")
    assert run.returncode == 0, run.stderr[-3000:]
    study = json.loads((workflow.root / "results/virheometry/Lotion/convergence.json").read_text())
    assert set(study["laws"]) == {"bingham", "rheometer"} and study["laws"]["rheometer"][2] < 0.6
    # the 2.5 cm setup gets three cells (4 cells over its height and the default grid give the same one), the
    # 7 cm setup two (4 and 7 cells over its height and the default grid give the 4 cm depth in 4 cells)
    cells = {setup: len({r["h_m"] for r in study["rows"] if r["setup"] == setup}) for setup in study["default_h_m"]}
    assert cells == {"ref_Lotion_2.5_5.1_1": 3, "ref_Lotion_7.0_7.0_2": 2}
    assert len(study["rows"]) == 2 * (3 + 2) and {c["grid"] for c in study["contests"]} == {"4x3", "7x3", "9x3", "4x4"}
    page = (workflow.root / target).read_text()
    assert page.count("<img") == 6 and "Which law comes closer" in page and "frame by frame" in page
    rerun = workflow.run(target, "--configfile", "quick.yaml", "-f")
    assert rerun.returncode == 0, rerun.stderr[-3000:]
    log = (workflow.root / "logs/virheometry/Lotion/convergence.log").read_text()
    assert "10 of 10 simulations stored; 0 to run" in log
    assert json.loads((workflow.root / "results/virheometry/Lotion/convergence.json").read_text())["rows"] == \
        study["rows"]
