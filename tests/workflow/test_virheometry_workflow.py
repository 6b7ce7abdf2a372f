"""The real dam-break rules in a scratch copy of the workflow: one setup imported, one setup fitted with a small
search, and the summary's plan over all twelve materials."""

import csv
import json


def test_a_setup_is_imported_and_fitted(workflow):
    (workflow.root / "quick.yaml").write_text(
        "virheometry:\n  simulation: {cells_per_height: 4, cells_across: 4, max_offset: 0.05}\n"
        "  fit: {samples: 2, evaluations: 2, starts: 1, rounds: 1, flow_index_searches: [1.0],\n"
        "        flow_index_evaluations: 2, stress_evaluations: 2}\n")
    run = workflow.run("results/virheometry/Carbonara/fit_setup2/params.json", "--configfile", "quick.yaml")
    assert run.returncode == 0, run.stderr[-3000:]
    setup = json.loads((workflow.root / "results/virheometry/setups/ref_Carbonara_2.0_2.5_2/setup.json").read_text())
    assert setup["units"].startswith("SI") and setup["height"] == 0.02 and setup["frames"] == 8
    assert setup["camera_check"]["cuboid_on_silhouette"] > 0.95
    fit = json.loads((workflow.root / "results/virheometry/Carbonara/fit_setup2/params.json").read_text())
    for key in ("tau_y_Pa", "K_Pa_s_n", "n"):
        low, high = fit[key]["ci95"]
        assert low <= fit[key]["value"] <= high and isinstance(fit[key]["determined"], bool)
        assert not (any(fit[key]["ci95_open"]) and fit[key]["determined"])  # an open interval bounds nothing
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
    assert {"stress", "n 1"} <= phases  # the stress search and the search of tau_y and K at the flow index ran
    assert not list((workflow.root / "results/virheometry/Carbonara/fit_setup2").glob("*.evaluations.json"))


def test_the_summary_plans_a_joint_fit_and_a_page_per_material_and_an_import_per_setup(workflow):
    run = workflow.run("-n", "results/virheometry/summary.html")
    assert run.returncode == 0, run.stderr[-3000:]
    counts = {}
    for line in run.stdout.splitlines():  # the job-stats table: rule, count
        parts = line.split()
        if len(parts) == 2 and parts[0].startswith("virheometry_") and parts[1].isdigit():
            counts[parts[0]] = int(parts[1])
    # Lotion's page also fits each of its setups alone (virheometry.single_setup_fits)
    assert counts == {"virheometry_fit": 14, "virheometry_import": 24, "virheometry_report": 12,
                      "virheometry_summary": 1}
