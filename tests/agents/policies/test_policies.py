"""Baselines: the CC model controller and the hybrid CC + GPR controller (wang2023 Tables I-II:
their K_p sweep is the claims ledger's, ``tests/eval/claims/test_quick_claims.py``).

Ground-truth feedback keeps these fast; the runner drives the same policies with fused feedback.
"""

from __future__ import annotations

import io
import json
import os
import pickle
import re
import shutil
import zipfile
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.controllers.cc_model import CCModelController
from agents.controllers.hybrid_gpr import HybridGPRController
from agents.controllers.local_ik_asdm import LocalIKASDMController
from agents.controllers.lwpr_rwr import LWPRRWRController
from agents.learners.local_ik import LocalIKNetwork
from agents.learners.lwpr import LWPR
from agents.learners.rwr_inverse import RewardWeightedInverse
from agents.learners.sliding_gp import SlidingWindowGP
from agents.policies import (BASELINES, NORMALIZATION_MARK, PolicyRefusal, SB3Policy,
                             SHIPPED_DIR, check_observation, make_policy, mark_model_file,
                             model_normalization_mark)
from agents.rollout import run_episode
from eval.runner import RunConfig, run
from soft_gym._model_files import write_model_state
from soft_gym.envs import SoftArmEnv


def test_probe_calibration_estimates_a_positive_linear_gain_per_chamber():
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("cc_model", env=env)
    alpha = policy.calibrate()
    assert alpha.shape == (3,) and np.all(alpha > 0)
    # symmetric arm: the three chambers' gains agree within 1 %
    assert np.ptp(alpha) / alpha.mean() < 0.01


@pytest.mark.smoke
@pytest.mark.parametrize("name", ["cc_model", "hybrid_gpr"])
def test_a_baseline_calibrates_on_first_predict_without_touching_the_env(name):
    """make_policy(name, env=env) predicts in a plain loop: the first predict() calibrates on a
    private copy of the env, leaving the env's episode as it was, with the alpha that
    calibrate() finds on a fresh env."""
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy(name, env=env)
    observation, _ = env.reset(seed=0)
    sim = env.unwrapped.sim
    before = (sim.time_s, np.array(sim.tip_pose()[0]), env.unwrapped.np_random.bit_generator.state)
    action, _ = policy.predict(observation)
    assert sim.time_s == before[0]
    np.testing.assert_array_equal(sim.tip_pose()[0], before[1])
    assert env.unwrapped.np_random.bit_generator.state == before[2]
    assert env.action_space.contains(action)
    observation, *_ = env.step(action)  # the loop goes on from where it was

    explicit = make_policy(name, env=gym.make("SoftArmTrack-v0", feedback="ground_truth"))
    np.testing.assert_array_equal(policy.alpha, explicit.calibrate())
    env.close()


def test_hybrid_save_and_load_keep_the_learned_window(tmp_path):
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("hybrid_gpr", env=env, kp=0.06)
    policy.calibrate()
    run_episode(env, policy, seed=0)
    policy.save(tmp_path / "hybrid")
    loaded = type(policy).load(tmp_path / "hybrid", env=env)
    assert len(loaded.gp) == len(policy.gp) and loaded.samples == policy.samples
    observation, _ = env.reset(seed=1)
    policy.reset()
    loaded.reset()
    np.testing.assert_array_equal(policy.predict(observation)[0], loaded.predict(observation)[0])


def test_bad_policy_requests_raise():
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    with pytest.raises(ValueError, match="policy"):
        make_policy("pid", env=env)
    with pytest.raises(ValueError, match="kp"):
        make_policy("cc_model", env=env, kp=-1.0)
    with pytest.raises(ValueError, match="calibrate"):  # no spec: nothing to calibrate on
        make_policy("cc_model", env=SoftArmEnv(feedback="ground_truth")).predict(
            env.reset(seed=0)[0])
    with pytest.raises(ValueError, match="obs"):
        make_policy("cc_model", env=gym.make("SoftArmTrack-v0", feedback="ground_truth",
                                             obs=("pressure",)))


def test_hybrid_compensation_never_reverses_or_overturns_a_command():
    """Eq. (29) with a bounded learned error: the compensated command keeps a positive gain
    along the desired motion, within [1 + min, 1 + max], and turns by at most max_turn_deg."""
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    policy = make_policy("hybrid_gpr", env=env, kp=0.06, max_turn_deg=30.0)
    rng = np.random.default_rng(0)
    for _ in range(500):
        desired = rng.normal(size=3)
        direction = desired / np.linalg.norm(desired)
        relative = rng.normal(scale=5.0, size=3)
        command = desired + policy.bounded_error(relative, direction) * np.linalg.norm(desired)
        gain = command @ direction / np.linalg.norm(desired)
        assert 1 + policy.min_relative_error - 1e-12 <= gain <= 1 + policy.max_relative_error + 1e-12
        angle = np.degrees(np.arccos(np.clip(command @ direction / np.linalg.norm(command), -1, 1)))
        assert angle <= 30.0 + 1e-9


def test_hybrid_improves_on_the_model_with_noisy_em_feedback():
    """With the EM tracker's 0.8 mm noise the compensator still learns (no divergence)."""
    errors = {}
    for policy in ("cc_model", "hybrid_gpr"):
        record = run(RunConfig(policy=policy, policy_params={"kp": 0.04},
                               env_kwargs={"path": "circle", "cycles": 3, "feedback": "em"}))
        last = record["cycle"] == record["cycle"].max()
        errors[policy] = (float(np.mean(record["error_mm"][last])),
                          float(np.max(record["error_mm"][last])))
    assert errors["hybrid_gpr"][0] <= 0.5 * errors["cc_model"][0], errors
    assert errors["hybrid_gpr"][1] < errors["cc_model"][1], errors


