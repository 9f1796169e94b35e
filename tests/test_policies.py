"""Baselines: the CC model controller and the hybrid CC + GPR controller (wang2023 Tables I-II).

Ground-truth feedback keeps these fast; the runner drives the same policies with fused feedback.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.policies import make_policy
from eval.runner import RunConfig, run, run_episode


def _mean_error_last_cycle(policy: str, kp: float, path: str = "circle") -> float:
    record = run(RunConfig(policy=policy, policy_params={"kp": kp},
                           env_kwargs={"path": path, "cycles": 3, "feedback": "ground_truth"}))
    last = record["cycle"] == record["cycle"].max()
    return float(np.mean(record["error_mm"][last]))


@pytest.mark.parametrize("path", ["circle", "pentagram"])
def test_smaller_gain_larger_model_error_and_hybrid_improves_by_half(path):
    """wang2023: the smaller K_p, the larger the model-based error; the hybrid improves it by
    52-90 %."""
    model = {kp: _mean_error_last_cycle("cc_model", kp, path) for kp in (0.04, 0.10)}
    assert model[0.04] > model[0.10]
    for kp in (0.04, 0.10):
        hybrid = _mean_error_last_cycle("hybrid_gpr", kp, path)
        improvement = (model[kp] - hybrid) / model[kp]
        assert improvement >= 0.5, f"{path} K_p={kp}: {model[kp]:.2f} -> {hybrid:.2f} mm"


def test_probe_calibration_estimates_a_positive_linear_gain_per_chamber():
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("cc_model", env=env)
    alpha = policy.calibrate()
    assert alpha.shape == (3,) and np.all(alpha > 0)
    # symmetric arm: the three chambers' gains agree within 1 %
    assert np.ptp(alpha) / alpha.mean() < 0.01


def test_hybrid_save_and_load_keep_the_learned_window(tmp_path):
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("hybrid_gpr", env=env, kp=0.06)
    policy.calibrate()
    run_episode(env, policy, seed=0)
    policy.save(tmp_path / "hybrid")
    loaded = type(policy).load(tmp_path / "hybrid", env=env)
    assert len(loaded.gp) == len(policy.gp) and loaded.samples == policy.samples
    observation, _ = env.reset(seed=1)
    policy.reset()
    loaded.reset()
    np.testing.assert_array_equal(policy.predict(observation)[0], loaded.predict(observation)[0])


def test_bad_policy_requests_raise():
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    with pytest.raises(ValueError, match="policy"):
        make_policy("pid", env=env)
    with pytest.raises(ValueError, match="kp"):
        make_policy("cc_model", env=env, kp=-1.0)
    with pytest.raises(ValueError, match="calibrate"):
        make_policy("cc_model", env=env).predict(env.reset(seed=0)[0])
    with pytest.raises(ValueError, match="obs"):
        make_policy("cc_model", env=gym.make("SoftArmTrack-v0", feedback="ground_truth",
                                             obs=("pressure",)))
