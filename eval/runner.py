"""Drive any policy (baseline or SB3 model) through any env configuration and record each step.

A :class:`RunConfig` names one run: its policy, env and seed. :func:`run` builds it
(:func:`build`) and records one episode with :func:`agents.rollout.run_episode` (the record's
columns are listed there; :mod:`eval.metrics` computes from them). With a video path
(``RunConfig.video_path``) the run also writes a video (:class:`eval.video.EpisodeVideo`) of
:func:`soft_gym.envs.rendering.render_frame` frames: one after ``reset`` and one after every
step, at the env's ``render_fps``. Rendering only reads the simulation, so the record is the same
with and without a video.

Before a batch of runs starts, :func:`check_configs` checks every configuration the cheap way
(each distinct env built once without calibrating its feedback,
:func:`soft_gym.envs.uncalibrated.make_uncalibrated_env`, every baseline made on it, every SB3
agent loaded once and its observation and action spaces compared with its env's), so that a bad
run late in a batch fails before the first one starts; :func:`run_many` hands each record to
``on_result`` as it finishes, so that a batch failing later keeps the finished runs.
"""

from __future__ import annotations

import json
import multiprocessing
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import soft_gym  # noqa: F401  (registers the env ids)
from agents.policies import BASELINES, BaselinePolicy, SB3Policy, make_policy
from agents.rollout import run_episode
from eval.video import EpisodeVideo
from soft_gym._progress import heartbeat
from soft_gym.envs.uncalibrated import make_uncalibrated_env


@dataclass
class RunConfig:
    """One run: which policy on which env configuration, with which seed.

    Attributes:
        policy: baseline name (``cc_model``, ``hybrid_gpr``, ...) or ``"sb3:PATH"``.
        policy_params: keyword arguments of the baseline (e.g. ``{"kp": 0.06}``).
        env_id: Gymnasium id.
        env_kwargs: keyword arguments of ``gymnasium.make`` (preset, path, cycles, scenario,
            faults, feedback, ...).
        seed: episode seed.
        labels: extra labels for tables (defaults are derived from the fields above).
        video_path: write a video of the run there (``.mp4``; ``.gif`` without ffmpeg);
            ``None``: no frames are rendered.
        video_panels: panels of each frame (:func:`soft_gym.envs.rendering.render_frame`);
            ``None``: the scene, and the camera sensors beside it when the env has any.
    """

    policy: str
    env_kwargs: dict = field(default_factory=dict)
    policy_params: dict = field(default_factory=dict)
    env_id: str = "SoftArmTrack-v0"
    seed: int = 0
    labels: dict = field(default_factory=dict)
    video_path: str | None = None
    video_panels: tuple[str, ...] | None = None

    def identity(self) -> dict[str, Any]:
        """Labels naming this run in tables."""
        labels = {"policy": self.policy.split("/")[-1]}
        labels.update({key: value for key, value in self.policy_params.items()
                       if isinstance(value, (int, float, str))})
        for key in ("preset", "path", "scenario", "faults", "feedback", "engine"):
            if key in self.env_kwargs:
                value = self.env_kwargs[key]
                labels[key] = value if isinstance(value, (str, int, float)) else _describe(value)
        labels["seed"] = self.seed
        labels.update(self.labels)
        return labels


def _describe(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, dict):
        return str(value.get("name", value))
    if isinstance(value, (list, tuple)):
        return "+".join(_describe(item) for item in value)
    return str(value)


def build(config: RunConfig) -> tuple[gym.Env, BaselinePolicy]:
    """Make the env and the policy of ``config`` (calibrating the policy if it needs to)."""
    if config.policy.startswith("sb3:"):
        # an agent reads and writes what it was trained with; the scenario stays the run's
        policy = SB3Policy.load(config.policy[4:])
        env = gym.make(config.env_id, **{**config.env_kwargs, **policy.env_interface})
        policy.check_env(env)
        return env, policy
    env = gym.make(config.env_id, **config.env_kwargs)
    policy = make_policy(config.policy, env=env, **config.policy_params)
    if hasattr(policy, "calibrate"):
        policy.calibrate()
    return env, policy


