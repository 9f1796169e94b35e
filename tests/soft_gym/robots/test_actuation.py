"""The actuation module: chamber angles, the two action modes' maps and their inverses, and the
baselines driving either mode through them."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from eval.runner import RunConfig, run
from soft_gym import kinematics
from soft_gym.robots import get_preset
from soft_gym.robots.actuation import (ACTION_MODES, CHAMBER_ANGLES_RAD, Actuation,
                                       absolute_action, absolute_pressure, chamber_angles,
                                       delta_action, delta_pressure, pressure_at_fraction)

SPEC = get_preset("ho2018")  # two segments, p_pre = 40 kPa, p_max = 110 kPa


def test_one_copy_of_the_chamber_angles():
    np.testing.assert_allclose(CHAMBER_ANGLES_RAD, 2.0 * np.pi * np.arange(3) / 3.0)
    assert kinematics.CHAMBER_ANGLES is CHAMBER_ANGLES_RAD
    assert SPEC.segments[0].chamber_angles_rad is CHAMBER_ANGLES_RAD
    assert not CHAMBER_ANGLES_RAD.flags.writeable
    np.testing.assert_array_equal(chamber_angles(2), np.tile(CHAMBER_ANGLES_RAD, 2))
    with pytest.raises(ValueError, match="n_segments"):
        chamber_angles(0)


@pytest.mark.smoke
def test_absolute_map_is_the_documented_formula_and_round_trips():
    rng = np.random.default_rng(0)
    low, high = SPEC.p_pre_pa, SPEC.p_max_pa
    for _ in range(20):
        action = rng.uniform(-1.0, 1.0, SPEC.n_chambers)
        pressure = absolute_pressure(SPEC, action)
        np.testing.assert_allclose(pressure, low + (action + 1.0) / 2.0 * (high - low), rtol=1e-15)
        np.testing.assert_allclose(absolute_action(SPEC, pressure), action, atol=1e-12)
    np.testing.assert_allclose(absolute_pressure(SPEC, -np.ones(6)), low)
    np.testing.assert_allclose(absolute_pressure(SPEC, np.ones(6)), high)
    # pressures outside [p_pre, p_max] saturate
    np.testing.assert_array_equal(absolute_action(SPEC, low - 1e3), -np.ones(6))
    np.testing.assert_array_equal(absolute_action(SPEC, high + 1e3), np.ones(6))
    np.testing.assert_allclose(pressure_at_fraction(SPEC, 0.25), low + 0.25 * (high - low))


@pytest.mark.smoke
def test_delta_map_is_the_documented_formula_and_its_inverse_reaches_the_wanted_pressure():
    rng = np.random.default_rng(1)
    low, high = SPEC.p_pre_pa, SPEC.p_max_pa
    fraction = 0.1
    for _ in range(20):
        previous = rng.uniform(low, high)
        action = rng.uniform(-1.0, 1.0, SPEC.n_chambers)
        np.testing.assert_allclose(delta_pressure(SPEC, action, previous, fraction),
                                   np.clip(previous + action * fraction * high, low, high))
        # a wanted pressure within one step is reached exactly, a farther one in one full step
        near = np.clip(previous + rng.uniform(-0.9, 0.9, 6) * fraction * high, low, high)
        step = delta_action(SPEC, near, previous, fraction)
        np.testing.assert_allclose(delta_pressure(SPEC, step, previous, fraction), near,
                                   rtol=1e-12)
        far = previous + 3.0 * fraction * high
        assert np.all(delta_action(SPEC, far, previous, fraction)[far <= high] == 1.0)


@pytest.mark.parametrize("mode", ACTION_MODES)
def test_actuation_round_trips_in_float32_actions(mode):
    actuation = Actuation(SPEC, mode, delta_fraction=0.2)
    rng = np.random.default_rng(2)
    command = actuation.initial_command_pa.copy()
    np.testing.assert_array_equal(command, SPEC.p_pre_pa)
    for _ in range(50):
        wanted = command + rng.uniform(-0.15, 0.15, 6) * SPEC.p_max_pa
        wanted = np.clip(wanted, SPEC.p_pre_pa, SPEC.p_max_pa)
        action = actuation.action(wanted, command)
        assert action.dtype == np.float32 and np.all(np.abs(action) <= 1.0)
        command = actuation.pressure(action, command)
        np.testing.assert_allclose(command, wanted, atol=1e-6 * SPEC.p_max_pa.max())


@pytest.mark.parametrize("mode", ACTION_MODES)
def test_actuation_gives_the_commands_the_env_gives(mode):
    """The env's own step map and the module agree on every command (what the env will call)."""
    env = gym.make("SoftArmReach-v0", preset="ho2018", feedback="ground_truth", action_mode=mode,
                   delta_fraction=0.15)
    env.reset(seed=0)
    actuation = Actuation.of_env(env)
    assert (actuation.mode, actuation.delta_fraction) == (mode, 0.15)
    command = actuation.initial_command_pa
    env.action_space.seed(0)
    for _ in range(10):
        action = env.action_space.sample()
        env.step(action)
        command = actuation.pressure(action, command)
        np.testing.assert_allclose(env.unwrapped.sim.supply.command_pa, command, rtol=1e-12)
    env.close()


@pytest.mark.parametrize("kwargs, name", [
    ({"mode": "sideways"}, "action_mode"),
    ({"mode": "delta", "delta_fraction": 0.0}, "delta_fraction"),
    ({"mode": "delta", "delta_fraction": 1.5}, "delta_fraction"),
    ({"mode": "delta", "delta_fraction": "0.1"}, "delta_fraction"),
])
def test_bad_actuation_settings_raise_naming_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name) as error:
        Actuation(SPEC, **kwargs)
    if name == "action_mode":
        assert "sideways" in str(error.value) and "absolute" in str(error.value)


def test_delta_mode_needs_the_previous_command():
    actuation = Actuation(SPEC, "delta")
    with pytest.raises(ValueError, match="previous_command_pa"):
        actuation.pressure(np.zeros(6))
    with pytest.raises(ValueError, match="previous_command_pa"):
        actuation.action(SPEC.p_pre_pa)


def _last_cycle(policy: str, mode: str) -> tuple[float, np.ndarray]:
    record = run(RunConfig(policy=policy, policy_params={"kp": 0.1},
                           env_kwargs={"path": "circle", "cycles": 2, "feedback": "ground_truth",
                                       "action_mode": mode}))
    last = record["cycle"] == record["cycle"].max()
    return float(np.mean(record["error_mm"][last])), record["action"]


@pytest.mark.parametrize("policy", ["cc_model", "hybrid_gpr"])
def test_baselines_track_as_well_in_delta_mode_as_in_absolute_mode(policy):
    """The controllers decide pressures; in delta mode they step the command to them, which
    the slow pressure changes of tracking (well under delta_fraction * p_max per step) allow."""
    absolute, absolute_actions = _last_cycle(policy, "absolute")
    delta, delta_actions = _last_cycle(policy, "delta")
    assert abs(delta - absolute) <= 0.05 * absolute + 0.05, (absolute, delta)
    # the delta run really sent increments: small actions once the arm is under way
    assert np.abs(delta_actions[50:]).mean() < 0.2 * np.abs(absolute_actions[50:]).mean()
