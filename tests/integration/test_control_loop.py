"""The control-loop contract of one env step, checked against references built outside the env.

docs/architecture.md, "One env step": the k-th observation presents ``(target_k, target_{k+1})``;
the reward of step k is ``-||tip - target_k|| - action_rate_weight ||a_k - a_{k-1}||^2`` with the
ground-truth tip after the step and the target presented in the observation ``a_k`` was chosen
from; ``info["error_mm"]`` uses the same target; a track episode ends (truncation) exactly when
the path's last target has been presented and acted on, a reach episode after ``episode_steps``.

The track reference trajectory is rebuilt here from the public path functions
(``soft_gym.tasks.paths``: ``PathSpec`` and ``make_reference_trajectory``) and the reachable set
(``soft_gym.procedures.workspace.reachable_tips``), never read back from ``task.target``. The eval
runner's per-step records are checked against a hand-written loop over the same env.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401  (registers the env ids)
from agents.policies import BaselinePolicy
from agents.rollout import run_episode
from soft_gym.robots.presets import get_preset
from soft_gym.tasks.paths import PathSpec, make_reference_trajectory
from soft_gym.procedures.workspace import reachable_tips

PRESET = "wang2023"
SEED = 3


def _reference_trajectory(path: str, cycles: int = 1) -> tuple[np.ndarray, PathSpec]:
    """The track task's targets per control step, built from the public path functions.

    TrackTask's documented construction (soft_gym/tasks/tasks.py): a ``path`` of radius half the
    75th percentile of the reachable set's lateral radius, centred on the arm axis at the
    reachable set's median height, traversed once in 20 s for a circle of that radius.
    """
    spec = get_preset(PRESET)
    tips = reachable_tips(spec)
    radius = 0.5 * float(np.percentile(np.linalg.norm(tips[:, :2], axis=1), 75))
    path_spec = PathSpec(shape=path, center_m=(0.0, 0.0, float(np.median(tips[:, 2]))),
                         radius_m=radius, speed_m_s=2 * np.pi * radius / 20.0, cycles=cycles)
    return make_reference_trajectory(path_spec, spec.control_period_s), path_spec


def _actions(n_steps: int, n_chambers: int, seed: int = 0) -> np.ndarray:
    """A known, varied action sequence (float64 in [-1, 1]) so that the action-rate term matters."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n_steps, n_chambers))


def _targets(env: gym.Env, observation) -> tuple[np.ndarray, np.ndarray]:
    part = env.unwrapped.observation_part(observation, "target")
    return np.asarray(part[:3], dtype=float), np.asarray(part[3:], dtype=float)


def _expected_reward(tip: np.ndarray, target: np.ndarray, action: np.ndarray,
                     previous: np.ndarray, weight: float) -> float:
    """docs/architecture.md, "One env step", item 6."""
    return float(-np.linalg.norm(tip - target) - weight * np.sum((action - previous) ** 2))


def test_reference_circle_is_the_stated_geometry() -> None:
    """The rebuilt reference is a real reference: targets on the circle of the stated radius and
    centre, equally spaced at about speed * control period (one 20 s cycle = 400 steps)."""
    trajectory, path_spec = _reference_trajectory("circle")
    spec = get_preset(PRESET)
    center = np.asarray(path_spec.center_m)
    assert len(trajectory) == int(round(20.0 / spec.control_period_s))
    assert np.allclose(np.linalg.norm(trajectory - center, axis=1), path_spec.radius_m, rtol=1e-3)
    assert np.allclose(trajectory[:, 2], center[2], atol=1e-9)  # plane normal to the arm axis
    steps = np.linalg.norm(np.diff(np.vstack([trajectory, trajectory[:1]]), axis=0), axis=1)
    spacing = path_spec.speed_m_s * spec.control_period_s
    assert np.allclose(steps, spacing, rtol=1e-2)


