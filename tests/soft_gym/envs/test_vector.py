"""The batched MuJoCo vector env: every arm moves bit for bit as the same env stepped alone
(seeds, loads, randomisation, autoreset), with threads or without; Gymnasium 1.x autoreset in
both modes; bad arguments refused by name."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401  (registers the ids)
from soft_gym.envs.soft_arm_env import SoftArmEnv
from soft_gym.envs.vector import MAX_NUM_ENVS, SoftArmVectorEnv

KWARGS = {"preset": "zhao2021", "engine": "mujoco", "feedback": "ground_truth",
          "episode_steps": 6, "scenario": [{"name": "push", "start_s": 0.1, "ramp_s": 0.1}],
          "randomization": {"load_weights": {"none": 0.4, "tip_mass": 0.4, "push": 0.2}}}
N_ARMS, STEPS, SEED = 3, 14, 7


def _actions(n_arms: int, n_chambers: int) -> np.ndarray:
    return np.random.default_rng(0).uniform(-1, 1, (STEPS, n_arms, n_chambers)).astype(np.float32)


def _batched(threads: int = 1, **extra) -> tuple[np.ndarray, np.ndarray]:
    env = gym.make_vec("SoftArmReach-v0", num_envs=N_ARMS, vectorization_mode="vector_entry_point",
                       threads=threads, **KWARGS, **extra)
    observation, _ = env.reset(seed=SEED)
    observations, rewards = [observation], []
    for action in _actions(N_ARMS, env.single_action_space.shape[0]):
        observation, reward, *_ = env.step(action)
        observations.append(observation)
        rewards.append(reward)
    env.close()
    return np.array(observations), np.array(rewards)


def _alone(arm: int) -> tuple[np.ndarray, np.ndarray]:
    """Arm ``arm`` as a single env, with NextStep autoreset done by hand."""
    env = SoftArmEnv(**KWARGS)
    observation, _ = env.reset(seed=SEED + arm)
    observations, rewards, done = [observation], [], False
    for action in _actions(N_ARMS, env.action_space.shape[0])[:, arm]:
        if done:
            (observation, _), reward, done = env.reset(), 0.0, False
        else:
            observation, reward, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
        observations.append(observation)
        rewards.append(reward)
    return np.array(observations), np.array(rewards)


@pytest.mark.smoke
def test_every_arm_of_the_batch_moves_as_it_does_alone():
    observations, rewards = _batched()
    for arm in range(N_ARMS):
        alone_observations, alone_rewards = _alone(arm)
        assert np.array_equal(observations[:, arm], alone_observations)
        assert np.array_equal(rewards[:, arm], alone_rewards)
    assert not np.array_equal(observations[:, 0], observations[:, 1])  # own seeds, own draws


def test_threads_change_nothing():
    single, _ = _batched(threads=1)
    threaded, _ = _batched(threads=2)
    assert np.array_equal(single, threaded)


def test_same_step_autoreset_returns_the_final_observation_in_info():
    env = gym.make_vec("SoftArmReach-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       autoreset_mode="SameStep", **{**KWARGS, "episode_steps": 2,
                                                     "randomization": None})
    assert env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    first, _ = env.reset(seed=1)
    zeros = np.zeros(env.action_space.shape, dtype=np.float32)
    env.step(zeros)
    observation, _, _, truncated, info = env.step(zeros)
    assert truncated.all() and info["_final_obs"].all()
    assert np.array_equal(observation[:, :7], first[:, :7])  # reset: the settled start pose
    assert not np.array_equal(info["final_obs"][0], observation[0])


def test_per_env_kwargs_give_each_arm_its_own_and_it_moves_as_it_does_alone():
    """Two arms of one batch on their own paths, one carrying a tip mass: each moves bit for
    bit as that env alone."""
    shared = {"preset": "zou2022", "engine": "mujoco", "feedback": "ground_truth"}
    own = [{"path": "circle"}, {"path": "star", "scenario": {"name": "tip_mass",
                                                              "mass_kg": 0.02}}]
    env = gym.make_vec("SoftArmTrack-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       per_env_kwargs=own, **shared)
    actions = np.random.default_rng(1).uniform(-1, 1, (4, *env.action_space.shape))
    batch = [env.reset(seed=3)[0]] + [env.step(a.astype(np.float32))[0] for a in actions]
    env.close()
    for arm in range(2):
        alone = SoftArmEnv(task="track", **shared, **own[arm])
        rows = [alone.reset(seed=3 + arm)[0]] + [alone.step(a[arm].astype(np.float32))[0]
                                                 for a in actions]
        alone.close()
        assert np.array_equal(np.array(batch)[:, arm], np.array(rows))
    assert not np.array_equal(np.array(batch)[1:, 0], np.array(batch)[1:, 1])


@pytest.mark.parametrize("per_env_kwargs, named", [
    ({"path": "circle"}, r"per_env_kwargs must be None or a list of num_envs \(2\)"),
    ([{"path": "circle"}], r"list of num_envs \(2\)"),
    ([{}, "circle"], "per_env_kwargs must be"),
    ([{}, {"engine": "pybullet"}], r"engine must be 'mujoco'.*per_env_kwargs\[1\]"),
    ([{}, {"path": "nowhere"}], r"per_env_kwargs\[1\]: .*path"),
    ([{}, {"preset": "zhao2021"}], r"per_env_kwargs\[1\] gives arm 1 the observation space"),
    ([{}, {"obs": ("pose", "target")}], r"per_env_kwargs\[1\] gives arm 1 the observation"),
])
def test_mismatched_per_env_kwargs_are_refused_by_name(per_env_kwargs, named):
    with pytest.raises(ValueError, match=named):
        SoftArmVectorEnv(2, engine="mujoco", feedback="ground_truth", preset="zou2022",
                         per_env_kwargs=per_env_kwargs)


@pytest.mark.parametrize("own, named", [
    ({"obs": ("pose", "pressure", "target")},
     r"the observation space whose low bound at index 7 is 0 \(part 'pressure' entry 0\), "
     r"arm 0's is -1\.54 \(part 'target' entry 0\): "),
    ({"preset": "zhao2021"},
     r"the observation space whose shape is \(19,\) \(parts pose 7, target 6, pressure 6\), "
     r"arm 0's is \(16,\) \(parts pose 7, target 6, pressure 3\): "),
    ({"obs_format": "dict"}, r"the observation space whose type is Dict, arm 0's is Box: "),
])
def test_an_unlike_arm_is_refused_naming_the_first_difference_not_both_spaces(own, named):
    """The refusal names what differs (bound and index with its part, shape with the parts, or
    type) and the two values, in one short line, rather than printing both spaces whole."""
    with pytest.raises(ValueError, match=r"^per_env_kwargs\[1\] gives arm 1 " + named) as refused:
        SoftArmVectorEnv(2, engine="mujoco", feedback="ground_truth", preset="zou2022",
                         per_env_kwargs=[{}, own])
    message = str(refused.value)
    assert "Box(" not in message and "\n" not in message and len(message) < 300


def test_an_arm_of_another_preset_is_refused_on_a_preset_id():
    with pytest.raises(ValueError, match="preset must be 'zou2022' on SoftArmTrackZou2022-v0"):
        gym.make_vec("SoftArmTrackZou2022-v0", num_envs=2, vectorization_mode="vector_entry_point",
                     engine="mujoco", feedback="ground_truth",
                     per_env_kwargs=[{}, {"preset": "zhao2021"}])


@pytest.mark.parametrize("kwargs, named", [
    ({"num_envs": 0}, "num_envs"), ({"num_envs": MAX_NUM_ENVS + 1}, "num_envs"),
    ({"num_envs": 2.0}, "num_envs"), ({"num_envs": True}, "num_envs"),
    ({"num_envs": 2, "threads": 0}, "threads"), ({"num_envs": 2, "threads": 1.5}, "threads"),
    ({"num_envs": 2, "autoreset_mode": "bogus"}, "autoreset_mode"),
    ({"num_envs": 2, "autoreset_mode": "Disabled"}, "autoreset_mode"),
    ({"num_envs": 2, "engine": "pybullet"}, "engine must be 'mujoco'"),
    ({"num_envs": 2, "bogus": 1}, "bogus"),
])
def test_bad_arguments_are_refused_by_name(kwargs, named):
    kwargs = {"engine": "mujoco", "feedback": "ground_truth", **kwargs}
    with pytest.raises(ValueError, match=named):
        gym.make_vec("SoftArmReach-v0", vectorization_mode="vector_entry_point", **kwargs)


def test_bad_actions_and_seeds_are_refused_before_any_arm_moves():
    env = SoftArmVectorEnv(2, engine="mujoco", feedback="ground_truth")
    env.reset(seed=0)
    times = [arm.sim.time_s for arm in env.envs]
    with pytest.raises(ValueError, match="actions must have shape"):
        env.step(np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"action must lie in \[-1, 1\]"):
        env.step(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))
    assert [arm.sim.time_s for arm in env.envs] == times
    with pytest.raises(ValueError, match="seed must be an integer or 2 seeds"):
        env.reset(seed=[1, 2, 3])


@pytest.mark.parametrize("actions, given", [
    ([[0.1, 0.2, 0.3], [0.1, [0.2, 0.3], 0.4]],
     r"a ragged sequence whose row 1 is itself ragged: \[0\.1, \[0\.2, 0\.3\], 0\.4\]"),
    ([[0.1, 0.2, 0.3], [0.1, 0.2]], r"a ragged sequence whose row 1 has shape \(2,\)"),
    ([[0.1, 0.2, 0.3], [0.1, 0.2, 0.3, 0.4]], r"a ragged sequence whose row 1 has shape \(4,\)"),
])
def test_ragged_actions_are_refused_naming_the_shape_and_the_row(actions, given):
    """Rows of unequal lengths (NumPy's "setting an array element with a sequence") are one
    ValueError naming ``actions``, the shape expected and the row given, before any arm moves."""
    env = gym.make_vec("SoftArmReach-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       engine="mujoco", feedback="ground_truth")
    env.reset(seed=0)
    times = [arm.sim.time_s for arm in env.unwrapped.envs]
    with pytest.raises(ValueError, match=r"^actions must have shape \(2, 3\) \(num_envs, "
                                         r"n_chambers\), got " + given + "$"):
        env.step(actions)
    assert [arm.sim.time_s for arm in env.unwrapped.envs] == times
    env.close()



def test_the_batch_refuses_step_before_reset():
    reset_needed = gym.error.ResetNeeded
    env = gym.make_vec("SoftArmReach-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       engine="mujoco", feedback="ground_truth")
    zeros = np.zeros(env.action_space.shape, dtype=np.float32)
    with pytest.raises(reset_needed, match=r"call reset\(\) before step\(\)"):
        env.step(zeros)
    assert [arm.sim.time_s for arm in env.unwrapped.envs] == [0.0, 0.0]
    env.reset(seed=0)
    env.step(zeros)
    env.close()


@pytest.mark.parametrize("threads", [1, 2])
def test_a_closed_batch_refuses_step_and_reset_and_closes_twice(threads):
    closed_error = gym.error.ClosedEnvironmentError
    env = gym.make_vec("SoftArmReach-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       threads=threads, engine="mujoco", feedback="ground_truth")
    env.reset(seed=0)
    zeros = np.zeros(env.action_space.shape, dtype=np.float32)
    env.step(zeros)
    env.close()
    for call in (lambda: env.step(zeros), lambda: env.reset(seed=0)):
        with pytest.raises(closed_error, match="closed.*make a new one"):
            call()
    env.close()  # harmless


def test_a_batch_with_a_closed_arm_refuses_to_step_or_reset_before_any_arm_moves():
    closed_error = gym.error.ClosedEnvironmentError
    env = SoftArmVectorEnv(3, engine="mujoco", feedback="ground_truth")
    env.reset(seed=0)
    env.envs[1].close()
    times = [arm.sim.time_s for arm in env.envs]
    with pytest.raises(closed_error, match=r"arm 1 .*closed.*make a new one"):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert [arm.sim.time_s for arm in env.envs] == times
    with pytest.raises(closed_error, match=r"arm 1 .*closed.*make a new one"):
        env.reset(seed=0)
    assert [arm.sim.time_s for arm in env.envs] == times
    env.close()
    env.close()
