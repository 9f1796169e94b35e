"""Point-to-point reach episodes (zhao2021 Section V-B): a fixed goal ``target_m``, a start
``start_m`` reached during ``reset`` and a ``tolerance_mm`` that ends the episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import soft_gym  # noqa: F401
from soft_gym.robots import get_preset
from soft_gym.procedures.workspace import reachable_tips

TIPS = reachable_tips(get_preset("wang2023"))
START, GOAL = TIPS[3], TIPS[7]


def _env(**kwargs):
    return gym.make("SoftArmReach-v0", preset="wang2023", feedback="ground_truth", **kwargs)


@pytest.mark.parametrize("action_mode", ["absolute", "delta"])
def test_reset_drives_the_tip_to_the_start_and_the_clock_starts_at_zero(action_mode):
    env = _env(start_m=START, target_m=GOAL, action_mode=action_mode)
    _, info = env.reset(seed=0)
    assert np.linalg.norm(info["tip_position_m"] - START) < 2e-3
    assert info["time_s"] == 0.0 and info["step"] == 0
    np.testing.assert_array_equal(info["target_m"], GOAL)
    # the command starts at the pressures found: holding them keeps the tip at the start
    hold = env.unwrapped.actuation.action(info["pressures_pa"], info["pressures_pa"])
    if action_mode == "delta":
        hold = np.zeros_like(hold)
    for _ in range(10):
        _, _, _, _, info = env.step(hold)
    assert np.linalg.norm(info["tip_position_m"] - START) < 2e-3
    env.close()


def test_the_episode_terminates_within_the_tolerance_and_reports_its_steps():
    env = _env(start_m=START, target_m=START, tolerance_mm=3.0, episode_steps=50)
    _, info = env.reset(seed=0)
    hold = env.unwrapped.actuation.action(info["pressures_pa"])
    _, _, terminated, truncated, info = env.step(hold)
    assert terminated and not truncated and info["step"] == 1
    far = _env(start_m=START, target_m=GOAL, tolerance_mm=0.5, episode_steps=3)
    far.reset(seed=0)
    results = [far.step(np.zeros(3, dtype=np.float32))[2:4] for _ in range(3)]
    assert results == [(False, False), (False, False), (False, True)]
    env.close()
    far.close()


def test_fixed_goal_is_the_same_every_episode_and_the_env_passes_the_checker():
    env = _env(target_m=GOAL, start_m=START, tolerance_mm=2.0)
    targets = [env.reset(seed=seed)[1]["target_m"] for seed in range(3)]
    assert all(np.array_equal(target, GOAL) for target in targets)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_bad_point_to_point_settings_are_refused_by_name():
    with pytest.raises(ValueError, match="start_m must lie within"):
        _env(start_m=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="target_m must have shape"):
        _env(target_m=(0.0, 0.1))
    with pytest.raises(ValueError, match="tolerance_mm"):
        _env(tolerance_mm=-1.0)
    with pytest.raises(ValueError, match="reach task"):
        gym.make("SoftArmTrack-v0", preset="wang2023", feedback="ground_truth", target_m=GOAL)
    env = _env(start_m=(0.0, 0.0, 0.02))  # within reach of the base, but the arm cannot shrink so
    with pytest.raises(ValueError, match=r"start_m=.*out of the wang2023 arm's reach"):
        env.reset(seed=0)
    env.close()
