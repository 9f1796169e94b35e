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
from soft_gym.envs import SoftArmEnv


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


@pytest.mark.parametrize("name", ["cc_model", "hybrid_gpr"])
def test_a_baseline_calibrates_on_first_predict_without_touching_the_env(name):
    """make_policy(name, env=env) predicts in a plain loop: the first predict() calibrates on a
    private copy of the env, leaving the env's episode as it was, with the alpha that
    calibrate() finds on a fresh env."""
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy(name, env=env)
    observation, _ = env.reset(seed=0)
    sim = env.unwrapped.sim
    before = (sim.time_s, np.array(sim.tip_pose()[0]), env.unwrapped.np_random.bit_generator.state)
    action, _ = policy.predict(observation)
    assert sim.time_s == before[0]
    np.testing.assert_array_equal(sim.tip_pose()[0], before[1])
    assert env.unwrapped.np_random.bit_generator.state == before[2]
    assert env.action_space.contains(action)
    observation, *_ = env.step(action)  # the loop goes on from where it was

    explicit = make_policy(name, env=gym.make("SoftArmTrack-v0", feedback="ground_truth"))
    np.testing.assert_array_equal(policy.alpha, explicit.calibrate())
    env.close()


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
    with pytest.raises(ValueError, match="calibrate"):  # no spec: nothing to calibrate on
        make_policy("cc_model", env=SoftArmEnv(feedback="ground_truth")).predict(
            env.reset(seed=0)[0])
    with pytest.raises(ValueError, match="obs"):
        make_policy("cc_model", env=gym.make("SoftArmTrack-v0", feedback="ground_truth",
                                             obs=("pressure",)))


def test_hybrid_compensation_never_reverses_or_overturns_a_command():
    """Eq. (29) with a bounded learned error: the compensated command keeps a positive gain
    along the desired motion, within [1 + min, 1 + max], and turns by at most max_turn_deg."""
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("hybrid_gpr", env=env, kp=0.06, max_turn_deg=30.0)
    rng = np.random.default_rng(0)
    for _ in range(500):
        desired = rng.normal(size=3)
        direction = desired / np.linalg.norm(desired)
        relative = rng.normal(scale=5.0, size=3)
        command = desired + policy.bounded_error(relative, direction) * np.linalg.norm(desired)
        gain = command @ direction / np.linalg.norm(desired)
        assert 1 + policy.min_relative_error - 1e-12 <= gain <= 1 + policy.max_relative_error + 1e-12
        angle = np.degrees(np.arccos(np.clip(command @ direction / np.linalg.norm(command), -1, 1)))
        assert angle <= 30.0 + 1e-9


def test_hybrid_improves_on_the_model_with_noisy_em_feedback():
    """With the EM tracker's 0.8 mm noise the compensator still learns (no divergence)."""
    errors = {}
    for policy in ("cc_model", "hybrid_gpr"):
        record = run(RunConfig(policy=policy, policy_params={"kp": 0.04},
                               env_kwargs={"path": "circle", "cycles": 3, "feedback": "em"}))
        last = record["cycle"] == record["cycle"].max()
        errors[policy] = (float(np.mean(record["error_mm"][last])),
                          float(np.max(record["error_mm"][last])))
    assert errors["hybrid_gpr"][0] <= 0.5 * errors["cc_model"][0], errors
    assert errors["hybrid_gpr"][1] < errors["cc_model"][1], errors
