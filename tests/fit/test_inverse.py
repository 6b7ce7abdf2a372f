"""The fit loop (cosine-annealed Adam phases that checkpoint and resume) and the parameter conventions."""

import math

import numpy as np
import pytest
import torch

from rheo.fit.inverse import Phase, cosine_rate, initial_guess, run_phase, simulator_parameters

TARGET = torch.tensor([1.5, -0.7], dtype=torch.float64)


def _loss(variables, frames, rng):
    noise = torch.as_tensor(rng.normal(0.0, 0.01, 2))  # a random batch, as the ray sampling is
    return ((variables - TARGET - noise) ** 2).sum()


def _describe(variables):
    return {"a": float(variables[0]), "b": float(variables[1])}


class Interrupted(Exception):
    pass


def test_an_interrupted_phase_resumes_where_it_stopped(tmp_path):
    phase = Phase("test", frames=1, iterations=30, rate=0.2)
    start = torch.zeros(2, dtype=torch.float64)
    straight, straight_history = run_phase(phase, start, _loss, _describe, tmp_path / "a.ckpt", "key", progress=False)
    assert straight_history[-1]["loss"] < 0.1 * straight_history[0]["loss"]

    calls = {"n": 0}

    def failing(variables, frames, rng):
        calls["n"] += 1
        if calls["n"] == 17:
            raise Interrupted
        return _loss(variables, frames, rng)

    checkpoint = tmp_path / "b.ckpt"
    with pytest.raises(Interrupted):
        run_phase(phase, start, failing, _describe, checkpoint, "key", progress=False)
    assert checkpoint.is_file()
    resumed, history = run_phase(phase, start, failing, _describe, checkpoint, "key", progress=False)
    assert calls["n"] == 17 + 14  # the sixteen steps done before the interruption are not repeated
    assert torch.equal(resumed, straight)
    assert [h["loss"] for h in history] == [h["loss"] for h in straight_history]
    # a checkpoint of other inputs or settings is not resumed
    other, _ = run_phase(phase, TARGET, _loss, _describe, checkpoint, "other key", progress=False)
    assert not torch.equal(other, straight)


def test_learning_rate_follows_a_cosine_from_the_base_to_a_twentieth():
    assert cosine_rate(0.1, 0, 50) == pytest.approx(0.1)
    assert cosine_rate(0.1, 25, 50) == pytest.approx(0.1 * (0.05 + 0.95 * 0.5))
    assert cosine_rate(0.1, 50, 50) == pytest.approx(0.005)


def test_pacnerf_convention_maps_to_shear_yield_stress_and_consistency():
    values = {"mu": torch.tensor(1000.0), "lam": torch.tensor(2000.0), "sigma_y": torch.tensor(50.0),
              "eta": torch.tensor(1.0)}
    params = simulator_parameters(values, "pacnerf", 1000.0).numpy()
    np.testing.assert_allclose(params, [1000.0, 50.0 / math.sqrt(3.0), 0.5, 1.0, 1000.0, 2000.0])
    rheo = simulator_parameters({"mu": torch.tensor(1.0), "lam": torch.tensor(2.0), "tau_y": torch.tensor(3.0),
                                 "K": torch.tensor(4.0), "n": torch.tensor(0.5)}, "rheo", 1200.0).numpy()
    np.testing.assert_allclose(rheo, [1200.0, 3.0, 4.0, 0.5, 1.0, 2.0])


def test_a_virtual_experiment_never_starts_from_its_truth():
    material = {"convention": "pacnerf", "mu": 1000.0, "lam": 1000.0, "sigma_y": 50.0, "eta": 1.0}
    virtual = {"name": "v", "kind": "virtual", "material": material,
               "fit": {"initial_guess": {"mu": 100.0, "lam": 1e4, "sigma_y": 10.0}}}
    with pytest.raises(ValueError, match=r"material is the truth; give fit\.initial_guess for eta"):
        initial_guess(virtual)
    real = {**virtual, "kind": "real"}  # a recording's material section is the user's starting guess
    assert initial_guess(real) == {"mu": 100.0, "lam": 1e4, "sigma_y": 10.0, "eta": 1.0}