def run(config: RunConfig, progress: bool = False) -> dict[str, np.ndarray]:
    """Build and run one configuration; returns its record."""
    env, policy = build(config)
    try:
        frames = (None if config.video_path is None
                  else EpisodeVideo(env, config.video_path, config.video_panels))
        return run_episode(env, policy, seed=config.seed, progress=progress,
                           description=f"{config.policy} seed {config.seed}", frames=frames)
    finally:
        env.close()


def run_many(configs: list[RunConfig], workers: int = 1, progress: bool = False,
             on_result: Callable[[int, dict[str, np.ndarray]], None] | None = None,
             ) -> list[dict[str, np.ndarray]]:
    """Run several configurations, in ``workers`` processes when > 1; records in input order.

    Each worker process calibrates its own sensing pipeline (the calibration is cached per
    process), and seeded runs give the same records whichever process runs them.

    ``on_result(index, record)`` is called in this process as each run finishes (in the order
    they finish), e.g. to write its record to disk at once. When a run fails, no further run is
    started, the runs already under way finish (and are handed to ``on_result``), and the first
    error is raised.
    """
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    records: list[dict[str, np.ndarray] | None] = [None] * len(configs)
    if workers == 1 or len(configs) <= 1:
        for index, config in enumerate(configs):
            records[index] = run(config, progress=progress)
            if on_result is not None:
                on_result(index, records[index])
        return records
    context = multiprocessing.get_context("spawn")
    bar = tqdm(total=len(configs), desc="runs", disable=not progress)
    first_error: BaseException | None = None
    with heartbeat(bar), ProcessPoolExecutor(max_workers=min(workers, len(configs)),
                                             mp_context=context) as pool:
        futures = {pool.submit(run, config): index for index, config in enumerate(configs)}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in sorted(done, key=futures.get):
                if future.cancelled():
                    continue
                error = future.exception()
                if error is not None:
                    first_error = first_error or error
                    continue
                index = futures[future]
                records[index] = future.result()
                bar.update(1)
                if on_result is not None:
                    try:
                        on_result(index, records[index])
                    except Exception as error:  # noqa: BLE001  (stop, as for a failed run)
                        first_error = first_error or error
            if first_error is not None:
                for future in pending:
                    future.cancel()  # the ones not started; those under way finish
    bar.close()
    if first_error is not None:
        raise first_error
    return records


# ------------------------------------------------------------------------------ checking
class ConfigError(ValueError):
    """A run configuration that cannot run: ``index`` of the config in the checked list,
    ``part`` that is refused (``"policy"``, ``"policy_params"``, ``"env_id"`` or
    ``"env_kwargs.<key>"``) and the env's or policy's own message; ``trained_preset``: the arm
    an SB3 agent refused for another arm was trained on (else ``None``)."""

    def __init__(self, index: int, config: RunConfig, part: str, message: str,
                 trained_preset: str | None = None) -> None:
        self.index, self.config, self.part = index, config, part
        self.trained_preset = trained_preset
        self.message = " ".join(str(message).split())
        super().__init__(f"run {index} ({config.policy}, seed {config.seed}): {part}: "
                         f"{self.message}")


class _Checker:
    """Builds each distinct env configuration once and remembers the outcome."""

    def __init__(self) -> None:
        self.errors: dict[str, str | None] = {}

    @staticmethod
    def _key(env_id: str, kwargs: dict[str, Any]) -> str:
        return json.dumps([env_id, kwargs], sort_keys=True, default=repr)

    def env_error(self, env_id: str, kwargs: dict[str, Any]) -> str | None:
        key = self._key(env_id, kwargs)
        if key not in self.errors:
            try:
                env = make_uncalibrated_env(env_id, kwargs)
            except Exception as error:  # noqa: BLE001  (any refusal is the user's input)
                self.errors[key] = f"{error}"
            else:
                env.close()
                self.errors[key] = None
        return self.errors[key]

    def blame(self, env_id: str, kwargs: dict[str, Any]) -> tuple[str, str] | None:
        """``None`` when the env accepts ``kwargs``; else the first keyword argument (in their
        order) whose addition makes it refuse, and the refusal."""
        message = self.env_error(env_id, kwargs)
        if message is None:
            return None
        partial: dict[str, Any] = {}
        for key, value in kwargs.items():
            partial[key] = value
            found = self.env_error(env_id, partial)
            if found is not None:
                return f"env_kwargs.{key}", found
        return "env_id", message