# ==========================================================================================
# Bad input to the policies and their saved models (issue 17): one clear ``ValueError``
#
# * :func:`agents.policies.make_policy` with a wrong name, env or parameter names the parameter, the
#   value and what is allowed;
# * every baseline's ``predict`` refuses a malformed observation (NaN, inf, wrong shape, strings,
#   objects, complex numbers, ...) *before* touching its state, so the next clean observation gets
#   the action it would have got had the bad one never come;
# * an ``sb3:`` agent is checked against the env's observation *and* action spaces;
# * saved models (``sb3:`` directories and files, the baselines' and learners' files) that are
#   missing, empty, truncated, random bytes, text, foreign or inconsistent are refused with exactly
#   one ``ValueError`` (not a subclass such as ``JSONDecodeError``) naming the file; what is saved
#   loads back identically.
# ==========================================================================================


SHIPPED = SHIPPED_DIR / "sac_wang2023_track"
ZHAO_OBS = ("pose", "target", "strain", "pressure")


def _refused(match: str, call: Callable[[], Any], kind: type = ValueError) -> str:
    """``call()`` raises exactly ``kind`` (no subclass: ``ValueError``, or the declared refusal
    of an env, ``PolicyRefusal``) whose message matches ``match``; returns the message."""
    with pytest.raises(ValueError) as info:
        call()
    assert type(info.value) is kind, f"{type(info.value).__name__}: {info.value}"
    message = str(info.value)
    assert re.search(match, message), message
    return message


def _named(path: Path) -> str:
    return re.escape(str(path))


@pytest.fixture(scope="module")
def track():
    env = gym.make("SoftArmTrack-v0", feedback="ground_truth")
    yield env
    env.close()


@pytest.fixture(scope="module")
def zhao():
    env = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="ground_truth", obs=ZHAO_OBS)
    yield env
    env.close()


# --------------------------------------------------------------------------- make_policy
@pytest.mark.parametrize("name", [123, None, 1.5, ["cc_model"], {"name": "cc_model"}, "pid", ""])
def test_make_policy_refuses_a_bad_name_listing_the_allowed_ones(track, name):
    message = _refused("policy", lambda: make_policy(name, env=track))
    assert "cc_model" in message and "sb3:PATH" in message


@pytest.mark.parametrize("env", [None, 123, "SoftArmTrack-v0", object()])
@pytest.mark.parametrize("name", sorted(BASELINES))
def test_make_policy_refuses_what_is_no_soft_arm_env(name, env):
    _refused(r"env must be the soft-arm environment", lambda: make_policy(name, env=env))


def test_make_policy_refuses_another_gymnasium_env():
    other = gym.make("CartPole-v1")
    _refused(r"env must be the soft-arm environment.*CartPole", lambda: make_policy("cc_model",
                                                                                  env=other))


@pytest.mark.parametrize("name", sorted(BASELINES))
def test_make_policy_refuses_unknown_parameters_listing_the_known_ones(track, name):
    message = _refused(rf"policy '{name}' parameters must be among .*\['no_such_option'\]",
                       lambda: make_policy(name, env=track, no_such_option=1))
    assert "seed" in message or "kp" in message


@pytest.mark.parametrize("name, params, match", [
    ("cc_model", {"kp": "fast"}, r"kp must be a real number, got 'fast'"),
    ("cc_model", {"kp": float("nan")}, r"kp must be a finite number > 0"),
    ("cc_model", {"probe_fraction": "a"}, r"probe_fraction must be a real number"),
    ("cc_model", {"probe_fraction": True}, r"probe_fraction must be a real number, got True"),
    ("cc_model", {"probe_fraction": 0.0}, r"probe_fraction must be in \(0, 1\]"),
    ("cc_model", {"probe_fraction": float("nan")}, r"probe_fraction must be in \(0, 1\]"),
    ("cc_model", {"probe_steps": 2.5}, r"probe_steps must be an integer >= 1, got 2.5"),
    ("cc_model", {"probe_steps": True}, r"probe_steps must be an integer >= 1, got True"),
    ("cc_model", {"controlled_axes": "xy"}, r"controlled_axes must be .*got 'xy'"),
    ("cc_model", {"controlled_axes": 1}, r"controlled_axes must be .*got 1"),
    ("cc_model", {"controlled_axes": (0.5,)}, r"controlled_axes must be .*got \(0.5,\)"),
    ("cc_model", {"controlled_axes": (0, 0)}, r"controlled_axes must be .*distinct"),
    ("cc_model", {"controlled_axes": (True,)}, r"controlled_axes must be"),
    ("cc_model", {"controlled_axes": ()}, r"controlled_axes must be .*non-empty"),
    ("cc_model", {"damping": None}, r"damping must be a real number, got None"),
    ("hybrid_gpr", {"window": "a"}, r"window must be an integer >= 1, got 'a'"),
    ("hybrid_gpr", {"n_init": True}, r"n_init must be an integer in \[1, window=300\]"),
    ("hybrid_gpr", {"n_init": 301}, r"n_init must be an integer in \[1, window=300\]"),
    ("hybrid_gpr", {"min_relative_error": None}, r"min_relative_error must be a real number"),
    ("hybrid_gpr", {"max_turn_deg": "x"}, r"max_turn_deg must be a real number"),
    ("hybrid_gpr", {"learning_horizon": 1.5}, r"learning_horizon must be an integer >= 1"),
    ("hybrid_gpr", {"length_scale": [1.0, -1.0]}, r"length_scales must be"),
    ("lwpr_rwr", {"window": "a"}, r"window must be an integer >= 1"),
    ("lwpr_rwr", {"online": "yes"}, r"online must be True or False"),
    ("lwpr_rwr", {"rest_actuation": 2.0}, r"rest_actuation must be within \[0.0, 1.0\]"),
])
def test_make_policy_refuses_parameters_of_the_wrong_type_or_value(track, name, params, match):
    _refused(match, lambda: make_policy(name, env=track, **params))


