"""zhao2021's local inverse-kinematics controller with ASDM (eqs. 13-20).

References: a linear plant ``Q = J A`` whose exact local inverse makes eq. (16)'s steps exactly
``d`` long, so step counts follow from the distance; ASDM's rule (eq. 18) checked sign by sign;
the network against its training data; the closed loop on the simulated arm with a small model.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.controllers.local_ik_asdm import LocalIKASDMController
from agents.controllers.saturation import SaturationWatch
from agents.learners.local_ik import LocalIKNetwork
from agents.policies import make_policy

OBS = ("pose", "target", "strain", "pressure")
SMALL = {"n_free": 240, "n_loaded": 120}


class _LinearPlantInverse:
    """The exact local inverse of ``Q = J A`` (m per Pa), scaled by ``gain``: a network that
    under-reaches when ``gain < 1``."""

    def __init__(self, jacobian: np.ndarray, gain: float = 1.0) -> None:
        self.pinv = np.linalg.pinv(jacobian)
        self.gain = gain

    def predict(self, pressures_pa, position_m, desired_m, readings):
        return pressures_pa + self.gain * self.pinv @ (desired_m - position_m)


@pytest.fixture(scope="module")
def env():
    env = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="ground_truth", obs=OBS)
    yield env
    env.close()


def _run_plant(controller, gain: float, start_mm, goal_mm, steps: int = 200):
    """Closed loop of ``decide`` on ``Q = J A``; returns the distance after every step (mm)."""
    rng = np.random.default_rng(0)
    jacobian = rng.normal(0.0, 1.0, (3, 6)) * 2e-7         # ~0.2 mm per kPa
    controller.network = _LinearPlantInverse(jacobian, gain)
    controller.p_low = np.full(6, -1e9)
    controller.p_high = np.full(6, 1e9)  # an unbounded plant: only the method is under test
    controller.saturation = SaturationWatch(controller.name, controller.p_low, controller.p_high,
                                            steps=3)
    pressures = np.linalg.pinv(jacobian) @ (np.asarray(start_mm) / 1000.0)
    goal = np.asarray(goal_mm) / 1000.0
    distances = []
    for _ in range(steps):
        position = jacobian @ pressures
        pressures = controller.decide(pressures, position, goal, np.zeros(6))
        distances.append(np.linalg.norm(jacobian @ pressures - goal) * 1000.0)
        if controller.history[-1]["reached"]:
            break
    return np.array(distances)


def test_fixed_step_distance_reaches_the_goal_in_distance_over_d_steps(env):
    controller = LocalIKASDMController(env, step_mm=8.0, adaptive=False, cache=False)
    distances = _run_plant(controller, 1.0, (40.0, 20.0, 0.0), (-50.0, 70.0, 0.0))
    start = np.hypot(90.0, 50.0)
    assert len(distances) == pytest.approx(np.ceil((start - 4.0) / 8.0) + 1, abs=1)
    assert controller.history[-1]["reached"]
    assert all(r["step_mm"] == 8.0 for r in controller.history)
    # eq. (16) without a cap: the last steps overshoot by up to d, so a d = 8 run ends by
    # crossing the goal rather than landing on it
    assert controller.history[-1]["distance_mm"] <= 4.0


def test_asdm_grows_the_step_when_the_arm_under_reaches(env):
    fixed = LocalIKASDMController(env, step_mm=2.0, adaptive=False, cache=False)
    slow = _run_plant(fixed, 0.5, (0.0, 0.0, 0.0), (60.0, 0.0, 0.0), steps=400)
    asdm = LocalIKASDMController(env, step_mm=8.0, adaptive=True, cache=False)
    fast = _run_plant(asdm, 0.5, (0.0, 0.0, 0.0), (60.0, 0.0, 0.0), steps=400)
    steps = [r["step_mm"] for r in asdm.history]
    assert steps[1] > steps[0]                # moved towards the plan, fell short: d grows
    assert max(steps) <= 15.0 and min(steps) >= 2.0
    assert len(fast) < len(slow) / 2


@pytest.mark.smoke
def test_asdm_rule_signs(env):
    controller = LocalIKASDMController(env, step_mm=8.0, adaptive=True, gain=0.12, cache=False)
    controller.network = _LinearPlantInverse(np.eye(3, 6) * 1e-6)
    a, s = np.zeros(6), np.zeros(6)
    goal = np.array([0.1, 0.0, 0.0])
    controller.decide(a, np.zeros(3), goal, s)              # plans 8 mm along +x
    controller.decide(a, np.array([0.004, 0.0, 0.0]), goal, s)  # moved 4 mm of the 8
    assert controller.step_distance_mm == pytest.approx(8.0 + 0.12 * 4.0)
    d = controller.step_distance_mm
    controller.decide(a, np.array([0.001, 0.0, 0.0]), goal, s)  # moved back, away from plan
    planned = 4.0 + d
    assert controller.step_distance_mm == pytest.approx(d - 0.12 * (planned - 1.0))


def test_bad_options_are_refused(env):
    for name, value in (("step_mm", 1.0), ("step_mm", 16.0), ("gain", -0.1),
                        ("tolerance_mm", 0.0), ("adaptive", "yes")):
        with pytest.raises(ValueError, match=name):
            make_policy("local_ik_asdm", env=env, **{name: value})
    with pytest.raises(ValueError, match="strain"):
        small = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="ground_truth",
                         obs=("pose", "target"))
        make_policy("local_ik_asdm", env=small)
    with pytest.raises(ValueError, match="options"):
        make_policy("local_ik_asdm", env=env, exploration={"samples": 3})


@pytest.mark.slow  # 45 s: the exploration of 900 steps
def test_network_learns_the_exploration_and_reloads_identically(tmp_path):
    from soft_gym.robots.presets import get_preset
    from soft_gym.papers.zhao2021.exploration import collect_exploration
    from soft_gym.sensors.strain_gauge import StrainGauges

    # 900 steps: the arm's bores balloon above 0.5 bar, so a 0.05 bar step moves the tip 2-22 mm
    # (10th-90th percentile) and the inverse needs more of them than a linear arm's would
    data = collect_exploration(get_preset("zhao2021"), StrainGauges(), n_free=900, n_loaded=0,
                               progress=False)
    network = LocalIKNetwork(6, 6, 80e3)
    report = network.fit(data.pressures_pa, data.key_points_m[:, -1], data.readings,
                         max_iterations=100, batch_size=64, learning_rate=1e-2, progress=False)
    # the change of pressure it predicts points the way the exploration went
    p, tips, s = data.pressures_pa, data.key_points_m[:, -1], data.readings
    predicted = np.array([network.predict(p[i], tips[i], tips[i + 1], s[i]) - p[i]
                          for i in range(len(p) - 1)])
    correlation = np.corrcoef(predicted.ravel(), np.diff(p, axis=0).ravel())[0, 1]
    assert correlation > 0.4, (correlation, report)
    path = tmp_path / "ik.bin"
    network.save(path)
    loaded = LocalIKNetwork.load(path)
    assert np.array_equal(loaded.predict(p[3], tips[3], tips[4], s[3]),
                          network.predict(p[3], tips[3], tips[4], s[3]))
    path.write_bytes(path.read_bytes()[:-10])
    with pytest.raises(ValueError, match="ik.bin"):
        LocalIKNetwork.load(path)


def test_delta_action_mode_ramps_the_env_to_the_decided_actuation():
    env = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="ground_truth", obs=OBS,
                   action_mode="delta", target_m=(0.02, 0.0, 0.28))
    try:
        controller = LocalIKASDMController(env, step_mm=8.0, cache=False)
        jacobian = np.random.default_rng(1).normal(0.0, 1.0, (3, 6)) * 2e-7
        controller.network = _LinearPlantInverse(jacobian)
        observation, _ = env.reset(seed=0)
        for _ in range(controller.hold_steps):
            action, _ = controller.predict(observation)
            assert env.action_space.contains(action)
            observation, *_ = env.step(action)
        decided = controller.history[0]["pressures_pa"]
        assert np.allclose(env.unwrapped.sim.supply.command_pa, decided, atol=1.0)
    finally:
        env.close()


def test_controller_saves_and_loads_back_identically(env, tmp_path):
    rng = np.random.default_rng(0)
    pressures = rng.uniform(0.0, 80e3, (40, 6))
    network = LocalIKNetwork(6, 6, 80e3)
    network.fit(pressures, rng.normal(0.0, 0.01, (40, 3)), rng.normal(0.0, 1e-3, (40, 6)),
                max_iterations=3, progress=False)
    controller = LocalIKASDMController(env, step_mm=5.0, adaptive=False, gain=0.2, cache=False)
    controller.network = network
    path = tmp_path / "controller.bin"
    controller.save(path)
    loaded = LocalIKASDMController.load(path, env=env)
    assert (loaded.step_mm, loaded.adaptive, loaded.gain) == (5.0, False, 0.2)
    args = (pressures[0], np.array([0.0, 0.0, 0.25]), np.array([0.0, 0.01, 0.25]), np.zeros(6))
    assert np.array_equal(loaded.network.predict(*args), network.predict(*args))
    path.write_bytes(path.read_bytes()[:-7])
    with pytest.raises(ValueError, match="controller.bin"):
        LocalIKASDMController.load(path, env=env)


def test_the_first_build_shows_progress_of_its_exploration_and_training(env, capsys):
    """The first build (exploration, then training) shows tqdm bars on stderr; with
    ``progress=False`` it is silent, and the setting does not change the network."""
    exploration = {"n_free": 60, "n_loaded": 0}
    shown = LocalIKASDMController(env, exploration=exploration, max_iterations=5, cache=False)
    shown.pretrain()
    err = capsys.readouterr().err
    assert "zhao2021 exploration" in err and "/60" in err
    assert "local IK training" in err and "/5" in err
    quiet = LocalIKASDMController(env, exploration=exploration, max_iterations=5, cache=False,
                                  progress=False)
    quiet.pretrain()
    assert capsys.readouterr().err == ""
    assert quiet.training == shown.training
    with pytest.raises(ValueError, match="progress must be True or False, got 'yes'"):
        make_policy("local_ik_asdm", env=env, progress="yes")