def _space_error(policy, env) -> str | None:
    """Why an SB3 agent cannot act on ``env``: another observation or action space."""
    try:
        policy.check_env(env)
    except ValueError as error:
        return str(error)
    expected = getattr(policy.model, "action_space", None)
    if expected is not None and expected.shape != env.action_space.shape:
        return (f"the agent writes actions of shape {expected.shape}, the env takes "
                f"{env.action_space.shape}: make the env with the agent's interface "
                f"{policy.env_interface}")
    return None


def check_configs(configs: Sequence[RunConfig], progress: bool = False) -> None:
    """Check every configuration as far as it can be without running it.

    Each distinct env (id and keyword arguments) is built once without calibrating its feedback
    source and closed; every baseline is made on its env with its parameters (not calibrated);
    every SB3 agent is loaded once and its observation and action spaces are compared with those
    of its env (made with the agent's interface, as :func:`build` does).

    Raises:
        ConfigError: the first configuration refused, with the part refused and the message.
    """
    checker = _Checker()
    agents: dict[str, Any] = {}
    made: set[str] = set()
    for index, config in enumerate(tqdm(configs, desc="checking the runs", leave=False,
                                        disable=not progress)):
        if not isinstance(config.seed, int) or isinstance(config.seed, bool) or config.seed < 0:
            raise ConfigError(index, config, "seed",
                              f"seed must be an integer >= 0, got {config.seed!r}")
        kwargs = dict(config.env_kwargs)
        if config.policy.startswith("sb3:"):
            if config.policy not in agents:
                try:
                    agents[config.policy] = SB3Policy.load(config.policy[4:])
                except Exception as error:  # noqa: BLE001  (a bad path or file)
                    agents[config.policy] = error
            policy = agents[config.policy]
            if isinstance(policy, Exception):
                raise ConfigError(index, config, "policy", str(policy))
            kwargs.update(policy.env_interface)
        blamed = checker.blame(config.env_id, kwargs)
        if blamed is not None:
            raise ConfigError(index, config, *blamed)
        key = checker._key(config.env_id, [config.policy, config.policy_params, kwargs])
        if key in made:
            continue
        made.add(key)
        env = make_uncalibrated_env(config.env_id, kwargs)
        try:
            if config.policy.startswith("sb3:"):
                message = _space_error(agents[config.policy], env)
                if message is not None:
                    raise ConfigError(index, config, "policy", message,
                                      trained_preset=agents[config.policy].other_arm(env))
                continue
            _check_baseline(index, config, env)
        finally:
            env.close()


def _check_baseline(index: int, config: RunConfig, env: gym.Env) -> None:
    """Make the baseline of ``config`` on ``env``; a refusal of its name or parameters raises
    :class:`ConfigError`."""
    if config.policy not in BASELINES:
        raise ConfigError(index, config, "policy",
                          f"policy must be one of {sorted(BASELINES)} or sb3:PATH, got "
                          f"{config.policy!r}")
    try:
        make_policy(config.policy, env=env)
    except Exception as error:  # noqa: BLE001  (the baseline refuses this env: its message)
        raise ConfigError(index, config, "policy", str(error)) from None
    if config.policy_params:
        try:
            make_policy(config.policy, env=env, **config.policy_params)
        except Exception as error:  # noqa: BLE001
            raise ConfigError(index, config, "policy_params", str(error)) from None


def agent_error(name: str, env_id: str, env_kwargs: dict[str, Any]) -> str | None:
    """Why the SB3 agent ``name`` (``"sb3:PATH"``) cannot run on ``env_id`` made with
    ``env_kwargs`` plus the agent's own interface (a path that holds no model, another
    observation or action space), or ``None`` when it can. The env is built without calibrating
    its feedback, and closed."""
    try:
        policy = SB3Policy.load(name[4:])
        env = make_uncalibrated_env(env_id, {**env_kwargs, **policy.env_interface})
    except Exception as error:  # noqa: BLE001  (a bad path, file or interface)
        return " ".join(str(error).split())
    try:
        return _space_error(policy, env)
    finally:
        env.close()
