"""The CC model controller (wang2023 eqs. (19)-(27)) on the two-segment arms (ho2018, zhao2021).

References: the CC forward map itself (a probe's fitted lengths must reproduce the displacement
they were made from), the rest-pose Jacobian (the fit's small-displacement limit), the arms'
symmetry (chambers 1 and 2 of a segment mirror each other across the x-z plane), and closed-loop
reaching on the arm.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.policies import make_policy
from soft_gym.kinematics import cc_jacobian, cc_tip_pose


def _controller(preset: str, **kwargs):
    env = gym.make("SoftArmReach-v0", preset=preset, feedback="ground_truth",
                   obs=("pose", "target"), **kwargs)
    return env, make_policy("cc_model", env=env)


@pytest.mark.parametrize("preset", ["ho2018", "zhao2021"])
def test_a_probe_fit_recovers_the_lengths_that_made_the_displacement(preset):
    env, controller = _controller(preset)
    rest, d = controller.rest_lengths, controller.d
    rng = np.random.default_rng(0)
    for segment in (0, 1):
        for _ in range(5):
            change = rng.uniform(-0.004, 0.012, 3)  # up to a large, far-from-linear bend
            lengths = rest.copy()
            lengths[3 * segment:3 * segment + 3] += change
            displacement = cc_tip_pose(lengths, d)[0] - cc_tip_pose(rest, d)[0]
            fitted = controller.segment_length_change(segment, displacement)
            np.testing.assert_allclose(fitted, change, atol=1e-7)
    env.close()


def test_a_small_probe_fit_is_the_rest_jacobian_inverse():
    env, controller = _controller("ho2018")
    jacobian = cc_jacobian(controller.rest_lengths, controller.d)
    for segment in (0, 1):
        block = jacobian[:, 3 * segment:3 * segment + 3]
        # lengths changing by microns: a long arm's tip already moves second-order (~0.4 %)
        displacement = block @ np.array([2e-6, -1e-6, 0.5e-6])
        fitted = controller.segment_length_change(segment, displacement)
        np.testing.assert_allclose(fitted, np.linalg.solve(block, displacement), rtol=1e-2,
                                   atol=2e-8)
    env.close()


@pytest.mark.parametrize("preset", ["ho2018", "zhao2021"])
def test_calibration_gives_every_chamber_a_positive_gain_with_the_arms_symmetry(preset):
    env, controller = _controller(preset)
    alpha = controller.calibrate(seed=0)
    assert alpha.shape == (6,) and np.all(np.isfinite(alpha)) and np.all(alpha > 0), alpha
    for segment in (0, 1):  # chambers at +-120 deg mirror each other across the x-z plane
        first, second = alpha[3 * segment + 1], alpha[3 * segment + 2]
        assert first == pytest.approx(second, rel=1e-3), alpha
    env.close()


def test_the_controller_reaches_a_point_with_both_segments_on_ho2018():
    target = np.array([0.03, -0.0125, 0.170])  # on the surface of the reachable tips
    env = gym.make("SoftArmReach-v0", preset="ho2018", feedback="ground_truth",
                   obs=("pose", "target"), target_m=target.tolist(), episode_steps=160)
    controller = make_policy("cc_model", env=env, kp=0.12)
    controller.calibrate(seed=0)
    observation, info = env.reset(seed=0)
    controller.reset()
    start_mm = float(np.linalg.norm(info["tip_position_m"] - target) * 1e3)
    for _ in range(160):
        action, _ = controller.predict(observation)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    final_mm = info["error_mm"]
    pressures = info["pressures_pa"]
    env.close()
    assert start_mm > 20.0 and final_mm < 3.0, (start_mm, final_mm)
    # the redundancy is used: both segments are pressurised above their pre-pressure
    spec_pre = 40_000.0
    assert pressures[:3].max() > spec_pre + 1e3 and pressures[3:].max() > spec_pre + 1e3, pressures