@pytest.mark.parametrize("path, cycles, weight", [
    ("circle", 1, 0.001),     # the default action-rate weight
    ("pentagram", 2, 0.05),   # corners, two cycles, a heavier action-rate term
])
def test_track_observation_reward_info_and_end_follow_the_trajectory(
        path: str, cycles: int, weight: float) -> None:
    """Step by step on a track episode: observed targets are ``(traj[k], traj[k+1])``, the reward
    and ``info["error_mm"]`` of step k use ``traj[k]``, and the episode is truncated exactly at
    step ``len(traj)``, so that every target is presented and acted on once, in order.

    The spacing between consecutive targets (about 0.5 mm for the circle) is far above the
    tolerances, so that presenting or scoring the neighbouring target fails."""
    trajectory, _ = _reference_trajectory(path, cycles)
    n = len(trajectory)
    env = gym.make("SoftArmTrack-v0", preset=PRESET, feedback="ground_truth", path=path,
                   cycles=cycles, action_rate_weight=weight)
    try:
        actions = _actions(n, env.action_space.shape[0])
        observation, info = env.reset(seed=SEED)
        np.testing.assert_allclose(info["target_m"], trajectory[0], atol=1e-12)
        previous = np.zeros(env.action_space.shape[0])
        truncations = []
        for k in range(n):
            current, upcoming = _targets(env, observation)
            np.testing.assert_allclose(current, trajectory[k], atol=1e-6, rtol=0,
                                       err_msg=f"current target of observation {k}")
            np.testing.assert_allclose(upcoming, trajectory[min(k + 1, n - 1)], atol=1e-6, rtol=0,
                                       err_msg=f"next target of observation {k}")
            observation, reward, terminated, truncated, info = env.step(actions[k])
            tip = np.asarray(info["tip_position_m"], dtype=float)
            assert reward == pytest.approx(
                _expected_reward(tip, trajectory[k], actions[k], previous, weight),
                rel=1e-9, abs=1e-12), f"reward of step {k}"
            np.testing.assert_allclose(info["target_m"], trajectory[k], atol=1e-12,
                                       err_msg=f"info target of step {k}")
            assert info["error_mm"] == pytest.approx(
                1000.0 * np.linalg.norm(tip - trajectory[k]), rel=1e-9, abs=1e-9)
            assert info["step"] == k + 1
            assert not terminated
            truncations.append(truncated)
            previous = actions[k]
        assert truncations == [False] * (n - 1) + [True]
    finally:
        env.close()


def test_reach_target_is_held_and_scored_and_episode_ends_on_time() -> None:
    """Reach: every observation presents ``(t, t)`` for one reachable target ``t`` drawn at reset
    (the reachable set from ``reachable_tips``); reward and ``error_mm`` use ``t``; the episode is
    truncated exactly after ``episode_steps``."""
    episode_steps = 30
    weight = 0.02
    reachable = reachable_tips(get_preset(PRESET))
    env = gym.make("SoftArmReach-v0", preset=PRESET, feedback="ground_truth",
                   episode_steps=episode_steps, action_rate_weight=weight)
    try:
        actions = _actions(episode_steps, env.action_space.shape[0], seed=1)
        targets = []
        for seed in (SEED, SEED + 1):
            observation, info = env.reset(seed=seed)
            target, upcoming = _targets(env, observation)
            np.testing.assert_array_equal(target, upcoming)
            assert np.min(np.linalg.norm(reachable - target, axis=1)) < 1e-6
            np.testing.assert_allclose(info["target_m"], target, atol=1e-6)
            targets.append(target)
            previous = np.zeros(env.action_space.shape[0])
            for k in range(episode_steps):
                np.testing.assert_allclose(np.r_[_targets(env, observation)], np.r_[target, target],
                                           atol=1e-6)
                observation, reward, terminated, truncated, info = env.step(actions[k])
                tip = np.asarray(info["tip_position_m"], dtype=float)
                exact_target = np.asarray(info["target_m"], dtype=float)
                np.testing.assert_allclose(exact_target, target, atol=1e-6)
                assert reward == pytest.approx(
                    _expected_reward(tip, exact_target, actions[k], previous, weight),
                    rel=1e-9, abs=1e-12)
                assert info["error_mm"] == pytest.approx(
                    1000.0 * np.linalg.norm(tip - exact_target), rel=1e-9, abs=1e-9)
                assert not terminated
                assert truncated == (k == episode_steps - 1)
                previous = actions[k]
        assert not np.allclose(targets[0], targets[1])  # a fresh draw per seed
    finally:
        env.close()


