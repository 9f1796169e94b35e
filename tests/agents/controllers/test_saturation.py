"""The warning a baseline gives once when its inverse cannot reach its targets
(agents/controllers/saturation.py): the watch on hand-made command sequences, and cc_model on
the upright ho2018 arm with targets below its resting tip (every chamber wants less than the
pre-pressure) against a reachable circle on wang2023."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.controllers.saturation import InfeasibleTargetWarning, SaturationWatch
from agents.policies import make_policy

LOW, HIGH = 40e3, 330e3


def _warnings(call) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    return [str(w.message) for w in caught if issubclass(w.category, InfeasibleTargetWarning)]


@pytest.mark.smoke
def test_the_watch_warns_once_after_a_run_of_fully_saturated_commands():
    watch = SaturationWatch("demo", LOW, HIGH, steps=3)
    target = np.array([0.0653, 0.0212, 0.0962])
    below, inside = np.full(3, 30e3), np.array([30e3, 100e3, 30e3])

    def commands(sequence):
        return lambda: [watch.observe(c, target) for c in sequence]

    # two saturated, one partly inside, two saturated: no run of three yet
    assert _warnings(commands([below, below, inside, below, below])) == []
    (message,) = _warnings(commands([below]))  # the third in a row
    assert message.startswith("demo: its inverse cannot reach the target (65.3, 21.2, 96.2) mm")
    assert "chambers [0, 1, 2] at the pre-pressure (40 kPa)" in message
    assert _warnings(commands([below] * 10)) == []  # once per controller, reset or not
    watch.reset()
    assert _warnings(commands([below] * 10)) == []
    mixed = SaturationWatch("demo", LOW, HIGH, steps=1)
    (message,) = _warnings(lambda: mixed.observe(np.array([400e3, 0.0, 331e3]), target))
    assert "chambers [1] at the pre-pressure (40 kPa) and chambers [0, 2] at p_max (330 kPa)" \
        in message
    # exactly at a bound is held there, not beyond it: no warning
    exact = SaturationWatch("demo", LOW, HIGH, steps=1)
    assert _warnings(lambda: exact.observe(np.array([LOW, HIGH, LOW]), target)) == []
    for steps in (0, 1.5, True):
        with pytest.raises(ValueError, match="steps must be an integer of at least 1"):
            SaturationWatch("demo", LOW, HIGH, steps=steps)


def _episode(policy, env) -> float:
    obs, info = env.reset(seed=0)
    policy.reset()
    done = False
    while not done:
        action, _ = policy.predict(obs)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    return info["error_mm"]


@pytest.mark.parametrize("name", ["cc_model", "hybrid_gpr"])
def test_cc_model_says_once_that_targets_below_the_upright_arm_are_out_of_reach(name):
    """ho2018 stands upright with its tip at rest at 161 mm; targets at z = 96 mm need shorter
    chambers than the pre-pressure gives, so every chamber is held at it and the tip never moves.
    The controller says so once, naming the target and the bound; on wang2023's reachable
    circle it says nothing."""
    circle = [(0.0687 * np.cos(a), 0.0687 * np.sin(a), 0.0962)
              for a in np.linspace(0.0, 2 * np.pi, 12, endpoint=False)]
    env = gym.make("SoftArmTrack-v0", preset="ho2018", feedback="ground_truth", path="waypoints",
                   waypoints_m=circle)
    policy = make_policy(name, env=env)
    messages = _warnings(lambda: _episode(policy, env))
    assert len(messages) == 1, messages
    assert messages[0].startswith(f"{name}: its inverse cannot reach the target (")
    assert ", 96.2) mm" in messages[0]
    assert "chambers [0, 1, 2, 3, 4, 5] at the pre-pressure (40 kPa)" in messages[0]
    assert _warnings(lambda: _episode(policy, env)) == []  # a second episode: already said
    env.close()
    reachable = gym.make("SoftArmTrackWang2023-v0", feedback="ground_truth", path="circle")
    policy = make_policy(name, env=reachable)
    errors = []
    assert _warnings(lambda: errors.append(_episode(policy, reachable))) == []
    assert errors[0] < 10.0
    reachable.close()