@pytest.mark.parametrize("params, match", [
    ({"exploration": [1]}, r"exploration must be None or a dict"),
    ({"exploration": {"no_such_field": 1}}, r"no_such_field"),
    ({"step_mm": 50.0}, r"step_mm must be within \[2.0, 15.0\]"),
    ({"adaptive": "yes"}, r"adaptive must be True or False"),
])
def test_make_policy_refuses_bad_local_ik_parameters(zhao, params, match):
    _refused(match, lambda: make_policy("local_ik_asdm", env=zhao, **params))


def test_make_policy_refuses_parameters_for_an_sb3_agent_and_an_empty_path(track):
    _refused(r"takes no parameters.*\['kp'\]",
             lambda: make_policy("sb3:sac_wang2023_track", env=track, kp=0.1))
    _refused(r"sb3 path must be", lambda: make_policy("sb3:", env=track))


# --------------------------------------------------------------------------- observations
def _bad_observations(clean: np.ndarray) -> dict[str, Any]:
    nan, inf = clean.copy(), clean.copy()
    nan[1] = np.nan
    inf[-1] = -np.inf
    return {
        "nan": nan, "inf": inf, "short": clean[:7], "long": np.r_[clean, 0.0],
        "batch": np.stack([clean, clean]), "scalar": 0.5, "empty": np.array([]),
        "strings": np.array(["a"] * clean.size), "objects": np.array(list(clean) + [None])[:-1],
        "ragged": [clean[:3], clean[3:]], "complex": clean + 1j, "bool": clean > 0,
        "none": None, "dict": {"pose": clean[:7]}, "list_with_nan": [*clean[:-1], float("nan")],
    }


def test_the_shared_check_names_the_shape_wanted_and_what_came():
    space = gym.spaces.Box(-1.0, 1.0, (19,), np.float32)
    message = _refused(r"observation", lambda: check_observation(space, np.zeros(7)))
    assert message == "observation must be a finite float array of shape (19,), got shape (7,)"
    _refused(r"got nan at index 3", lambda: check_observation(space, np.r_[np.zeros(3), np.nan,
                                                                          np.zeros(15)]))
    assert check_observation(space, [0] * 19).shape == (19,)  # integers are numbers too
    _refused(r"shape \(19,\), got shape \(2, 19\)",
             lambda: check_observation(space, np.zeros((2, 19))))
    assert check_observation(space, np.zeros((2, 19)), batch=True).shape == (2, 19)
    parts = gym.spaces.Dict({"pose": gym.spaces.Box(-1, 1, (7,)),
                             "image": gym.spaces.Box(0, 255, (4, 4, 3), np.uint8)})
    _refused(r"observation must be a dict of the parts \['image', 'pose'\]",
             lambda: check_observation(parts, np.zeros(7)))
    _refused(r"the parts \['pose'\]", lambda: check_observation(parts, {"pose": np.zeros(7)}))
    _refused(r"observation\['pose'\] must be a finite float array of shape \(7,\)", lambda:
             check_observation(parts, {"pose": np.full(7, np.nan),
                                       "image": np.zeros((4, 4, 3), np.uint8)}))
    _refused(r"observation\['image'\] must be a finite uint8 array of shape \(4, 4, 3\)", lambda:
             check_observation(parts, {"pose": np.zeros(7), "image": np.zeros((4, 4))}))


class _StubInverse:
    """A fixed linear inverse for lwpr_rwr (no pre-training): ``du = 0.01 dp`` per chamber."""

    def predict(self, wanted, p, u):
        return np.resize(0.01 * np.asarray(wanted), len(u))


class _StubNetwork:
    """A fixed local-IK network for local_ik_asdm (no training): steps towards ``desired``."""

    def predict(self, pressures_pa, position_m, desired_m, readings):
        return np.asarray(pressures_pa) + 1e5 * np.resize(desired_m - position_m, len(pressures_pa))


def _ready_baseline(name: str, env) -> Any:
    """A baseline ready to predict without calibration or training (fixed gains or stubs)."""
    policy = make_policy(name, env=env, **({"cache": False} if name in ("lwpr_rwr",
                                                                        "local_ik_asdm") else {}))
    if name in ("cc_model", "hybrid_gpr"):
        policy.alpha = np.array([2.0e6, 2.1e6, 1.9e6])  # Pa/m, as calibrate() finds them
    elif name == "lwpr_rwr":
        policy.inverse = _StubInverse()
    else:
        policy.network = _StubNetwork()
    return policy