class _ScriptedPolicy(BaselinePolicy):
    """Plays a fixed action sequence; remembers what it saw in ``predict`` and ``update``."""

    name = "scripted"

    def __init__(self, actions: np.ndarray) -> None:
        self.actions = actions
        self.seen_targets: list[np.ndarray] = []
        self.updates: list[tuple[np.ndarray, int]] = []
        self._k = 0
        self.env: gym.Env | None = None

    def reset(self) -> None:
        self._k = 0
        self.seen_targets.clear()
        self.updates.clear()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        self.seen_targets.append(
            np.asarray(self.env.unwrapped.observation_part(observation, "target")[:3], dtype=float))
        action = self.actions[self._k]
        self._k += 1
        return action, state

    def update(self, observation, action, reward, next_observation, info) -> None:
        self.updates.append((np.asarray(action, dtype=float), int(info["step"])))


def test_eval_runner_records_line_up_with_the_env_steps() -> None:
    """Row k of ``run_episode``'s record describes step k: the action played at step k, the
    target that step was scored against (the one in the observation the action was chosen from),
    and the tip, pressures, error and time of the env's own ``info`` after step k. The reference
    is a hand-written loop over a second env with the same seed and actions."""
    trajectory, _ = _reference_trajectory("circle")
    n = len(trajectory)
    kwargs = dict(preset=PRESET, feedback="ground_truth", path="circle")
    env = gym.make("SoftArmTrack-v0", **kwargs)
    actions = _actions(n, env.action_space.shape[0], seed=2)
    policy = _ScriptedPolicy(actions)
    policy.env = env
    try:
        record = run_episode(env, policy, seed=SEED)
    finally:
        env.close()

    reference = gym.make("SoftArmTrack-v0", **kwargs)
    infos, observations = [], []
    try:
        observation, _ = reference.reset(seed=SEED)
        for k in range(n):
            observations.append(observation)
            observation, _, _, truncated, info = reference.step(actions[k])
            infos.append(info)
        assert truncated
    finally:
        reference.close()

    assert len(record["action"]) == n
    np.testing.assert_allclose(np.vstack(policy.seen_targets), trajectory, atol=1e-6)
    for k in range(n):
        info = infos[k]
        np.testing.assert_array_equal(record["action"][k], actions[k], err_msg=f"action row {k}")
        np.testing.assert_allclose(record["target_m"][k], trajectory[k], atol=1e-12,
                                   err_msg=f"target row {k}")
        np.testing.assert_allclose(record["tip_m"][k], info["tip_position_m"], atol=1e-12,
                                   err_msg=f"tip row {k}")
        np.testing.assert_allclose(record["pressure_pa"][k], info["pressures_pa"], rtol=1e-12)
        assert record["error_mm"][k] == pytest.approx(info["error_mm"], rel=1e-12)
        assert record["time_s"][k] == pytest.approx(info["time_s"], rel=1e-12)
        assert record["error_mm"][k] == pytest.approx(
            1000.0 * np.linalg.norm(record["tip_m"][k] - record["target_m"][k]), rel=1e-9)
        # ground-truth feedback: the pose the policy sees next is the tip after step k
        np.testing.assert_allclose(record["feedback_m"][k], info["tip_position_m"], atol=1e-6)
        action, step = policy.updates[k]
        np.testing.assert_array_equal(action, actions[k])
        assert step == k + 1
    assert np.all(np.diff(record["time_s"]) > 0)
