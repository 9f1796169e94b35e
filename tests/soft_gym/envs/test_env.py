"""Environment API: Gymnasium and SB3 checkers, determinism, input validation, long soaks."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import soft_gym
from soft_gym.envs.config import MAX_ACTION_RATE_WEIGHT, MAX_SETTLE_S
from soft_gym.envs.soft_arm_env import SoftArmEnv
from soft_gym.robots import PRESETS, get_preset
from soft_gym.robots.spec import ArmSpec
from soft_gym.scenarios import FillingLoad, Flick, ObstacleRod, Push, SwayingMass, TipMass
from soft_gym.scenarios.loads import (MAX_FILL_RATE_KG_S, MAX_FORCE_N, MAX_MASS_KG,
                                      MAX_SWAY_LENGTH_M)
from soft_gym.scenarios.randomization import RandomizationConfig

ALL_IDS = soft_gym.registered_ids()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_registered_ids_pass_gymnasium_and_sb3_checkers(env_id):
    env = gym.make(env_id)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=True)
    env.close()


@pytest.mark.parametrize("preset", [pytest.param(name, marks=pytest.mark.smoke) if name == "wang2023"
                                    else name for name in sorted(PRESETS)])
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


@pytest.mark.smoke
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


@pytest.mark.parametrize("steps", [2_000, pytest.param(10_000, marks=pytest.mark.slow)])
@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_random_action_soak_stays_finite_and_within_joint_limits(preset, steps):
    """``steps`` random-action steps: no NaN and no joint beyond its physical range.

    The default run soaks 2,000 steps per preset; the 10,000-step soak (about 25 s a preset on
    one core) runs with ``-m slow``."""
    env = gym.make("SoftArmReach-v0", preset=preset, episode_steps=steps,
                   feedback="ground_truth")
    env.reset(seed=0)
    env.action_space.seed(0)
    arm = env.unwrapped.sim.arm
    tolerance = 1e-3
    for step in range(steps):
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


# ==========================================================================================
# Bad input, case by case
#
# Every kind of bad input to the env gets a ``ValueError`` naming the parameter (issue 17).
#
# Constructor keyword arguments (through ``gymnasium.make``, as users call it), every scenario
# element's parameters, randomisation ranges, ``reset`` arguments and ``step`` actions: a wrong
# type, a non-finite or out-of-range value, a value the env would silently ignore, truncate or clip,
# or one that would hang or throw the physics out of range is refused by name. Also: pickled and
# deep-copied envs are independent envs of the same configuration.
#
# The parametrised cases come from a bad-input sweep of the env (about 300 inputs); each case is
# ``(id, kwargs, pattern)`` with ``pattern`` a regular expression the message must match, normally
# the parameter's name.
# ==========================================================================================


NAN, INF = float("nan"), float("inf")
REACH, TRACK = "SoftArmReach-v0", "SoftArmTrack-v0"
NEAR_WAYPOINTS = [[0.02, 0.0, 0.08], [0.0, 0.02, 0.08], [-0.02, 0.0, 0.08]]


def _cases(env_id: str, parameter: str, values, pattern: str | None = None, **extra):
    return [pytest.param(env_id, {parameter: value, **extra}, pattern or parameter,
                         id=f"{parameter}={value!r}"[:60]) for value in values]


CONSTRUCTOR_CASES = [
    # the wrong types
    *_cases(REACH, "preset", [["wang2023"], 123, None, "nope", {"name": "wang2023"}]),
    *_cases(REACH, "task", ["fly", None, ["reach"], 1]),
    *_cases(REACH, "delta_fraction", ["0.1", 0, 2, NAN, -0.1, None, True, [0.1]],
            action_mode="delta"),
    *_cases(REACH, "episode_steps", ["100", 2.5, 100.0, np.float64(100), 0, -1, True, None, NAN]),
    *_cases(REACH, "obs", [123, [], ["pose", "pose"], ["nope"], [1], {"pose"}, None, [["pose"]]]),
    *_cases(TRACK, "path", [None, 123, [], ["circle", 1], "hexagon", {"circle"}, [["circle"]]]),
    *_cases(TRACK, "waypoints_m", ["abc", [[0, 0, 0.08]], [[0, 0, 0.08], [0, 0, 0.08]],
                                   [[NAN, 0, 0.08], [0, 0, 0.08]], [[0, 0], [0, 1]], 5,
                                   [[0, 0, 0.08], "x"], [[0.01j, 0, 0.08], [0, 0.01, 0.08]],
                                   np.zeros((2, 3, 1)), None], path="waypoints"),
    pytest.param(TRACK, {"path": "waypoints", "waypoints_m": [[1.0, 0, 0], [0, 1.0, 0]]},
                 r"waypoints_m must lie within the wang2023 arm's reach of 144 mm",
                 id="waypoints_m-a-metre-away"),
    pytest.param(TRACK, {"path": "circle", "waypoints_m": NEAR_WAYPOINTS}, "waypoints_m",
                 id="waypoints_m-without-path-waypoints"),
    # silently accepted before
    *_cases(REACH, "action_rate_weight", [NAN, INF, -1, "x", None, True, 1j,
                                          MAX_ACTION_RATE_WEIGHT * 10, 1e308]),
    *_cases(REACH, "settle_s", [-1, NAN, INF, "0.5", None, True, 0.5j, MAX_SETTLE_S + 1, 1e9]),
    *_cases(TRACK, "cycles", [0, -1, 2.5, "2", None, True, NAN, INF, [1]]),
    pytest.param(TRACK, {"cycles": 10**6}, r"cycles.*at most 72000 steps", id="cycles=10**6"),
    *_cases(TRACK, "speed_m_s", [0, -1, NAN, INF, "0.1", 1e6, True, 1j, [0.01]]),
    pytest.param(TRACK, {"speed_m_s": 1e-12}, r"speed_m_s must be >= ", id="speed_m_s=1e-12"),
    *_cases(REACH, "target_m", [[1.0, 0, 0], "abc", [0, 0], [NAN, 0, 0.05], [0.01j, 0, 0.05], 5,
                                [[0, 0, 0.05]]]),
    pytest.param(REACH, {"target_m": [0.0, 0.0, 1.0]},
                 r"target_m must lie within the wang2023 arm's reach of 144 mm",
                 id="target_m-a-metre-away"),
    *_cases(REACH, "start_m", [[1.0, 0, 0], "abc", [0, 0], [NAN, 0, 0.05], 5]),
    *_cases(REACH, "tolerance_mm", [0, -1, NAN, "1", INF, True, [1.0]]),
    # arguments of the other task, which the env would ignore
    *_cases(REACH, "path", ["star", ["circle", "star"]], "path, cycles"),
    *_cases(REACH, "cycles", [3], "path, cycles"),
    *_cases(REACH, "speed_m_s", [0.01], "speed_m_s"),
    *_cases(REACH, "waypoints_m", [NEAR_WAYPOINTS], "waypoints_m"),
    *_cases(TRACK, "target_m", [[0, 0, 0.08]]),
    *_cases(TRACK, "start_m", [[0, 0, 0.08]]),
    *_cases(TRACK, "tolerance_mm", [2.0]),
    # observation, sensors, feedback
    *_cases(REACH, "obs_format", ["xml", None, 1, ["flat"]]),
    pytest.param(REACH, {"obs": ("pose", "image")}, "obs", id="obs-image-in-flat"),
    *_cases(REACH, "sensors", [123, ["nope"], [1], None, [["fbg"]], 1.5, {"fbg": 1},
                               ["em", "em"]]),
    *_cases(REACH, "sensor_config", ["abc", 123, {"fbg": 123}, {"nope": {}}, [("em", {})],
                                     {"em": "x"}, {1: {}}]),
    pytest.param(REACH, {"sensor_config": {"em": {"noise_std_m": 0.001}}},
                 r"sensor_config\['em'\] configures a sensor this env does not simulate",
                 id="sensor_config-for-an-absent-sensor"),
    pytest.param(REACH, {"sensor_config": {"em": {"nope": 1}}, "feedback": "em"}, "nope",
                 id="sensor_config-unknown-option"),
    *_cases(REACH, "feedback", ["nope", None, 123, ["fused"], {"a": 1}]),
    *_cases(REACH, "sensing", ["abc", 123, [1], {"nope": 1}], feedback="strain_sr",
            preset="zhao2021"),
    pytest.param(REACH, {"faults": "low_light"}, "faults", id="faults-without-a-camera"),
    *_cases(REACH, "faults", ["nope", 123, {"stereo": "nope"}], "fault", feedback="stereo",
            preset="zou2022"),
    *_cases(REACH, "action_mode", ["abs", None, ["delta"], 1]),
    *_cases(REACH, "render_size", [(0, 0), (1.5, 2), "320x240", (100000, 100000), (320,), None,
                                   (True, True), (-1, 240), (320.0, 240.0), (320, 240, 3)],
            render_mode="rgb_array"),
    pytest.param(REACH, {"render_mode": "rgb"}, "render_mode", id="render_mode='rgb'",
                 marks=pytest.mark.filterwarnings("ignore:.*render_mode:UserWarning")),
    pytest.param(REACH, {"nope": 1}, r"unknown env keyword argument\(s\) \['nope'\]",
                 id="unknown-keyword"),
    pytest.param("SoftArmReachWang2023-v0", {"preset": "ho2018"}, "preset", id="alias-preset"),
    pytest.param("SoftArmReachWang2023-v0", {"preset": ["ho2018"]}, "preset",
                 id="alias-preset-list"),
    pytest.param("SoftArmReachWang2023-v0", {"colour": "red"}, "colour", id="alias-unknown"),
]


@pytest.mark.parametrize("env_id, kwargs, pattern", CONSTRUCTOR_CASES)
def test_bad_constructor_arguments_are_refused_by_name(env_id, kwargs, pattern):
    kwargs = {"feedback": "ground_truth", **kwargs}
    with pytest.raises(ValueError, match=pattern):
        gym.make(env_id, **kwargs)


def test_a_bad_render_mode_is_refused_by_the_env():
    """``gymnasium.make`` handles ``render_mode`` itself before the env sees it (a non-string
    crashes in gymnasium, ``"human"`` wraps the env for pygame); the env refuses by name."""
    with pytest.raises(ValueError, match="render_mode"):
        SoftArmEnv(feedback="ground_truth", render_mode=1)


# --------------------------------------------------------------------------------- scenarios
def _scenario(element: str, parameter: str, values, pattern: str | None = None, **extra):
    return [pytest.param({"name": element, parameter: value, **extra}, pattern or parameter,
                         id=f"{element}.{parameter}={value!r}"[:60]) for value in values]


SCENARIO_CASES = [
    pytest.param({"name": ["tip_mass"]}, "scenario", id="name-a-list"),
    *[pytest.param(value, "scenario", id=f"scenario={value!r}")
      for value in ("nope", 123, [123], {"mass_kg": 1}, {1: 2}, 1.5)],
    pytest.param({"name": "tip_mass", "nope": 1}, "nope", id="unknown-parameter"),
    *_scenario("tip_mass", "mass_kg", [-1, NAN, INF, "x", True, None, [0.1], 1j]),
    pytest.param({"name": "tip_mass", "mass_kg": 1e6}, r"max_load_n.*mass_kg=1000000.0",
                 id="tip_mass.mass_kg=1e6"),
    pytest.param([{"name": "tip_mass", "mass_kg": 0.07}, {"name": "tip_mass", "mass_kg": 0.07}],
                 "max_load_n", id="two-masses-beyond-max_load_n"),
    *_scenario("tip_mass", "start_s", [-1, "x", NAN, INF, None]),
    *_scenario("tip_mass", "end_s", [INF, "x", 0.0, -1.0]),
    *_scenario("filling_load", "initial_mass_kg", [-1, NAN, "x"]),
    *_scenario("filling_load", "added_mass_kg", [-1, INF, None]),
    *_scenario("filling_load", "rate_kg_s", [0, -1, "x", NAN, MAX_FILL_RATE_KG_S * 2, 1e9]),
    *_scenario("swaying_mass", "mass_kg", [0, -1, "x", NAN]),
    *_scenario("swaying_mass", "length_m", [0, -1, NAN, MAX_SWAY_LENGTH_M * 2, 1e3]),
    *_scenario("swaying_mass", "radius_m", [0, "x", 1e3, 1e-6]),
    *_scenario("push", "link", [1.5, "tip", None, True, 100, -100, np.int64(50)]),
    *_scenario("push", "force_n", ["x", [NAN, 0, 0], [1j, 0, 0], [1.0, 0.0], 1.0]),
    pytest.param({"name": "push", "force_n": [1e9, 0, 0]}, r"max_load_n.*force_n",
                 id="push.force_n=1e9"),
    *_scenario("push", "ramp_s", [-1, INF, "x", None]),
    *_scenario("push", "on_tip_cap", ["yes", 2, None]),
    *_scenario("flick", "impulse_ns", ["x", [NAN, 0, 0], [1.0]]),
    pytest.param({"name": "flick", "impulse_ns": [1e3, 0, 0]}, r"max_load_n.*impulse_ns",
                 id="flick.impulse_ns=1e3"),
    *_scenario("flick", "duration_s", [0, -1, "x", INF]),
    pytest.param({"name": "flick", "duration_s": 1e-12}, r"max_load_n.*duration_s",
                 id="flick.duration_s=1e-12"),
    *_scenario("flick", "force_n", [[1.0, 0.0, 0.0]]),
    *_scenario("flick", "link", ["x"]),
    *_scenario("obstacle_rod", "point_m", ["x", [0, 0], [NAN, 0, 0.07]]),
    *_scenario("obstacle_rod", "axis", [(0, 0, 0), "x"]),
    *_scenario("obstacle_rod", "radius_m", [0, -1, 1e3]),
    *_scenario("obstacle_rod", "length_m", [0, 1e6]),
    pytest.param({"name": "obstacle_rod", "point_m": (0.0, 0.0, 0.05)},
                 r"point_m, axis and radius_m put the obstacle rod through the wang2023 arm",
                 id="obstacle_rod-through-the-arm"),
    pytest.param({"name": "obstacle_rod", "point_m": (0.0, 0.0, 0.05), "axis": (0, 0, 1)},
                 r"obstacle rod through", id="obstacle_rod-along-the-arm"),
    pytest.param({"name": "obstacle_rod", "point_m": (-0.02, 0.0, 0.07), "radius_m": 0.05},
                 r"obstacle rod through", id="obstacle_rod-too-thick-beside-the-arm"),
]


@pytest.mark.parametrize("scenario, pattern", SCENARIO_CASES)
def test_bad_scenarios_are_refused_by_name(scenario, pattern):
    with pytest.raises(ValueError, match=pattern):
        gym.make(REACH, feedback="ground_truth", scenario=scenario)


@pytest.mark.parametrize("make, pattern", [
    (lambda: TipMass(mass_kg=-0.1), "mass_kg"),
    (lambda: FillingLoad(rate_kg_s=10.0), "rate_kg_s"),
    (lambda: SwayingMass(length_m=2.0), "length_m"),
    (lambda: Push(link=0.5), "link"),
    (lambda: Push(on_tip_cap="no"), "on_tip_cap"),
    (lambda: Flick(duration_s=0.0), "duration_s"),
    (lambda: ObstacleRod(radius_m=0.5), "radius_m"),
])
def test_load_constructors_refuse_bad_parameters(make, pattern):
    with pytest.raises(ValueError, match=pattern):
        make()


def test_absolute_load_bounds_hold_on_an_arm_that_bears_more():
    """An arm strong enough to bear them still gets no load beyond ``MAX_MASS_KG`` or
    ``MAX_FORCE_N`` (the bounds hold whatever the arm)."""
    from soft_gym.engines.pybullet.simulator import ArmSimulator

    class StrongArm(ArmSpec):
        @property
        def max_load_n(self) -> float:
            return 1e6

    spec = get_preset("wang2023")
    strong = StrongArm(**{name: getattr(spec, name) for name in spec.__dataclass_fields__})
    sim = ArmSimulator(strong)
    try:
        with pytest.raises(ValueError, match=rf"mass_kg must be at most {MAX_MASS_KG:g} kg"):
            sim.add_load(TipMass(mass_kg=2 * MAX_MASS_KG))
        with pytest.raises(ValueError, match=rf"force_n must be a force of at most "
                                             rf"{MAX_FORCE_N:g} N"):
            sim.add_load(Push(force_n=(2 * MAX_FORCE_N, 0.0, 0.0)))
        with pytest.raises(ValueError, match=r"impulse_ns / duration_s"):
            sim.add_load(Flick(impulse_ns=(1.0, 0.0, 0.0), duration_s=0.01))
    finally:
        sim.close()


# ---------------------------------------------------------------------------- randomization
RANDOMIZATION_CASES = [
    pytest.param("no/such/file.yaml", "randomization", id="missing-file"),
    pytest.param(123, "randomization", id="an-int"),
    pytest.param({"nope": 1}, "nope", id="unknown-key"),
    pytest.param({1: (0, 1)}, "randomization", id="non-string-key"),
    *[pytest.param({"tip_mass_kg": value}, "tip_mass_kg", id=f"tip_mass_kg={value!r}")
      for value in ("ab", 5, (0.01, 0.0), (NAN, 0.01), (0, 0.01, 0.02), ("a", "b"),
                    (True, 0.01), (0.0, True), (1j, 0.01), (0.0, 2 * MAX_MASS_KG), None)],
    *[pytest.param({"load_weights": value}, "load_weights", id=f"load_weights={value!r}")
      for value in ({"tip_mass": "x"}, {"tip_mass": NAN}, {"tip_mass": None}, [],
                    {"nope": 1}, {"tip_mass": -1}, {"tip_mass": INF}, {"tip_mass": True})],
    pytest.param({"fault_weights": {"low_light": "x"}}, "fault_weights", id="fault-odds-str"),
    pytest.param({"push_force_n": (0, 1e9)}, "push_force_n", id="push-1e9"),
    pytest.param({"push_force_n": (0, 5.0)}, r"push_force_n can draw a load of 5 N",
                 id="push-beyond-the-arm"),
    pytest.param({"filling_rate_kg_s": (1e3, 1e9)}, "filling_rate_kg_s", id="fill-rate"),
    pytest.param({"swaying_mass_kg": (0.0, 0.01)}, "swaying_mass_kg", id="sway-zero"),
    pytest.param({"fault_strength": (0.5, 2)}, "fault_strength", id="fault-strength"),
    *[pytest.param({name: value}, name, id=f"{name}={value!r}")
      for name, values in (("stiffness_scale", [(0.01, 100), (0, 1), (0.5, 1.0), (1.0, 6.0)]),
                           ("time_constant_scale", [(1e-12, 1e-12), (1e6, 1e6), (0.05, 1.0)]),
                           ("sensor_noise_scale", [(1e6, 1e300), (0.0, 1.0), (1.0, 11.0)]))
      for value in values],
]


@pytest.mark.parametrize("randomization, pattern", RANDOMIZATION_CASES)
def test_bad_randomization_is_refused_by_name(randomization, pattern):
    with pytest.raises(ValueError, match=pattern):
        gym.make(REACH, feedback="ground_truth", randomization=randomization)


def test_shipped_randomization_ranges_are_accepted():
    RandomizationConfig()
    RandomizationConfig.from_any({"tip_mass_kg": [0.0, 0.150], "filling_added_kg": [0.010, 0.100],
                                  "filling_rate_kg_s": [0.003, 0.010],
                                  "swaying_mass_kg": [0.010, 0.120], "push_force_n": [0.1, 1.0]})


# ------------------------------------------------------------------------------ reset, step
@pytest.fixture(scope="module")
def env():
    env = gym.make(REACH, feedback="ground_truth")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.mark.parametrize("kwargs, pattern", [
    ({"seed": "abc"}, "seed"), ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
    ({"seed": True}, "seed"), ({"options": "abc"}, "options"), ({"options": 123}, "options"),
    ({"options": {"nope": 1}}, r"options keys must be among \['recalibrate'\]"),
    ({"options": {"recalibrate": "yes"}}, "recalibrate"),
    ({"options": {"recalibrate": True}}, "recalibrate"),  # ground truth does not calibrate
], ids=lambda value: repr(value)[:40])
def test_bad_reset_arguments_are_refused_by_name(env, kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        env.reset(**kwargs)


@pytest.mark.parametrize("action", [
    [0.1, 0.2], np.zeros((1, 3)), np.zeros(6), [[0, 0, 0]], 0.5, "abc", None, {"a": 1},
    [np.nan, 0, 0], [np.inf, 0, 0], [-np.inf, 0, 0], [0.1j, 0, 0], np.array([0, 0, 0.1j]),
    ["a", "b", "c"], [None, 0, 0], np.array([0, "a", 0], dtype=object), [2.0, 0, 0],
    [-1.5, 0, 0], np.array([True, False, True]), [True, False, True],
], ids=lambda value: repr(value)[:40])
def test_bad_actions_are_refused_by_name(env, action):
    with pytest.raises(ValueError, match="action"):
        env.step(action)


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_ragged_or_wrong_length_action_is_one_line_naming_the_shape(engine):
    """A ragged action (NumPy's "setting an array element with a sequence") and one of the wrong
    length are refused naming ``action``, the shape expected and what was given."""
    env = SoftArmEnv(feedback="ground_truth", engine=engine)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action must have shape \(3,\) \(one number per "
                                         r"chamber\), got a ragged sequence "
                                         r"\[0\.1, \[0\.2, 0\.3\], 0\.4\]$"):
        env.step([0.1, [0.2, 0.3], 0.4])
    with pytest.raises(ValueError, match=r"^action must have shape \(3,\), got \(2,\)$"):
        env.step([0.1, 0.2])
    assert env.step_count == 0
    env.close()


def test_complex_actions_are_refused():
    env = gym.make(REACH, feedback="ground_truth", action_mode="delta")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real"):
        env.step(np.array([0.1 + 0.5j, 0.0, 0.0]))
    env.close()


def test_good_inputs_of_odd_types_are_accepted():
    """What the checks must not refuse: numpy integers and floats, lists, float32 actions."""
    env = gym.make(TRACK, feedback="ground_truth", cycles=np.int64(1), speed_m_s=np.float32(0.01),
                   settle_s=0, action_rate_weight=np.float64(0.01),
                   path=("circle", "star"), sensors=["em"], render_size=[64, 48])
    assert gym.make(REACH, feedback="ground_truth", engine="mujoco",
                    episode_steps=np.int64(5)).unwrapped.task.episode_steps == 5
    env.reset(seed=np.int64(3), options={"recalibrate": False})
    _, reward, *_ = env.step([0.0, 0.5, -1.0])
    assert np.isfinite(reward)
    env.step(np.array([1.0, 1.0, 1.0], dtype=np.float32))
    env.close()


# ------------------------------------------------------------------------------- copies
@pytest.mark.parametrize("copier", [lambda env: pickle.loads(pickle.dumps(env)), copy.deepcopy],
                         ids=["pickle", "deepcopy"])
def test_a_copy_is_an_independent_env_of_the_same_configuration(copier):
    """Pickled or deep-copied, the env is rebuilt from its constructor arguments: its own
    simulator (closing the original leaves it running) and the same configuration."""
    original = gym.make("SoftArmTrackWang2023-v0", feedback="ground_truth",
                        scenario={"name": "tip_mass", "mass_kg": 0.01}, obs=("pose", "target"),
                        settle_s=0.2)
    first, _ = original.reset(seed=0)
    original.step(original.action_space.sample())
    duplicate = copier(original)
    original.close()
    base = duplicate.unwrapped
    assert base.sim.client is not original.unwrapped.sim.client
    assert base.spec.id == "SoftArmTrackWang2023-v0"
    assert base.settle_s == 0.2 and base.obs_parts == ("pose", "target")
    assert [type(load).__name__ for load in base.loads] == ["TipMass"]
    copied_first, _ = duplicate.reset(seed=0)
    np.testing.assert_allclose(copied_first, first, atol=1e-6)  # same configuration and seed
    for _ in range(5):
        observation, reward, *_ = duplicate.step(duplicate.action_space.sample())
    assert np.all(np.isfinite(observation)) and np.isfinite(reward)
    duplicate.close()


def test_an_uncopyable_argument_makes_pickling_fail_by_name():
    class Uncopyable(TipMass):
        def __deepcopy__(self, memo):
            raise TypeError("no copies")

    env = gym.make(REACH, feedback="ground_truth", scenario=Uncopyable(mass_kg=0.001))
    with pytest.raises(ValueError, match="cannot be copied or pickled"):
        pickle.dumps(env)
    env.close()


def test_a_scenario_element_defined_in_a_function_is_deep_copied_and_refused_by_pickle():
    """``copy.deepcopy`` copies an env whose scenario element's class is defined inside a
    function; pickling it is one ValueError naming the argument and the element and saying
    where the class must be defined (not pickle's ``AttributeError: Can't pickle local
    object``)."""
    class LocalMass(TipMass):
        pass

    env = gym.make(REACH, feedback="ground_truth", engine="mujoco",
                   scenario=[LocalMass(mass_kg=0.01)])
    duplicate = copy.deepcopy(env)
    assert [type(load).__name__ for load in duplicate.unwrapped.loads] == ["LocalMass"]
    duplicate.reset(seed=0)
    duplicate.step(np.zeros(3, dtype=np.float32))
    duplicate.close()
    with pytest.raises(ValueError, match=r"^scenario holds .*LocalMass\(.*mass_kg=0\.01\), an "
                                         r"instance of .*<locals>\.LocalMass defined inside a "
                                         r"function: .* defined at a module's top level"):
        pickle.dumps(env)
    env.close()


@pytest.mark.parametrize("env_id", [TRACK, "SoftArmTrackZou2022-v0"])
@pytest.mark.parametrize("steps", [100, 50, np.int64(5)], ids=repr)
def test_episode_steps_is_refused_on_the_track_task(env_id, steps):
    """A track episode lasts until its path's last target (path, cycles, speed_m_s): an
    ``episode_steps`` given to a track env, even the reach default 100, is refused, not
    ignored."""
    with pytest.raises(ValueError, match=r"^episode_steps belongs to the reach task: a track "
                                         r"episode ends when its path's last target has been "
                                         r"presented \(its length set by path, cycles and "
                                         r"speed_m_s\), got episode_steps=.* with task='track'$"):
        gym.make(env_id, feedback="ground_truth", engine="mujoco", episode_steps=steps)


# ==========================================================================================
# Bad input through gymnasium.make and step
#
# Bad input to the env gets a ValueError that names the parameter, never a TypeError from deep
# inside, a NaN reward, a silent truncation or a runaway allocation.
# ==========================================================================================


CASES = [
    ("SoftArmReach-v0", {"preset": ["wang2023"]}, "preset"),
    ("SoftArmReach-v0", {"delta_fraction": "0.1"}, "delta_fraction"),
    ("SoftArmReach-v0", {"episode_steps": "100"}, "episode_steps"),
    ("SoftArmReach-v0", {"episode_steps": 2.5}, "episode_steps"),
    ("SoftArmReach-v0", {"obs": 123}, "obs"),
    ("SoftArmTrack-v0", {"path": None}, "path"),
    ("SoftArmTrack-v0", {"path": "waypoints", "waypoints_m": "abc"}, "waypoints_m"),
    ("SoftArmTrack-v0", {"path": "waypoints", "waypoints_m": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]},
     "waypoints_m must lie within the wang2023 arm's reach of 144 mm"),
    ("SoftArmReach-v0", {"scenario": {"name": "push", "link": 1.5}}, "link"),
    ("SoftArmReach-v0", {"scenario": {"name": "push", "link": "tip"}}, "link"),
    ("SoftArmReach-v0", {"scenario": {"name": ["tip_mass"]}}, "scenario"),
    ("SoftArmReach-v0", {"action_rate_weight": float("nan")}, "action_rate_weight"),
    ("SoftArmReach-v0", {"action_rate_weight": float("inf")}, "action_rate_weight"),
    ("SoftArmReach-v0", {"settle_s": -1}, "settle_s"),
    ("SoftArmReach-v0", {"settle_s": float("nan")}, "settle_s"),
    ("SoftArmReach-v0", {"settle_s": float("inf")}, "settle_s"),
    ("SoftArmTrack-v0", {"speed_m_s": 1e-12}, "speed_m_s must be >= "),
    ("SoftArmReach-v0", {"render_mode": "rgb_array", "render_size": (0, 0)}, "render_size"),
]


@pytest.mark.parametrize("env_id, kwargs, message", CASES,
                         ids=[f"{case[0]}-{sorted(case[1])}-{i}" for i, case in enumerate(CASES)])
def test_bad_env_arguments_are_refused_by_name(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, feedback="ground_truth", **kwargs)


def test_complex_actions_are_refused_in_absolute_mode():
    env = gym.make("SoftArmReach-v0", feedback="ground_truth")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real"):
        env.step(np.array([0.1 + 0.5j, 0.0, 0.0]))
    env.close()


# ------------------------------------------------------------------------------- lifecycle
ENGINES = ["pybullet", "mujoco"]



@pytest.mark.parametrize("engine", ENGINES)
def test_a_new_env_refuses_step_until_reset(engine):
    """Made directly (no OrderEnforcing wrapper), the env itself refuses ``step`` before its
    first ``reset`` with gymnasium's ``ResetNeeded`` (also a ``RuntimeError``) saying what to
    call; after ``reset`` it steps."""
    reset_needed = gym.error.ResetNeeded
    env = SoftArmEnv(feedback="ground_truth", engine=engine)
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    with pytest.raises(reset_needed, match=r"call reset\(\) before step\(\)") as refused:
        env.step(action)
    assert isinstance(refused.value, gym.error.ResetNeeded)
    assert isinstance(refused.value, RuntimeError)
    assert env.sim.time_s == 0.0 and env.step_count == 0  # nothing moved
    env.reset(seed=0)
    _, reward, *_ = env.step(action)
    assert np.isfinite(reward)
    env.close()


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("made", ["directly", "gym.make"])
def test_a_closed_env_refuses_step_and_reset_and_closes_twice(engine, made):
    """After ``close()``: ``step`` and ``reset`` raise one clear error (gymnasium's
    ``ClosedEnvironmentError``, also a ``RuntimeError``) saying to make a new env, on either
    engine (MuJoCo stepped on, PyBullet raised ``pybullet.error``); ``close()`` again is
    harmless."""
    closed_error = gym.error.ClosedEnvironmentError
    env = (SoftArmEnv(feedback="ground_truth", engine=engine) if made == "directly"
           else gym.make(REACH, feedback="ground_truth", engine=engine))
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    env.step(action)
    env.close()
    for call in (lambda: env.step(action), lambda: env.reset(seed=0), env.reset):
        with pytest.raises(closed_error, match="closed.*make a new one") as refused:
            call()
        assert isinstance(refused.value, gym.error.ClosedEnvironmentError)
        assert isinstance(refused.value, RuntimeError)
    env.close()  # harmless
    env.close()


@pytest.mark.parametrize("copier", [lambda env: pickle.loads(pickle.dumps(env)), copy.deepcopy],
                         ids=["pickle", "deepcopy"])
@pytest.mark.parametrize("made", ["directly", "gym.make"])
def test_a_copy_of_a_reset_env_is_un_reset(copier, made):
    """A pickled or deep-copied env starts as a freshly made one (module docstring, "Copies"):
    it refuses ``step`` until its own ``reset``, even when the original had been reset and
    stepped (and gymnasium's wrapper, copied with it, believes it was)."""
    reset_needed = gym.error.ResetNeeded
    original = (SoftArmEnv(feedback="ground_truth") if made == "directly"
                else gym.make(REACH, feedback="ground_truth"))
    original.reset(seed=0)
    action = np.zeros(original.action_space.shape, dtype=np.float32)
    original.step(action)
    duplicate = copier(original)
    with pytest.raises(reset_needed, match=r"call reset\(\) before step\(\)"):
        duplicate.step(action)
    original.step(action)  # the original is untouched
    duplicate.reset(seed=0)
    duplicate.step(action)
    original.close()
    duplicate.close()


def test_a_refused_reset_argument_leaves_the_episode_running():
    """A ``reset`` refused for a bad argument changes nothing: the episode goes on."""
    env = SoftArmEnv(feedback="ground_truth", engine="mujoco")
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    env.step(action)
    for bad in ({"seed": -1}, {"options": {"recalibrate": True}}, {"options": {"nope": 1}}):
        with pytest.raises(ValueError):
            env.reset(**bad)
    env.step(action)
    assert env.step_count == 2
    env.close()
