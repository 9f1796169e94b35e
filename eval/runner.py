"""Drive any policy (baseline or SB3 model) through any env configuration and record each step.

The record of one episode is a dict of arrays (see :mod:`eval.metrics` for what is computed from
it): ``time_s``, ``target_m``, ``tip_m`` (ground truth), ``feedback_m`` (the pose the policy saw),
``action``, ``pressure_pa``, ``cycle`` and, for tracking tasks, ``polyline_m``; plus the sensing
pipeline's estimates (``camera_m``, ``femp_m``, ``fused_m``, ``em_m``,
``reprojection_error_px``) when the env provides them in ``info["estimates"]``.

With a video path (``RunConfig.video_path``, ``run_episode(video_path=...)``) the run also writes
a video (:mod:`eval.video`) of :func:`soft_gym.envs.rendering.render_frame` frames: one after
``reset`` and one after every step, at the env's ``render_fps``. Rendering only reads the
simulation, so the record is the same with and without a video.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import soft_gym  # noqa: F401  (registers the env ids)
from agents.policies import BaselinePolicy, SB3Policy, make_policy
from soft_gym.tasks.paths import cycle_index


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
        for key in ("preset", "path", "scenario", "faults", "feedback"):
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


def run_episode(env: gym.Env, policy: BaselinePolicy, seed: int = 0, learn: bool = True,
                progress: bool = False, description: str = "",
                video_path: str | Path | None = None,
                video_panels: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Run one episode of ``policy`` on ``env`` (online learners update every step); with
    ``video_path``, write its video there (see the module docstring)."""
    unwrapped = env.unwrapped
    video = None if video_path is None else _EpisodeVideo(env, video_path, video_panels)
    observation, info = env.reset(seed=seed)
    policy.reset()
    if video is not None:
        video.capture()
    columns: dict[str, list] = {key: [] for key in (
        "time_s", "target_m", "tip_m", "feedback_m", "action", "pressure_pa", "error_mm")}
    estimates: dict[str, list] = {}
    task = unwrapped.task
    total = getattr(task, "episode_steps", None)
    bar = tqdm(total=total, desc=description, leave=False, disable=not progress)
    done = False
    while not done:
        action, _ = policy.predict(observation, deterministic=True)
        next_observation, reward, terminated, truncated, info = env.step(action)
        if learn:
            policy.update(observation, action, reward, next_observation, info)
        columns["time_s"].append(info["time_s"])
        columns["target_m"].append(info["target_m"])
        columns["tip_m"].append(info["tip_position_m"])
        columns["feedback_m"].append(
            unwrapped.observation_part(next_observation, "pose")[:3]
            if "pose" in unwrapped.obs_parts else info["tip_position_m"])
        columns["action"].append(np.asarray(action, dtype=float))
        columns["pressure_pa"].append(info["pressures_pa"])
        columns["error_mm"].append(info["error_mm"])
        for key, value in info.get("estimates", {}).items():
            estimates.setdefault(key, []).append(value)
        observation = next_observation
        done = terminated or truncated
        if video is not None:
            video.capture()
        bar.update(1)
    bar.close()
    if video is not None:
        video.close()
    record = {key: np.asarray(value, dtype=float) for key, value in columns.items()}
    steps = len(record["time_s"])
    cycles = getattr(getattr(task, "path_spec", None), "cycles", 1)
    if hasattr(task, "trajectory_m") and len(task.trajectory_m) == steps:
        record["cycle"] = cycle_index(steps, cycles)
        record["polyline_m"] = np.asarray(task.polyline_m)
    else:
        record["cycle"] = np.zeros(steps, dtype=int)
    for key, values in estimates.items():
        try:
            record[key] = np.asarray(values, dtype=float)
        except (TypeError, ValueError):  # not numbers per step (zou2022's SOM nodes, reasons)
            continue
    return record


class _EpisodeVideo:
    """Frames of one episode streamed into a video file."""

    def __init__(self, env: gym.Env, path: str | Path, panels: Sequence[str] | None) -> None:
        from eval.video import VideoWriter
        from soft_gym.envs.rendering import check_panels, default_panels

        self.env = env
        self.panels = default_panels(env) if panels is None else check_panels(env, panels)
        self.writer = VideoWriter(path, env.unwrapped.metadata["render_fps"])

    def capture(self) -> None:
        from soft_gym.envs.rendering import render_frame

        self.writer.append(render_frame(self.env, self.panels))

    def close(self) -> Path:
        return self.writer.close()


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
        return run_episode(env, policy, seed=config.seed, progress=progress,
                           description=f"{config.policy} seed {config.seed}",
                           video_path=config.video_path, video_panels=config.video_panels)
    finally:
        env.close()


def run_many(configs: list[RunConfig], workers: int = 1,
             progress: bool = False) -> list[dict[str, np.ndarray]]:
    """Run several configurations, in ``workers`` processes when > 1; records in input order.

    Each worker process calibrates its own sensing pipeline (the calibration is cached per
    process), and seeded runs give the same records whichever process runs them.
    """
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if workers == 1 or len(configs) <= 1:
        return [run(config, progress=progress) for config in configs]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(workers, len(configs)), mp_context=context) as pool:
        return list(tqdm(pool.map(run, configs), total=len(configs), desc="runs",
                         disable=not progress))
