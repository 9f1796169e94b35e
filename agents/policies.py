"""The baseline-policy protocol and a registry of baselines by name.

Every baseline has stable-baselines3's face, so the benchmark runner drives baselines and SB3
models alike (DESIGN.md section 6):

* ``reset()`` at the start of an episode;
* ``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``;
* ``update(obs, action, reward, next_obs, info)`` after each step (online learners learn here);
* ``save(path)`` / ``load(path)``.

Baselines read only what the real robot gives them: the observation (whose ``pose`` part is the
env's feedback source) and sensor signals; never privileged simulator state.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import numpy as np

BASELINES: dict[str, str] = {
    "cc_model": "agents.controllers.cc_model:CCModelController",
    "hybrid_gpr": "agents.controllers.hybrid_gpr:HybridGPRController",
}
"""Baseline names and the classes implementing them."""


class BaselinePolicy:
    """Base class of the baselines (see the module docstring)."""

    name = "baseline"

    def reset(self) -> None:
        """Start of an episode; learned state persists, episode state is cleared."""

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        raise NotImplementedError

    def update(self, observation, action, reward, next_observation, info) -> None:
        """Learn from one transition (no-op for non-learning baselines)."""

    def save(self, path: str | Path) -> None:
        raise NotImplementedError

    @classmethod
    def load(cls, path: str | Path, env=None) -> "BaselinePolicy":
        raise NotImplementedError


class SB3Policy(BaselinePolicy):
    """A stable-baselines3 model behind the baseline face (loaded from ``sb3:PATH``)."""

    name = "sb3"

    def __init__(self, model) -> None:
        self.model = model

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        return self.model.predict(observation, state=state, episode_start=episode_start,
                                  deterministic=deterministic)

    def save(self, path: str | Path) -> None:
        self.model.save(path)

    @classmethod
    def load(cls, path: str | Path, env=None) -> "SB3Policy":
        import zipfile

        with zipfile.ZipFile(path) as archive:
            data = archive.read("data").decode()
        for algorithm in ("SAC", "TD3", "PPO", "DDPG", "A2C"):
            if f"stable_baselines3.{algorithm.lower()}" in data:
                module = importlib.import_module("stable_baselines3")
                return cls(getattr(module, algorithm).load(path, env=env))
        raise ValueError(f"path {str(path)!r} holds no stable-baselines3 model this loader knows")


def make_policy(name: str, env=None, **params: Any) -> BaselinePolicy:
    """Build a baseline by name (see :data:`BASELINES`), or load ``"sb3:PATH"``."""
    if name.startswith("sb3:"):
        return SB3Policy.load(name[4:], env=env)
    if name not in BASELINES:
        raise ValueError(f"policy must be one of {sorted(BASELINES)} or 'sb3:PATH', got {name!r}")
    module_name, class_name = BASELINES[name].split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    try:
        return cls(env, **params)
    except TypeError as error:
        raise ValueError(f"policy {name!r} got invalid parameters {params}: {error}") from error


def pressures_to_action(pressures_pa: np.ndarray, p_low: np.ndarray, p_high: np.ndarray) -> np.ndarray:
    """Absolute-mode action in [-1, 1] for chamber pressures (Pa), saturating at the limits."""
    fraction = (np.asarray(pressures_pa) - p_low) / (p_high - p_low)
    return np.clip(2.0 * fraction - 1.0, -1.0, 1.0).astype(np.float32)
