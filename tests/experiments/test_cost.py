"""The cost estimate before a run: its per-step tape memory is the simulator's own, it grows as the grid, the
particles, the steps and the images do, and a run over the limits is refused with the limit and how to raise it."""

import copy
from pathlib import Path

import pytest
import torch
import yaml

from rheo.config import ConfigError, load_schema, validated
from rheo.experiments import cost
from rheo.experiments.cost import check_cost, experiment_cost
from rheo.experiments.scene import simulator

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = load_schema(ROOT / "workflow/schemas/experiment.schema.yaml")


def tiny(**changes) -> dict:
    exp = yaml.safe_load((ROOT / "config/experiments/tiny.yaml").read_text())
    for section, values in changes.items():
        exp[section].update(values)
    return validated(copy.deepcopy(exp), SCHEMA, "tiny.yaml")


def test_the_tape_memory_per_step_is_the_simulators_own():
    exp = tiny()
    sim = simulator(exp, exp["simulation"]["resolution"], dtype=torch.float32)
    particles = 1234
    estimated = particles * cost.TAPE_PARTICLE_BYTES + sim.resolution**3 * cost.TAPE_NODE_BYTES
    assert estimated == sim.bytes_per_step(particles)


def test_the_estimate_grows_with_the_grid_the_steps_and_the_images():
    small_images = {"width": 16, "height": 16}
    base = experiment_cost(tiny(cameras=small_images))
    finer = experiment_cost(tiny(cameras=small_images, simulation={"resolution": 32}))
    longer = experiment_cost(tiny(cameras=small_images, simulation={"substeps": 170}))
    # twice the cells per axis: eight times the particles and the nodes; ten times the steps, ten times the time
    assert finer.seconds / base.seconds == pytest.approx(8.0, rel=0.05)
    assert longer.seconds / base.seconds == pytest.approx(10.0, rel=0.05)
    base, wider = experiment_cost(tiny()), experiment_cost(tiny(cameras={"width": 3200, "height": 2400}))
    assert wider.memory_bytes == pytest.approx(100 * base.memory_bytes, rel=0.01)  # the renderer drives both
    assert "renderer" in wider.memory_driver and "3200 x 2400" in wider.memory_driver


def test_a_run_over_the_limits_is_refused_with_the_limit_and_how_to_raise_it():
    check_cost(experiment_cost(tiny()), {"memory_gb": None, "hours": 24.0}, "tiny.yaml")
    huge = experiment_cost(tiny(simulation={"resolution": 256, "substeps": 2000}))
    with pytest.raises(ConfigError, match=r"^tiny\.yaml: would take about [\d,]+ h on the CPU \(the fit's .* a 256\^3 "
                                          r"grid.*above the limit of 24 h; .*--config 'limits=\{hours: \d+\}'"):
        check_cost(huge, {"memory_gb": None, "hours": 24.0}, "tiny.yaml")
    wide = experiment_cost(tiny(cameras={"width": 8192, "height": 8192}))
    with pytest.raises(ConfigError, match=r"would need about [\d.,]+ GB of memory \(the lab's renderer: 3 cameras of "
                                          r"8192 x 8192 px.*above the limit of 1 GB.*limits=\{memory_gb: \d+\}"):
        check_cost(wide, {"memory_gb": 1.0, "hours": 24.0}, "tiny.yaml")


def test_an_experiment_that_simulates_nothing_known_in_advance_has_no_estimate():
    assert experiment_cost({"name": "calibration_only", "kind": "real"}) is None
