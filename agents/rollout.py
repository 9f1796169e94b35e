"""One episode of a policy on an env, recorded step by step: what evaluation scores and training's
tracking curve evaluates.

The record of one episode is a dict of arrays over its ``T`` control steps, SI units (what is
computed from it: :mod:`agents.tracking_error`, :mod:`eval.metrics`): ``time_s``, ``target_m``,
``tip_m`` (ground truth), ``feedback_m`` (the pose the policy saw), ``action``,
``pressure_pa``, ``error_mm`` (the env's ``info["error_mm"]``), ``cycle`` and, for tracking
tasks, ``polyline_m``; plus the sensing pipeline's estimates (``camera_m``, ``femp_m``,
``fused_m``, ``em_m``, ``reprojection_error_px``) when the env provides them in
``info["estimates"]``.

A :class:`FrameSink` (``run_episode(frames=...)``, e.g. :class:`eval.video.EpisodeVideo`) is
handed one frame after ``reset`` and one after every step; taking a frame only reads the
simulation, so the record is the same with and without one.
"""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from agents.policies.base import BaselinePolicy
from soft_gym.tasks.paths import cycle_index


class FrameSink(Protocol):
    """Where the frames of an episode go: :meth:`capture` after ``reset`` and after every step,
    :meth:`close` once after the last."""

    def capture(self) -> None:
        """Take the env's frame now."""

    def close(self) -> Any:
        """Finish (e.g. write the video file)."""


def run_episode(env: gym.Env, policy: BaselinePolicy, seed: int = 0, learn: bool = True,
                progress: bool = False, description: str = "",
                frames: FrameSink | None = None) -> dict[str, np.ndarray]:
    """Run one episode of ``policy`` on ``env`` and record it (see the module docstring).

    Args:
        env: the env (a soft-arm env, possibly wrapped).
        policy: the policy; it is reset first and, with ``learn``, updated after every step
            (online learners).
        seed: the env's reset seed.
        learn: whether ``policy.update`` sees every transition.
        progress: show a progress bar over the task's ``episode_steps``.
        description: the progress bar's label.
        frames: given a frame after ``reset`` and one after every step, closed after the last
            step; ``None``: no frame is taken.

    Returns:
        The episode's record: column name -> array over the steps.
    """
    unwrapped = env.unwrapped
    observation, info = env.reset(seed=seed)
    policy.reset()
    if frames is not None:
        frames.capture()
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
        if frames is not None:
            frames.capture()
        bar.update(1)
    bar.close()
    if frames is not None:
        frames.close()
    record = {key: np.asarray(value, dtype=float) for key, value in columns.items()}
    steps = len(record["time_s"])
    cycles = getattr(getattr(task, "path_spec", None), "cycles", 1)
    if hasattr(task, "trajectory_m") and len(task.trajectory_m) == steps:
        record["cycle"] = cycle_index(steps, cycles)
        record["polyline_m"] = np.asarray(task.path_m)
    else:
        record["cycle"] = np.zeros(steps, dtype=int)
    for key, values in estimates.items():
        try:
            record[key] = np.asarray(values, dtype=float)
        except (TypeError, ValueError):  # not numbers per step (zou2022's SOM nodes, reasons)
            continue
    return record
