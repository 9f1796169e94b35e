"""Bad input to the env gets a ValueError that names the parameter, never a TypeError from deep
inside, a NaN reward, a silent truncation or a runaway allocation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401

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


def test_complex_actions_are_refused():
    env = gym.make("SoftArmReach-v0", feedback="ground_truth")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real"):
        env.step(np.array([0.1 + 0.5j, 0.0, 0.0]))
    env.close()
