"""Environment API: Gymnasium and SB3 checkers, determinism, input validation, long soaks."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import soft_gym
from soft_gym.robots import PRESETS

ALL_IDS = soft_gym.registered_ids()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_registered_ids_pass_gymnasium_and_sb3_checkers(env_id):
    env = gym.make(env_id)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=True)
    env.close()


@pytest.mark.parametrize("preset", sorted(PRESETS))
@pytest.mark.parametrize("task", ["reach", "track"])
def test_every_preset_passes_checker_through_generic_ids(task, preset):
    env = gym.make("SoftArmReach-v0" if task == "reach" else "SoftArmTrack-v0", preset=preset)
    gym_check_env(env.unwrapped, skip_render_check=True)
    assert env.action_space.shape == (PRESETS[preset].n_chambers,)
    env.close()


@pytest.mark.parametrize("task", ["reach", "track"])
def test_alias_ids_refuse_another_preset_and_accept_their_own(task):
    """An alias id names its arm: another preset is a contradiction (ValueError naming preset,
    the value and the alias's preset); the alias's own preset, by name or as the equal
    ArmSpec, builds the same arm."""
    from soft_gym.envs.registration import preset_env_id

    alias = preset_env_id(task, "wang2023")
    with pytest.raises(ValueError, match=r"preset must be 'wang2023'.*got 'ho2018'"):
        gym.make(alias, preset="ho2018", feedback="ground_truth")
    variant = dataclasses.replace(PRESETS["wang2023"], name="wang2023_soft")
    with pytest.raises(ValueError, match="preset.*'wang2023_soft'"):
        gym.make(alias, preset=variant, feedback="ground_truth")
    for preset in (None, "wang2023", PRESETS["wang2023"]):
        kwargs = {} if preset is None else {"preset": preset}
        env = gym.make(alias, feedback="ground_truth", **kwargs)
        assert env.unwrapped.arm == PRESETS["wang2023"]
        remade = gym.make(env.spec)  # a spec remakes the same env (SubprocVecEnv, copies)
        assert remade.unwrapped.arm == PRESETS["wang2023"]
        env.close()
        remade.close()


def _rollout(seed: int, steps: int = 15, **kwargs) -> np.ndarray:
    env = gym.make("SoftArmReach-v0", **kwargs)
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    sequence = [obs]
    for _ in range(steps):
        obs, *_ = env.step(env.action_space.sample())
        sequence.append(obs)
    env.close()
    return np.array(sequence)


def test_same_seed_same_observations_different_seed_differs():
    first, again, other = _rollout(3), _rollout(3), _rollout(4)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_two_envs_in_one_process_are_independent():
    a = gym.make("SoftArmReach-v0")
    b = gym.make("SoftArmReach-v0")
    a.reset(seed=0)
    b.reset(seed=0)
    a.step(np.ones(3, dtype=np.float32))
    obs_b, *_ = b.step(-np.ones(3, dtype=np.float32))
    obs_a, *_ = a.step(np.ones(3, dtype=np.float32))
    assert not np.allclose(obs_a[:3], obs_b[:3])
    a.close()
    b.close()


@pytest.mark.parametrize("bad", [np.array([np.nan, 0, 0]), np.array([np.inf, 0, 0]),
                                 np.zeros(4), np.zeros((1, 3)), np.array([1.5, 0, 0]), "abc"])
def test_bad_actions_raise_value_error_naming_action(bad):
    env = gym.make("SoftArmReach-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.unwrapped.step(bad)
    env.close()


@pytest.mark.parametrize("kwargs, name", [
    ({"preset": "nonexistent"}, "preset"),
    ({"scenario": "earthquake"}, "scenario"),
    ({"scenario": {"name": "tip_mass", "mass_kg": -0.01}}, "mass_kg"),
    ({"scenario": {"name": "swaying_mass", "length_m": -0.1}}, "length_m"),
    ({"task": "juggle"}, "task"),
    ({"obs": ("pose", "smell")}, "obs"),
    ({"action_mode": "sideways"}, "action_mode"),
    ({"task": "track", "path": "hexagon"}, "path"),
])
def test_bad_configuration_raises_value_error_naming_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("SoftArmReach-v0", **kwargs)


def test_negative_segment_length_rejected():
    from soft_gym.robots import SegmentSpec

    with pytest.raises(ValueError, match="length_m"):
        SegmentSpec(length_m=-0.1, outer_radius_m=0.01, chamber_offset_m=0.005,
                    chamber_area_m2=1e-5, youngs_modulus_pa=1e5)


def test_delta_mode_accumulates_pressure_and_observation_parts_select():
    env = gym.make("SoftArmReach-v0", action_mode="delta", obs=("pressure",))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (3,)
    for _ in range(5):
        obs, *_ = env.step(np.array([1.0, 0.0, 0.0], dtype=np.float32))
    # five +10 % steps command 50 % of p_max on chamber 0; the lag lets it rise towards that
    assert 0.2 < obs[0] <= 0.5 + 1e-6
    assert obs[1] == pytest.approx(0.0, abs=1e-6)
    env.close()


def test_track_task_presents_path_targets_and_ends_after_the_path():
    env = gym.make("SoftArmTrack-v0", path="circle", cycles=2, speed_m_s=0.02)
    env.reset(seed=0)
    task = env.unwrapped.task
    n = task.episode_steps
    assert len(task.trajectory_m) == n
    truncated, steps = False, 0
    while not truncated:
        _, _, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
        steps += 1
        assert not terminated
    assert steps == n
    env.close()


def test_reward_is_minus_error_in_metres_without_action_change():
    env = gym.make("SoftArmReach-v0", action_rate_weight=0.0)
    env.reset(seed=2)
    _, reward, *_, info = env.step(np.zeros(3, dtype=np.float32))
    assert reward == pytest.approx(-info["error_mm"] / 1000.0, rel=1e-9)
    env.close()


def test_render_returns_rgb_array():
    env = gym.make("SoftArmReach-v0", render_mode="rgb_array", render_size=(64, 48))
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
    assert frame.std() > 0  # the arm is visible against the background
    env.close()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_random_action_soak_stays_finite_and_within_joint_limits(preset):
    """10,000 random-action steps: no NaN and no joint beyond its physical range."""
    env = gym.make("SoftArmReach-v0", preset=preset, episode_steps=10_000,
                   feedback="ground_truth")
    env.reset(seed=0)
    env.action_space.seed(0)
    arm = env.unwrapped.sim.arm
    tolerance = 1e-3
    for step in range(10_000):
        obs, *_ = env.step(env.action_space.sample())
        if step % 50 == 0:
            assert np.all(np.isfinite(obs))
            q = env.unwrapped.sim.joint_positions()
            assert np.all(q >= arm.lower_limit - tolerance), (step, q)
            assert np.all(q <= arm.upper_limit + tolerance), (step, q)
    assert np.all(np.isfinite(env.unwrapped.sim.backbone()))
    env.close()


def test_sensor_parts_in_flat_and_dict_observations_and_info():
    env = gym.make("SoftArmReach-v0", obs=("pose", "fbg", "em", "encoder"), sensors=("strain",),
                   feedback="ground_truth")
    gym_check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=1)
    n_gratings = env.unwrapped.sensors["fbg"].layout.n_gratings
    assert obs.shape == (7 + n_gratings + 7 + 3,)
    assert set(info["sensors"]) == {"fbg", "em", "encoder", "strain"}
    np.testing.assert_allclose(obs[7:7 + n_gratings], info["sensors"]["fbg"], rtol=1e-6)
    env.close()
    env = gym.make("SoftArmReach-v0", obs=("target", "fbg"), obs_format="dict",
                   feedback="ground_truth")
    obs, _ = env.reset(seed=1)
    assert set(obs) == {"target", "fbg"} and env.observation_space.contains(obs)
    env.close()


def test_sensors_cost_nothing_unless_asked_and_readings_repeat_under_a_seed():
    # ground truth reads the privileged truth sensor alone, which no observation or info shows
    base = gym.make("SoftArmReach-v0", feedback="ground_truth").unwrapped
    assert list(base.sensors) == ["truth"] and base.sensors["truth"].privileged
    assert base.reset(seed=0)[1]["sensors"] == {}
    runs = []
    for _ in range(2):
        env = gym.make("SoftArmReach-v0", obs=("fbg", "em"), feedback="ground_truth")
        env.reset(seed=7)
        env.action_space.seed(7)
        runs.append([env.step(env.action_space.sample())[0] for _ in range(5)])
        env.close()
    np.testing.assert_array_equal(np.array(runs[0]), np.array(runs[1]))


@pytest.mark.parametrize("kwargs, name", [
    ({"obs_format": "nested"}, "obs_format"),
    ({"sensors": ("sonar",)}, "sensors"),
    ({"sensor_config": {"sonar": {}}}, "sensor_config"),
    ({"obs": ("fbg",), "sensor_config": {"fbg": {"noise_std_nm": -1.0}}}, "noise_std_nm"),
])
def test_bad_sensor_configuration_raises(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("SoftArmReach-v0", **kwargs)


@pytest.mark.parametrize("feedback, tolerance_mm", [
    ("ground_truth", 1e-3), ("em", 4.0), ("camera", 3.0), ("fbg", 3.0), ("fused", 3.0)])
def test_feedback_sources_fill_the_pose_part(feedback, tolerance_mm):
    env = gym.make("SoftArmTrack-v0", feedback=feedback)
    obs, info = env.reset(seed=0)
    errors = []
    for _ in range(20):
        # a bend inside the calibration exploration's range (F-emp is a local model)
        obs, _, _, _, info = env.step(np.array([0.0, -0.8, -0.8], dtype=np.float32))
        errors.append(np.linalg.norm(obs[:3] - info["tip_position_m"]) * 1000)
    assert np.mean(errors) <= tolerance_mm, f"{feedback}: {np.mean(errors):.3f} mm"
    if feedback in ("camera", "fbg", "fused"):
        assert set(info["estimates"]) >= {"camera", "femp", "fused", "reprojection_error_px"}
    env.close()


def test_pipeline_persists_across_resets_and_recalibrates_on_request():
    env = gym.make("SoftArmReach-v0")
    env.reset(seed=0)
    pipeline = env.unwrapped.pipeline
    for _ in range(30):
        env.step(env.action_space.sample())
    learned = pipeline.femp.updates
    assert learned > 0
    env.reset()
    assert pipeline.femp.updates >= learned  # a plain reset keeps what was learned
    env.reset(seed=1)
    assert pipeline.femp.updates <= 1  # a seeded reset returns to the calibrated state (the
    # reset observation itself may update once)
    env.reset(options={"recalibrate": True})
    assert pipeline.is_calibrated and pipeline.calibration_samples > 100
    env.close()


def test_feedback_and_fault_configuration_errors():
    with pytest.raises(ValueError, match="feedback"):
        gym.make("SoftArmReach-v0", feedback="telepathy")
    with pytest.raises(ValueError, match="faults"):
        gym.make("SoftArmReach-v0", feedback="ground_truth", faults="low_light")
    with pytest.raises(ValueError, match="faults"):
        gym.make("SoftArmReach-v0", faults="earthquake")
