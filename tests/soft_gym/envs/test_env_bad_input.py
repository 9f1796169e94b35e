"""Every kind of bad input to the env gets a ``ValueError`` naming the parameter (issue 17).

Constructor keyword arguments (through ``gymnasium.make``, as users call it), every scenario
element's parameters, randomisation ranges, ``reset`` arguments and ``step`` actions: a wrong
type, a non-finite or out-of-range value, a value the env would silently ignore, truncate or
clip, or one that would hang or throw the physics out of range is refused by name. Also: pickled
and deep-copied envs are independent envs of the same configuration.

The parametrised cases come from a bad-input sweep of the env (about 300 inputs); each case is
``(id, kwargs, pattern)`` with ``pattern`` a regular expression the message must match, normally
the parameter's name.
"""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from soft_gym.envs.config import MAX_ACTION_RATE_WEIGHT, MAX_SETTLE_S
from soft_gym.envs.soft_arm_env import SoftArmEnv
from soft_gym.scenarios import FillingLoad, Flick, ObstacleRod, Push, SwayingMass, TipMass
from soft_gym.scenarios.loads import (MAX_FILL_RATE_KG_S, MAX_FORCE_N, MAX_MASS_KG,
                                      MAX_SWAY_LENGTH_M)
from soft_gym.scenarios.randomization import RandomizationConfig
from soft_gym.robots.spec import ArmSpec
from soft_gym.robots import get_preset

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


def test_complex_actions_are_refused():
    env = gym.make(REACH, feedback="ground_truth", action_mode="delta")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real"):
        env.step(np.array([0.1 + 0.5j, 0.0, 0.0]))
    env.close()


def test_good_inputs_of_odd_types_are_accepted():
    """What the checks must not refuse: numpy integers and floats, lists, float32 actions."""
    env = gym.make(TRACK, feedback="ground_truth", cycles=np.int64(1), speed_m_s=np.float32(0.01),
                   settle_s=0, episode_steps=np.int64(5), action_rate_weight=np.float64(0.01),
                   path=("circle", "star"), sensors=["em"], render_size=[64, 48])
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