@pytest.mark.smoke
@pytest.mark.parametrize("name", sorted(BASELINES))
def test_every_baseline_refuses_a_bad_observation_before_touching_its_state(name, track, zhao):
    """A bad observation raises ValueError naming ``observation`` and the shape wanted; the
    controller goes on as if it had never come (the same actions as a twin that never saw it)."""
    env = zhao if name == "local_ik_asdm" else track
    policy, twin = _ready_baseline(name, env), _ready_baseline(name, env)
    clean, _ = env.reset(seed=0)
    shape = re.escape(str(env.observation_space.shape))
    observations = [clean] + [env.step(env.action_space.sample() * 0.0)[0] for _ in range(24)]
    for index, observation in enumerate(observations):
        if index % 6 == 1:
            for case, bad in _bad_observations(observation).items():
                message = _refused(rf"^observation", lambda: policy.predict(bad))
                assert case in ("dict",) or shape in message or "must be a finite" in message
        action, _ = policy.predict(observation)
        np.testing.assert_array_equal(action, twin.predict(observation)[0])
        assert np.all(np.isfinite(action)) and env.action_space.contains(action)


def test_a_nan_observation_leaves_a_calibrated_cc_model_working(track):
    """The issue's case: before, predict(NaN) returned NaN actions and every later predict
    raised until reset(); now the NaN is refused and the next clean observation is served."""
    policy = make_policy("cc_model", env=track)
    observation, _ = track.reset(seed=0)
    first = policy.predict(observation)[0]  # calibrates on a private copy
    broken = observation.copy()
    broken[0] = np.nan
    _refused(r"observation must be a finite float array of shape \(16,\), got nan at index 0",
             lambda: policy.predict(broken))
    second = policy.predict(observation)[0]
    assert np.all(np.isfinite(second)) and not np.array_equal(first, np.full(3, np.nan))


def test_hybrid_update_refuses_bad_observations_before_learning(track):
    policy = _ready_baseline("hybrid_gpr", track)
    observation, _ = track.reset(seed=0)
    action, _ = policy.predict(observation)
    following = track.step(action)[0]
    pending = policy._pending
    bad = following.copy()
    bad[2] = np.inf
    _refused(r"^next_observation must be a finite float array of shape \(16,\)",
             lambda: policy.update(observation, action, 0.0, bad, {}))
    _refused(r"^observation must be", lambda: policy.update(observation[:3], action, 0.0,
                                                             following, {}))
    assert policy._pending is pending and len(policy.gp) == 0


