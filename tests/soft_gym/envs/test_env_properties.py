"""Property-based tests of the env's input checks and physics (issue 17), with ``hypothesis``.

* Valid draws (any preset and task, action mode, reward weight, rest time, one load of any kind
  within what the arm bears, a reach target or a track speed and cycle count): the env builds,
  resets and runs 50 steps of actions in [-1, 1] with finite observations inside its observation
  space, finite rewards and the tip within the arm's largest reach (every link at its longest,
  :attr:`~soft_gym.robots.spec.ArmSpec.max_reach_m`, plus 2 %).
* Invalid draws (one argument, load parameter, reset argument or action out of its allowed range
  or of a wrong type): a ``ValueError`` whose message names the parameter.

Deterministic (``derandomize=True``) and fast (about 100 examples, well under a minute on one
core). The actions are uniform in [-1, 1] from a drawn seed, scaled by a drawn amplitude: the
ho2018 arm carrying its paper's 14 g load under bang-bang actions (every chamber at -1 or +1,
switched every 0.5 s) leaves its end stops (``PhysicsDivergedError``), a known simulator issue.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("hypothesis", reason="property tests need hypothesis (pip install hypothesis)")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import soft_gym  # noqa: E402,F401
from soft_gym.envs.config import MAX_ACTION_RATE_WEIGHT, MAX_SETTLE_S  # noqa: E402
from soft_gym.robots import get_preset  # noqa: E402
from soft_gym.robots.spec import GRAVITY_M_S2  # noqa: E402

PRESETS = ("wang2023", "ho2018", "zhao2021", "zou2022")
STEPS = 50
REACH_MARGIN = 1.02
"""The tip may be at most this factor times ``max_reach_m`` from the base."""

SETTINGS = dict(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# ------------------------------------------------------------------------------ valid draws


@st.composite
def loads(draw, preset: str):
    """One load of any kind, at most 90 % of what the arm bears (``max_load_n``)."""
    spec = get_preset(preset)
    heaviest_kg = 0.9 * spec.max_load_n / GRAVITY_M_S2
    strongest_n = 0.9 * spec.max_load_n
    kind = draw(st.sampled_from(["none", "tip_mass", "filling_load", "swaying_mass", "push",
                                 "flick"]))
    start = draw(st.floats(0.0, 2.0))
    if kind == "none":
        return None
    if kind == "tip_mass":
        return {"name": kind, "mass_kg": draw(st.floats(0.0, heaviest_kg)), "start_s": start}
    if kind == "filling_load":
        initial = draw(st.floats(0.0, heaviest_kg / 2))
        return {"name": kind, "initial_mass_kg": initial,
                "added_mass_kg": draw(st.floats(0.0, heaviest_kg / 2)),
                "rate_kg_s": draw(st.floats(1e-4, 0.1)), "start_s": start}
    if kind == "swaying_mass":
        return {"name": kind, "mass_kg": draw(st.floats(1e-3, heaviest_kg)),
                "length_m": draw(st.floats(0.005, 0.1)), "radius_m": draw(st.floats(0.002, 0.02))}
    n_links = get_preset(preset).n_segments  # at least one link per segment
    direction = draw(st.floats(0.0, 2 * math.pi))
    magnitude = draw(st.floats(0.0, strongest_n))
    force = [magnitude * math.cos(direction), magnitude * math.sin(direction), 0.0]
    link = draw(st.integers(-n_links, n_links - 1))
    if kind == "push":
        return {"name": kind, "force_n": force, "link": link, "start_s": start,
                "ramp_s": draw(st.floats(0.0, 1.0)), "end_s": start + draw(st.floats(0.1, 3.0)),
                "on_tip_cap": draw(st.booleans())}
    duration = draw(st.floats(0.01, 0.2))
    return {"name": "flick", "impulse_ns": [f * duration for f in force], "duration_s": duration,
            "link": link, "start_s": start}


@st.composite
def valid_envs(draw):
    preset = draw(st.sampled_from(PRESETS))
    task = draw(st.sampled_from(["reach", "track"]))
    kwargs = {
        "preset": preset, "task": task, "feedback": "ground_truth",
        "action_mode": draw(st.sampled_from(["absolute", "delta"])),
        "delta_fraction": draw(st.floats(1e-3, 1.0)),
        "action_rate_weight": draw(st.floats(0.0, MAX_ACTION_RATE_WEIGHT)),
        "settle_s": draw(st.floats(0.0, 1.0)),
        "scenario": draw(loads(preset)),
        "obs": draw(st.sampled_from([("pose", "target", "pressure"), ("pose",),
                                     ("pressure", "target")])),
    }
    reach = get_preset(preset).max_reach_m
    if task == "reach":
        kwargs["episode_steps"] = draw(st.integers(1, 2 * STEPS))
        if draw(st.booleans()):  # a fixed goal anywhere within reach (reachable or not)
            direction = np.array(draw(st.tuples(*[st.floats(-1.0, 1.0)] * 3))) + [0, 0, 1e-3]
            kwargs["target_m"] = (direction / np.linalg.norm(direction)
                                  * draw(st.floats(0.0, reach))).tolist()
    else:
        kwargs["path"] = draw(st.sampled_from(["circle", "pentagram", "rectangle", "spiral",
                                               "star"]))
        kwargs["cycles"] = draw(st.integers(1, 3))
        kwargs["speed_m_s"] = draw(st.floats(0.005, 0.05))
    return kwargs


@given(kwargs=valid_envs(), seed=st.integers(0, 2**31 - 1), amplitude=st.floats(0.0, 1.0))
@settings(max_examples=24, **SETTINGS)
def test_valid_configurations_run_physically(kwargs, seed, amplitude):
    env = gym.make("SoftArmReach-v0" if kwargs["task"] == "reach" else "SoftArmTrack-v0",
                   **kwargs)
    try:
        base = env.unwrapped
        reach = base.arm.max_reach_m
        observation, _ = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for step in range(STEPS):
            assert env.observation_space.contains(observation), (step, observation)
            action = (amplitude * rng.uniform(-1, 1, env.action_space.shape)).astype(np.float32)
            observation, reward, terminated, truncated, info = env.step(action)
            assert np.all(np.isfinite(observation)) and math.isfinite(reward), step
            tip_m = float(np.linalg.norm(info["tip_position_m"]))
            assert tip_m <= REACH_MARGIN * reach, (step, tip_m, reach)
            if terminated or truncated:
                observation, _ = env.reset()
    finally:
        env.close()


# ---------------------------------------------------------------------------- invalid draws
NOT_NUMBERS = st.sampled_from(["1", None, [1.0], {"a": 1}, 1j, b"1"])
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])


def _bad_non_negative(maximum: float | None = None):
    """Negative, non-finite, over ``maximum`` or not a number."""
    bad = [st.floats(max_value=-1e-9, allow_nan=False, allow_infinity=False), NON_FINITE,
           NOT_NUMBERS, st.just(True)]
    if maximum is not None:
        bad.append(st.floats(min_value=maximum * 1.001, allow_nan=False, allow_infinity=False))
    return st.one_of(bad)


def _bad_positive(maximum: float | None = None):
    return st.one_of(_bad_non_negative(maximum), st.just(0), st.just(0.0))


def _bad_integer(minimum: int = 1):
    return st.one_of(st.integers(max_value=minimum - 1), NOT_NUMBERS, st.just(True),
                     st.floats(allow_nan=True).filter(lambda v: not float(v).is_integer()),
                     st.integers(1, 100).map(float))


def _far_points(reach: float):
    """Points farther from the base than ``reach`` (m), up to 10 m."""
    return st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.01, 1),
                     st.floats(reach * 1.01, 10.0)).map(
        lambda v: (np.array(v[:3]) / np.linalg.norm(v[:3]) * v[3]).tolist())


WANG_REACH = get_preset("wang2023").max_reach_m
WANG_LOAD_KG = get_preset("wang2023").max_load_n / GRAVITY_M_S2

INVALID = {
    # parameter -> (env id, strategy of {kwargs}); the message must name the parameter
    "settle_s": ("SoftArmReach-v0", _bad_non_negative(MAX_SETTLE_S).map(
        lambda v: {"settle_s": v})),
    "action_rate_weight": ("SoftArmReach-v0", _bad_non_negative(MAX_ACTION_RATE_WEIGHT).map(
        lambda v: {"action_rate_weight": v})),
    "episode_steps": ("SoftArmReach-v0", _bad_integer().map(lambda v: {"episode_steps": v})),
    "delta_fraction": ("SoftArmReach-v0", st.one_of(
        _bad_positive(), st.floats(min_value=1.0001, allow_nan=False)).map(
        lambda v: {"action_mode": "delta", "delta_fraction": v})),
    "speed_m_s": ("SoftArmTrack-v0", st.one_of(  # None is the default speed
        _bad_positive().filter(lambda v: v is not None), st.floats(1e-300, 1e-6)).map(
        lambda v: {"speed_m_s": v})),
    "cycles": ("SoftArmTrack-v0", _bad_integer().map(lambda v: {"cycles": v})),
    "target_m": ("SoftArmReach-v0", st.one_of(  # None: a random reachable goal
        _far_points(WANG_REACH), NOT_NUMBERS.filter(lambda v: v is not None)).map(
        lambda v: {"target_m": v})),
    "waypoints_m": ("SoftArmTrack-v0", st.lists(_far_points(WANG_REACH), min_size=2,
                                                max_size=5).map(
        lambda v: {"path": "waypoints", "waypoints_m": v})),
    "render_size": ("SoftArmReach-v0", st.one_of(
        st.tuples(st.integers(max_value=0), st.integers(1, 100)),
        st.tuples(st.integers(1, 100), st.integers(min_value=4097)),
        st.tuples(st.floats(1, 100), st.floats(1, 100))).map(
        lambda v: {"render_mode": "rgb_array", "render_size": v})),
    "mass_kg": ("SoftArmReach-v0", st.one_of(
        _bad_non_negative(), st.floats(WANG_LOAD_KG * 1.01, 1e9)).map(
        lambda v: {"scenario": {"name": "tip_mass", "mass_kg": v}})),
    "force_n": ("SoftArmReach-v0", st.one_of(
        st.floats(get_preset("wang2023").max_load_n * 1.01, 1e12).map(lambda f: [f, 0.0, 0.0]),
        st.sampled_from([[math.nan, 0, 0], "x", [1.0, 0.0], 1.0])).map(
        lambda v: {"scenario": {"name": "push", "force_n": v}})),
    "link": ("SoftArmReach-v0", st.one_of(
        st.integers(min_value=100), st.integers(max_value=-100), NOT_NUMBERS,
        st.floats(allow_nan=True), st.just(True)).map(
        lambda v: {"scenario": {"name": "push", "link": v}})),
    "start_s": ("SoftArmReach-v0", _bad_non_negative().map(
        lambda v: {"scenario": {"name": "tip_mass", "start_s": v}})),
    "length_m": ("SoftArmReach-v0", _bad_positive(0.5).map(
        lambda v: {"scenario": {"name": "swaying_mass", "length_m": v}})),
    "rate_kg_s": ("SoftArmReach-v0", _bad_positive(1.0).map(
        lambda v: {"scenario": {"name": "filling_load", "rate_kg_s": v}})),
    "stiffness_scale": ("SoftArmReach-v0", st.one_of(
        st.tuples(st.floats(0.0, 0.59), st.floats(0.6, 5.0)),
        st.tuples(st.floats(0.6, 5.0), st.floats(5.01, 1e9)), NOT_NUMBERS).map(
        lambda v: {"randomization": {"stiffness_scale": v}})),
}


@given(parameter=st.sampled_from(sorted(INVALID)), data=st.data())
@settings(max_examples=80, **SETTINGS)
def test_invalid_arguments_are_refused_by_name(parameter, data):
    env_id, strategy = INVALID[parameter]
    kwargs = data.draw(strategy, label=parameter)
    with pytest.raises(ValueError, match=parameter):
        gym.make(env_id, feedback="ground_truth", **kwargs)


@pytest.fixture(scope="module")
def reach_env():
    env = gym.make("SoftArmReach-v0", feedback="ground_truth")
    env.reset(seed=0)
    yield env
    env.close()


BAD_ACTIONS = st.one_of(
    st.lists(st.floats(-1, 1), min_size=0, max_size=6).filter(lambda v: len(v) != 3),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.one_of(
        st.floats(min_value=1.001), st.floats(max_value=-1.001), NON_FINITE)).map(list),
    st.tuples(st.floats(-1, 1), st.sampled_from([1j, "a", None, [0.0]]),
              st.floats(-1, 1)).map(list),
    st.lists(st.booleans(), min_size=3, max_size=3).map(np.array),
)


@given(action=BAD_ACTIONS)
@settings(max_examples=40, **SETTINGS)
def test_invalid_actions_are_refused_by_name(reach_env, action):
    with pytest.raises(ValueError, match="action"):
        reach_env.step(action)


@given(seed=st.one_of(st.integers(max_value=-1), NOT_NUMBERS.filter(lambda v: v is not None),
                      st.floats(), st.just(True)))
@settings(max_examples=20, **SETTINGS)
def test_invalid_seeds_are_refused_by_name(reach_env, seed):
    with pytest.raises(ValueError, match="seed"):
        reach_env.reset(seed=seed)
