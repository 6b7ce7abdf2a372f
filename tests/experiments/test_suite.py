"""Concealed suites drawn from a seed: reproducible, new with each seed, valid case files, names that say nothing,
magnitudes from continuous ranges, channels the scene's camera sees, and the lab's account of two effects at once."""

import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml

from rheo.config import workflow_settings
from rheo.experiments.concealed import OUTSIDE_EFFECTS, RELEASE_STEP, channel, concealed_truth, zoomed
from rheo.experiments.suite import MAGNITUDES, draw_suite

ROOT = Path(__file__).resolve().parents[2]


def test_a_seed_draws_the_same_suite_and_another_seed_a_new_one():
    assert draw_suite(3, 20) == draw_suite(3, 20)  # a drawn suite is plain data: its case files read back the same
    first, second = draw_suite(3, 20), draw_suite(4, 20)
    assert not {c["name"] for c in first} & {c["name"] for c in second}
    assert [c["law"] for c in first] != [c["law"] for c in second]


def test_drawn_cases_are_valid_and_say_nothing_of_their_effects():
    schema = yaml.safe_load((ROOT / "workflow/schemas/concealed_case.schema.yaml").read_text())
    cases = draw_suite(11, 20)
    kinds = {"none": 0, "one": 0, "two": 0, "outside": 0}
    for case in cases:
        jsonschema.validate(yaml.safe_load(yaml.safe_dump(case)), schema)  # as the case file holds it
        names = [e["effect"] for e in case["effects"]]
        kinds["outside" if set(names) & set(OUTSIDE_EFFECTS) else ("none", "one", "two")[len(names)]] += 1
        assert all(n not in case["name"] for n in MAGNITUDES) and len(case["name"]) == 9
        for effect in case["effects"]:
            low, high = MAGNITUDES[effect["effect"]]
            assert low * 0.999 <= abs(effect["magnitude"]) <= high * 1.001
        steps = case["release_s"] / RELEASE_STEP
        assert math.isclose(steps, round(steps)) and 0 < case["release_s"] <= 1 / 24 + 1e-12
        assert 5 <= case["law"]["tau_y"] <= 40 and 0.5 <= case["law"]["K"] <= 5
    assert kinds == {"none": 3, "one": 11, "two": 3, "outside": 3}


def test_the_largest_drawn_channels_stay_in_the_scene_cameras_view():
    scene = workflow_settings()["concealed"]["scene"]
    for height, width in ((0.065, 0.055), (0.03, 0.055), (0.065, 0.035)):
        setup = channel(scene, {"height": height, "width": width}, 1, "view")
        assert setup.camera.pixels(setup.cuboid_corners())[1].all()


def test_the_lab_films_two_effects_at_once_and_a_miscalibrated_camera_no_candidate_models():
    case = {"effects": [{"effect": "shear_thinning", "magnitude": 0.45}, {"effect": "thixotropy", "magnitude": 0.7},
                        {"effect": "camera_roll", "magnitude": -2.0}, {"effect": "camera_zoom", "magnitude": 0.03}],
            "law": {"tau_y": 12.0, "K": 1.5}}
    truth = concealed_truth(case, {"tau_y": 30.0, "K": 3.0})
    assert truth.law == {"tau_y": 12.0, "K": 1.5, "n": 0.45}
    assert truth.effects.physics.thixotropy == 0.7 and (truth.camera_roll, truth.camera_zoom) == (-2.0, 0.03)
    # a focal length 3 % longer puts every point 3 % farther from the principal point
    scene = workflow_settings()["concealed"]["scene"]
    camera = channel(scene, {"height": 0.04, "width": 0.04}, 1, "view").camera
    points = np.array([[0.0, 0.0, 0.0], [0.04, 0.04, 0.04], [0.1, 0.0, 0.02]])
    centre = camera.K[:2, 2]
    assert np.allclose(zoomed(camera, 0.03).project(points)[0] - centre, 1.03 * (camera.project(points)[0] - centre))
    with pytest.raises(ValueError, match="unknown effect"):
        concealed_truth({"effects": [{"effect": "magnetism", "magnitude": 1.0}]}, {"tau_y": 1.0, "K": 1.0})