# --------------------------------------------------------------------------- sb3 agents
class _SpacesEnv(gym.Env):
    """An env with given spaces only (to build an SB3 model of another interface)."""

    def __init__(self, n_obs: int, n_actions: int) -> None:
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (n_obs,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (n_actions,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(self.observation_space.shape, np.float32), {}

    def step(self, action):
        return np.zeros(self.observation_space.shape, np.float32), 0.0, False, False, {}


def test_an_sb3_model_with_six_actions_is_refused_for_a_three_chamber_env(tmp_path, track):
    from stable_baselines3 import PPO

    model_path = tmp_path / "six_actions.zip"
    PPO("MlpPolicy", _SpacesEnv(16, 6), n_steps=64, batch_size=64, device="cpu").save(model_path)
    message = _refused(_named(model_path), lambda: make_policy(f"sb3:{model_path}", env=track),
                       PolicyRefusal)
    assert "actions" in message and "(6,)" in message and "(3,)" in message
    assert "observations" in message and "(16,)" in message
    policy = SB3Policy.load(model_path)  # without an env it loads; check_env refuses later
    _refused(r"does not fit the env's actions", lambda: policy.check_env(track), PolicyRefusal)
    _refused(r"env must be a gymnasium environment", lambda: policy.check_env("track"))



def test_a_shipped_agent_on_another_arm_names_the_arm_it_was_trained_on(track):
    """sac_zhao2021_track (six chambers) on wang2023's arm: the refusal names the arm of its
    training (its config.yaml's env id) and carries it; on that arm it fits."""
    policy = SB3Policy.load("sac_zhao2021_track")
    assert policy.trained_preset == "zhao2021"
    with pytest.raises(PolicyRefusal) as error:
        policy.check_env(track)
    assert error.value.trained_preset == "zhao2021"
    assert str(error.value).endswith("; it was trained on the zhao2021 arm "
                                     "(preset='zhao2021')"), str(error.value)
    env = gym.make("SoftArmTrack-v0", preset="zhao2021", feedback="ground_truth",
                   **policy.env_interface)
    policy.check_env(env)
    env.close()

def test_an_sb3_agent_refuses_bad_observations_and_takes_batches(track):
    policy = make_policy("sb3:sac_wang2023_track", env=track)
    observation, _ = track.reset(seed=0)
    action = policy.predict(observation)[0]
    for case, bad in _bad_observations(observation).items():
        if case == "batch":
            batch = policy.predict(bad)[0]
            assert batch.shape == (2, 3)
            np.testing.assert_allclose(batch[0], action, atol=1e-6)
            continue
        _refused(r"^observation", lambda: policy.predict(bad))
    np.testing.assert_array_equal(policy.predict(observation)[0], action)


def test_an_sb3_agent_saves_and_loads_back_identically(tmp_path, track):
    policy = make_policy("sb3:sac_wang2023_track", env=track)
    policy.save(tmp_path / "again")
    again = make_policy(f"sb3:{tmp_path / 'again'}", env=track)
    observations = [track.reset(seed=3)[0]] + [track.step(track.action_space.sample())[0]
                                                for _ in range(4)]
    for observation in observations:
        np.testing.assert_array_equal(policy.predict(observation)[0],
                                      again.predict(observation)[0])
    for name in ("mean", "var"):
        np.testing.assert_array_equal(getattr(policy.normalization.obs_rms, name),
                                      getattr(again.normalization.obs_rms, name))
    assert again.config == policy.config and again.env_interface == policy.env_interface


@pytest.mark.smoke
@pytest.mark.parametrize("agent", sorted(path.name for path in SHIPPED_DIR.iterdir()
                                         if (path / "model.zip").is_file()))
def test_a_bare_shipped_model_zip_without_its_statistics_is_refused_naming_them(tmp_path, agent):
    """A shipped model.zip copied alone (no config.yaml, no vecnormalize.pkl) carries its own
    mark that it was trained with VecNormalize, so loading it names the missing file instead of
    running it on raw observations."""
    assert model_normalization_mark(SHIPPED_DIR / agent / "model.zip") is True
    bare = tmp_path / "model.zip"
    shutil.copy(SHIPPED_DIR / agent / "model.zip", bare)
    message = _refused(rf"normalised observations but its VecNormalize statistics "
                       rf"'{_named(tmp_path / 'vecnormalize.pkl')}' are missing",
                       lambda: SB3Policy.load(bare))
    assert "copy them beside model.zip" in message


def test_the_mark_is_written_into_the_data_entry_alone_and_decides_the_statistics(tmp_path,
                                                                                    track):
    """mark_model_file changes the mark and nothing else of the archive; a model marked as
    trained without VecNormalize ignores statistics lying beside it, one marked with them
    applies them, and a saved policy keeps its mark."""
    directory = tmp_path / "agent"
    shutil.copytree(SHIPPED, directory)
    model = directory / "model.zip"
    mark_model_file(model, False)
    with zipfile.ZipFile(SHIPPED / "model.zip") as before, zipfile.ZipFile(model) as after:
        assert before.namelist() == after.namelist()
        for name in before.namelist():
            if name != "data":
                assert before.read(name) == after.read(name), name
        data_before = json.loads(before.read("data"))
        data_after = json.loads(after.read("data"))
    assert data_before.pop(NORMALIZATION_MARK) is True and data_after.pop(NORMALIZATION_MARK) is False
    assert data_before == data_after
    observation, _ = track.reset(seed=0)
    raw = SB3Policy.load(model, env=track)
    assert raw.normalization is None and getattr(raw.model, NORMALIZATION_MARK) is False
    normalised = SB3Policy.load(SHIPPED, env=track)
    from stable_baselines3 import SAC

    np.testing.assert_array_equal(raw.predict(observation)[0],
                                  SAC.load(model, device="cpu").predict(observation,
                                                                        deterministic=True)[0])
    assert not np.array_equal(raw.predict(observation)[0], normalised.predict(observation)[0])
    normalised.save(tmp_path / "saved")
    assert model_normalization_mark(tmp_path / "saved" / "model.zip") is True
    with pytest.raises(TypeError, match="normalized must be a bool, got"):
        mark_model_file(model, 1)


def _zip_with(entries: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    return buffer.getvalue()


def _other_vecnormalize() -> bytes:
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    statistics = VecNormalize(DummyVecEnv([lambda: _SpacesEnv(5, 3)]))
    return pickle.dumps(statistics)


def _flipped(data: bytes) -> bytes:
    """``data`` with a run of bytes in the middle of its first entry's payload inverted."""
    middle = 200
    return data[:middle] + bytes(b ^ 0xFF for b in data[middle:middle + 64]) + data[middle + 64:]


MODEL = (SHIPPED / "model.zip").read_bytes()
STATISTICS = (SHIPPED / "vecnormalize.pkl").read_bytes()
CORRUPTIONS: dict[str, tuple[str, Callable[[], bytes | None], str]] = {
    "model_empty": ("model.zip", lambda: b"", r"not a stable-baselines3 model: it is empty"),
    "model_truncated_half": ("model.zip", lambda: MODEL[:len(MODEL) // 2],
                             r"not a stable-baselines3 model"),
    "model_truncated_end": ("model.zip", lambda: MODEL[:-100], r"not a stable-baselines3 model"),
    "model_random": ("model.zip", lambda: np.random.default_rng(0).bytes(4096),
                     r"not a readable zip archive"),
    "model_text": ("model.zip", lambda: b"this is a text file\n", r"not a readable zip archive"),
    "model_foreign_zip": ("model.zip", lambda: _zip_with({"readme.txt": b"x"}),
                          r"lacks the entries \['data', 'policy.pth'\]"),
    "model_bad_data": ("model.zip", lambda: _zip_with({"data": b"{not json",
                                                       "policy.pth": b""}),
                       r"corrupt 'data' entry"),
    "model_bad_policy": ("model.zip", lambda: _zip_with({
        "data": zipfile.ZipFile(SHIPPED / "model.zip").read("data"), "policy.pth": b"junk"}),
        r"does not load as a stable-baselines3 SAC model"),
    "model_flipped": ("model.zip", lambda: _flipped(MODEL), r"model"),
    "statistics_garbage": ("vecnormalize.pkl", lambda: b"garbage",
                           r"VecNormalize statistics .* cannot be read"),
    "statistics_empty": ("vecnormalize.pkl", lambda: b"", r"the file is empty"),
    "statistics_truncated": ("vecnormalize.pkl", lambda: STATISTICS[:len(STATISTICS) // 2],
                             r"cannot be read"),
    "statistics_dict": ("vecnormalize.pkl", lambda: pickle.dumps({"obs_rms": 1}),
                        r"hold a dict, not a pickled stable-baselines3 VecNormalize"),
    "statistics_other_obs": ("vecnormalize.pkl", _other_vecnormalize,
                             r"are for observations Box.*\(5,\).*the model reads"),
    "statistics_missing": ("vecnormalize.pkl", lambda: None,
                           r"trained on normalised observations .* are missing"),
    "config_not_yaml": ("config.yaml", lambda: b"algo: [\n", r"is not readable YAML"),
    "config_a_list": ("config.yaml", lambda: b"- 1\n- 2\n", r"must hold a mapping"),
    "config_unknown_algo": ("config.yaml", lambda: b"algo: dqn\n",
                            r"names the algo 'dqn', not one of"),
    "config_env_kwargs": ("config.yaml", lambda: b"algo: sac\nenv_kwargs: 3\n",
                          r"env_kwargs must be a mapping"),
}


@pytest.mark.parametrize("case", sorted(CORRUPTIONS))
def test_a_corrupt_sb3_directory_is_refused_naming_the_file(tmp_path, track, case):
    file_name, content, match = CORRUPTIONS[case]
    directory = tmp_path / "agent"
    shutil.copytree(SHIPPED, directory)
    data = content()
    if data is None:
        (directory / file_name).unlink()
    else:
        (directory / file_name).write_bytes(data)
    culprit = directory / file_name
    message = _refused(match, lambda: make_policy(f"sb3:{directory}", env=track))
    assert str(culprit) in message or str(directory) in message, message
    if case.startswith("model_"):
        assert str(culprit) in message
        # the bare .zip, without its run config: the algorithm guess refuses it the same way
        bare = tmp_path / "bare" / "model.zip"
        bare.parent.mkdir()
        bare.write_bytes(culprit.read_bytes())
        _refused(_named(bare), lambda: SB3Policy.load(bare))


def test_sb3_paths_that_are_no_model_are_refused(tmp_path, track):
    _refused(rf"sb3 path '{_named(tmp_path / 'nowhere')}' does not exist and is no shipped agent "
             r"\[.*'sac_wang2023_track'", lambda: make_policy(f"sb3:{tmp_path / 'nowhere'}",
                                                            env=track))
    (tmp_path / "empty").mkdir()
    _refused(rf"{_named(tmp_path / 'empty')}' is a directory without model.zip",
             lambda: make_policy(f"sb3:{tmp_path / 'empty'}", env=track))
    unknown = tmp_path / "unknown.zip"
    unknown.write_bytes(_zip_with({"data": b'{"something": 1}', "policy.pth": b""}))
    _refused(rf"{_named(unknown)}' holds no stable-baselines3 model this loader knows",
             lambda: make_policy(f"sb3:{unknown}", env=track))


# --------------------------------------------------------------------------- cc_model / hybrid
def test_cc_model_saves_and_loads_back_identically(tmp_path, track):
    policy = make_policy("cc_model", env=track, kp=0.07, controlled_axes=(0, 1))
    policy.calibrate()
    policy.save(tmp_path / "cc.json")
    loaded = CCModelController.load(tmp_path / "cc.json", env=track)
    np.testing.assert_array_equal(loaded.alpha, policy.alpha)
    assert (loaded.kp, loaded.controlled_axes, loaded.probe_steps) == (0.07, (0, 1), 30)
    observation, _ = track.reset(seed=2)
    for _ in range(5):
        action = policy.predict(observation)[0]
        np.testing.assert_array_equal(action, loaded.predict(observation)[0])
        observation = track.step(action)[0]
    fresh = make_policy("cc_model", env=track)
    fresh.save(tmp_path / "uncalibrated.json")
    assert CCModelController.load(tmp_path / "uncalibrated.json", env=track).alpha is None


def _cc_file(tmp_path: Path, **changes) -> dict:
    data = {"name": "cc_model", "kp": 0.06, "null_space_gain": 0.1, "probe_fraction": 0.3,
            "probe_steps": 30, "damping": 1e-4, "controlled_axes": [0, 1, 2],
            "alpha": [2e6, 2e6, 2e6]}
    data.update(changes)
    return {key: value for key, value in data.items() if value is not ...}


@pytest.mark.parametrize("content, match", [
    (b"", r"is not readable JSON"),
    (b"{not json", r"is not readable JSON"),
    (b"\xff\xfe\x00garbage", r"is not readable JSON"),
    (b"[1, 2, 3]", r"must hold a JSON object of settings, got list"),
    (json.dumps({"kp": 0.06, "alpha": None}).encode(), r"holds no controller name"),
    (json.dumps({"name": "hybrid_gpr", "alpha": None}).encode(), r"'hybrid_gpr' controller"),
    ("alpha", r"has no 'alpha' entry"),
    ({"alpha": [1.0, 2.0]}, r"alpha must be null or 3 finite gains > 0"),
    ({"alpha": [1.0, float("nan"), 2.0]}, r"alpha must be null or 3 finite gains > 0"),
    ({"alpha": [1.0, -2.0, 2.0]}, r"alpha must be null or 3 finite gains > 0"),
    ({"alpha": "fast"}, r"alpha must be null"),
    ({"kp": -1.0}, r"holds invalid settings \(kp must be a finite number > 0"),
    ({"kp": "x"}, r"holds invalid settings \(kp must be a real number"),
    ({"controlled_axes": [0, 7]}, r"holds invalid settings \(controlled_axes"),
    ({"no_such_setting": 1}, r"holds invalid settings .*no_such_setting"),
])
def test_a_corrupt_cc_model_file_is_refused_naming_it(tmp_path, track, content, match):
    path = tmp_path / "cc.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        changes = {content: ...} if isinstance(content, str) else content
        path.write_text(json.dumps(_cc_file(tmp_path, **changes)))
    message = _refused(match, lambda: CCModelController.load(path, env=track))
    assert str(path) in message
    _refused(r"does not exist", lambda: CCModelController.load(tmp_path / "none.json", env=track))


def test_a_corrupt_hybrid_directory_is_refused_naming_the_file(tmp_path, track):
    policy = _ready_baseline("hybrid_gpr", track)
    observation, _ = track.reset(seed=0)
    for _ in range(30):
        action = policy.predict(observation)[0]
        following = track.step(action)[0]
        policy.update(observation, action, 0.0, following, {})
        observation = following
    good = tmp_path / "good"
    policy.save(good)
    loaded = HybridGPRController.load(good, env=track)
    assert loaded.samples == policy.samples and len(loaded.gp) == len(policy.gp) > 0
    np.testing.assert_array_equal(loaded.alpha, policy.alpha)
    policy.reset()
    np.testing.assert_array_equal(loaded.predict(observation)[0], policy.predict(observation)[0])

    _refused(rf"{_named(tmp_path / 'missing')}' does not exist",
             lambda: HybridGPRController.load(tmp_path / "missing", env=track))
    (tmp_path / "a_file").write_text("{}")
    _refused(r"is a file, not a directory", lambda: HybridGPRController.load(tmp_path / "a_file",
                                                                            env=track))
    damages = {
        "gp.npz": [b"", b"junk", (good / "gp.npz").read_bytes()[:200], None],
        "hybrid.json": [b"{", b"[]", json.dumps({"samples": -1}).encode(),
                        json.dumps({"samples": 3, "n_init": "x"}).encode(), None],
        "cc_model.json": [b"", json.dumps({"name": "cc_model", "alpha": None}).encode(), None],
    }
    for file_name, contents in damages.items():
        for content in contents:
            broken = tmp_path / "broken"
            shutil.rmtree(broken, ignore_errors=True)
            shutil.copytree(good, broken)
            if content is None:
                (broken / file_name).unlink()
            else:
                (broken / file_name).write_bytes(content)
            message = _refused(r"", lambda: HybridGPRController.load(broken, env=track))
            assert str(broken / file_name) in message or str(broken) in message, message


# --------------------------------------------------------------------------- lwpr_rwr
def _small_lwpr_rwr(env) -> LWPRRWRController:
    """An lwpr_rwr controller with small, untrained models (what save() needs, no pre-training)."""
    controller = make_policy("lwpr_rwr", env=env, cache=False)
    c = controller.n_chambers
    controller.forward = LWPR(3 + 2 * c, 3)
    rng = np.random.default_rng(0)
    for _ in range(20):
        controller.forward.update(rng.uniform(0, 1, 3 + 2 * c), rng.uniform(-1, 1, 3))
    controller.inverse = controller._new_inverse()
    controller.inverse.set_fields(*controller._inverse_fields())
    controller._pretraining_tips_mm = rng.uniform(0, 100, (5, 3))
    controller.pretraining = {"samples": 20}
    controller._fields_seen = controller.forward.fields_per_output
    return controller


def test_lwpr_rwr_files_load_back_by_their_name_or_are_refused(tmp_path, track):
    controller = _small_lwpr_rwr(track)
    path = tmp_path / "controller"  # no .npz suffix: saved and loaded by exactly this name
    controller.save(path)
    assert path.is_file() and not (tmp_path / "controller.npz").exists()
    loaded = LWPRRWRController.load(path, env=track)
    np.testing.assert_array_equal(loaded._pretraining_tips_mm, controller._pretraining_tips_mm)
    position, target = np.array([0.0, 0.0, 0.12]), np.array([0.01, 0.0, 0.115])
    for _ in range(4):
        np.testing.assert_array_equal(controller.action_for(position, target),
                                      loaded.action_for(position, target))

    good = path.read_bytes()
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    def npz(**changes) -> bytes:
        buffer = io.BytesIO()
        np.savez(buffer, **{**arrays, **changes})
        return buffer.getvalue()
    cases = {
        b"": r"not a readable \.npz archive \(the file is empty\)",
        good[:len(good) // 2]: r"not a readable \.npz archive|foreign or truncated",
        good[:-30]: r"not a readable \.npz archive|foreign or truncated",
        b"text, not an archive\n": r"not a readable \.npz archive",
        np.random.default_rng(1).bytes(2000): r"not a readable \.npz archive",
        npz(format=np.array("something else/1")): r"format marker 'something else/1'",
        npz(settings=np.array("{not json")): r"holds invalid settings",
        npz(settings=np.array(json.dumps({"no_such": 1}))): r"holds invalid settings.*no_such",
        npz(settings=np.array(json.dumps({"window": -1}))): r"holds invalid settings.*window",
        npz(forward=np.frombuffer(b"junk", dtype=np.uint8)): r"'forward' entry is not a readable",
        npz(pretraining_tips_mm=np.full((2, 3), np.nan)): r"pretraining_tips_mm",
        npz(inverse_betas=np.zeros(3)): r"is not a saved reward-weighted inverse",
    }
    buffer = io.BytesIO()
    np.save(buffer, np.zeros(3))
    cases[buffer.getvalue()] = r"single \.npy array"
    buffer = io.BytesIO()
    np.savez(buffer, X=np.zeros(3))
    cases[buffer.getvalue()] = r"format marker None"
    for content, match in cases.items():
        path.write_bytes(content)
        message = _refused(match, lambda: LWPRRWRController.load(path, env=track))
        assert str(path) in message, message
    _refused(rf"{_named(tmp_path / 'none.npz')}' does not exist",
             lambda: LWPRRWRController.load(tmp_path / "none.npz", env=track))


# --------------------------------------------------------------------------- local_ik_asdm
def test_local_ik_asdm_files_with_bad_settings_are_refused_naming_them(tmp_path, zhao):
    rng = np.random.default_rng(0)
    network = LocalIKNetwork(6, 6, 80e3)
    network.fit(rng.uniform(0.0, 80e3, (40, 6)), rng.normal(0.0, 0.01, (40, 3)),
                rng.normal(0.0, 1e-3, (40, 6)), max_iterations=2, progress=False)
    path = tmp_path / "controller.bin"
    for settings, match in (({"step_mm": 99.0}, r"step_mm must be within"),
                            ({"no_such": 1}, r"no_such"), ([1, 2], r"settings must be a JSON object")):
        write_model_state(path, "soft-arm-gym local-ik-asdm 1", {
            "settings": json.dumps(settings), "training": json.dumps({}),
            "network": network.state()})
        message = _refused(match, lambda: LocalIKASDMController.load(path, env=zhao))
        assert str(path) in message
    for content in (b"", b"junk\n", b"soft-arm-gym local-ik-asdm 1 0000\npayload"):
        path.write_bytes(content)
        _refused(_named(path), lambda: LocalIKASDMController.load(path, env=zhao))
        _refused(_named(path), lambda: LocalIKNetwork.load(path))
    _refused(_named(tmp_path / "none.bin"),
             lambda: LocalIKASDMController.load(tmp_path / "none.bin", env=zhao))
    _refused(r"env must be the soft-arm environment",
             lambda: LocalIKASDMController.load(path, env=None))


# --------------------------------------------------------------------------- learners
def _gp() -> SlidingWindowGP:
    rng = np.random.default_rng(0)
    gp = SlidingWindowGP(window=20, length_scales=[0.5, 0.7], noise_variance=1e-2)
    for _ in range(30):
        x = rng.uniform(-1, 1, 2)
        gp.add(x, np.array([np.sin(x[0]), x[1]]))
    gp.predict(np.zeros((1, 2)))  # caches alpha, which is saved too
    return gp


def _inverse() -> RewardWeightedInverse:
    rng = np.random.default_rng(0)
    model = RewardWeightedInverse(3, 3)
    model.set_fields(rng.uniform(0, 1, (2, 6)), np.tile(np.eye(6), (2, 1, 1)))
    p, u = rng.uniform(0, 1, (30, 3)), rng.uniform(0, 1, (30, 3))
    du = rng.normal(0, 0.05, (30, 3))
    model.fit(p, u, du, du @ rng.normal(size=(3, 3)))
    return model


@pytest.mark.parametrize("kind", ["gp", "inverse"])
def test_learner_files_round_trip_by_their_name_and_refuse_corruption(tmp_path, kind):
    model = _gp() if kind == "gp" else _inverse()
    cls = type(model)
    path = tmp_path / "model.bin"  # not .npz: saved and loaded by exactly this name
    model.save(path)
    assert path.is_file() and not (tmp_path / "model.bin.npz").exists()
    loaded = cls.load(path)
    if kind == "gp":
        query = np.random.default_rng(5).uniform(-1, 1, (4, 2))
        for a, b in zip(model.predict(query, return_std=True), loaded.predict(query,
                                                                              return_std=True)):
            np.testing.assert_array_equal(a, b)
    else:
        args = (np.array([0.1, 0.0, -0.1]), np.full(3, 0.5), np.full(3, 0.3))
        np.testing.assert_array_equal(model.predict(*args), loaded.predict(*args))

    good = path.read_bytes()
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    def npz(**changes) -> bytes:
        buffer = io.BytesIO()
        np.savez(buffer, **{key: value for key, value in {**arrays, **changes}.items()
                            if value is not None})
        return buffer.getvalue()
    buffer = io.BytesIO()
    np.save(buffer, np.zeros(3))
    contents = [b"", good[:len(good) // 2], good[:-25], b"plain text\n", os.urandom(500),
                buffer.getvalue(), npz(centres=None, X=None)]
    if kind == "gp":
        contents += [npz(X=np.zeros((3, 5))), npz(n=np.array(99)), npz(R=np.full_like(
            arrays["R"], np.nan)), npz(window=np.array(1.5)), npz(mean=np.array("median"))]
    else:
        contents += [npz(format=np.array("other/1")), npz(betas=np.zeros(4)),
                     npz(centres=np.zeros((2, 4)))]
    for content in contents:
        path.write_bytes(content)
        _refused(_named(path), lambda: cls.load(path))
    _refused(rf"{_named(tmp_path / 'none.npz')}' does not exist",
             lambda: cls.load(tmp_path / "none.npz"))
