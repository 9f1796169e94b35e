"""The baseline-policy protocol and the checks of what a policy is given.

Every baseline has stable-baselines3's face, so the benchmark runner drives baselines and SB3
models alike (docs/architecture.md, "Baselines"):

* ``reset()`` at the start of an episode;
* ``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``;
* ``update(obs, action, reward, next_obs, info)`` after each step (online learners learn here);
* ``save(path)`` / ``load(path)``.

A baseline made by :func:`agents.policies.make_policy` with an env is ready to predict in a plain
``obs -> predict -> step`` loop: one that needs a calibration runs it on its first ``predict``,
on a private copy of the env (see :mod:`agents.controllers.cc_model`).

Baselines read only what the real robot gives them: the observation (whose ``pose`` part is the
env's feedback source) and sensor signals; never privileged simulator state. Baselines that
decide chamber pressures turn them into actions with the env's own map,
:class:`soft_gym.robots.actuation.Actuation` (``Actuation.of_env(env)``), in either action mode.

Here: :class:`BaselinePolicy` (the base class), :class:`PolicyRefusal` (a baseline declining an
env it cannot drive), :func:`check_observation` (an observation against its space),
:func:`require_soft_arm_env` (the env a baseline controls) and :func:`describe_value` (a value in
a few words, for error messages).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from soft_gym.envs import SoftArmEnv


class PolicyRefusal(ValueError):
    """A policy declining an env it cannot drive by design: an arm of another layout (chambers,
    segments), an observation without the parts it reads, an SB3 agent's other interface. The
    suite records such a run as ``n/a`` (:mod:`eval.suite`); every other error while a run is
    set up (a bad option, a calibration that fails) is an error."""


def describe_value(value: Any) -> str:
    """A short description of ``value`` for error messages (no full dump of large arrays)."""
    if isinstance(value, Mapping):
        return f"a dict with keys {list(value)}"
    if isinstance(value, np.ndarray) and value.size > 8:
        return f"an array of dtype {value.dtype} and shape {value.shape}"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def check_observation(space: Any, observation: Any, name: str = "observation",
                      batch: bool = False) -> Any:
    """``observation`` checked against the observation ``space`` it should come from.

    A ``Box`` space wants a real array (integer or float dtype; no strings, objects, booleans or
    complex numbers) of the space's shape, with no NaN or inf; a ``Dict`` space a dict with
    exactly its parts, each checked the same way (``observation['pose']``, ...). With ``batch``
    a stack of observations, shape ``(n, *space.shape)``, is accepted too (what an SB3 model
    predicts on). Other spaces are not checked.

    Returns:
        The observation as an array (a dict of arrays for a ``Dict`` space), its dtype kept.

    Raises:
        ValueError: naming ``name``, the shape wanted and what was given, e.g. ``observation
            must be a finite float array of shape (19,), got shape (7,)``.
    """
    if isinstance(space, spaces.Dict):
        parts = list(space.spaces)
        if not isinstance(observation, Mapping):
            raise ValueError(f"{name} must be a dict of the parts {parts}, got "
                             f"{describe_value(observation)}")
        if set(observation) != set(parts):
            raise ValueError(f"{name} must be a dict of the parts {parts}, got the parts "
                             f"{list(observation)}")
        return {part: check_observation(space.spaces[part], observation[part],
                                        f"{name}[{part!r}]", batch) for part in parts}
    if not isinstance(space, spaces.Box):
        return observation
    shape = tuple(space.shape)
    kind = "float" if np.issubdtype(space.dtype, np.floating) else str(space.dtype)
    wanted = f"{name} must be a finite {kind} array of shape {shape}"
    if isinstance(observation, Mapping) or observation is None:
        raise ValueError(f"{wanted}, got {describe_value(observation)}")
    try:
        array = np.asarray(observation)
    except (TypeError, ValueError) as error:  # ragged nesting
        raise ValueError(f"{wanted}, got {describe_value(observation)} ({error})") from None
    if np.iscomplexobj(array):
        raise ValueError(f"{wanted}, got complex values ({describe_value(observation)})")
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{wanted}, got dtype {array.dtype} ({describe_value(observation)})")
    batched = batch and array.ndim == len(shape) + 1 and array.shape[1:] == shape
    if array.shape != shape and not batched:
        raise ValueError(f"{wanted}, got shape {array.shape}")
    if array.dtype.kind == "f":
        bad = np.argwhere(~np.isfinite(array))
        if len(bad):
            index = tuple(int(i) for i in bad[0])
            raise ValueError(f"{wanted}, got {array[index]} at index "
                             f"{index[0] if len(index) == 1 else index} ({len(bad)} non-finite "
                             "entries)")
    return array


def require_soft_arm_env(env: Any, policy: str) -> SoftArmEnv:
    """The unwrapped :class:`~soft_gym.envs.SoftArmEnv` under ``env``; anything else (``None``,
    a string, another gymnasium env) raises ``ValueError`` naming ``env`` and ``policy``."""
    unwrapped = getattr(env, "unwrapped", None)
    if not isinstance(unwrapped, SoftArmEnv):
        raise ValueError(f"env must be the soft-arm environment {policy} controls (made by "
                         f"gymnasium.make('SoftArmTrack-v0', ...) or a SoftArmEnv), got "
                         f"{describe_value(env)}")
    return unwrapped


class BaselinePolicy:
    """Base class of the baselines (see the module docstring).

    Baselines that control an env keep its unwrapped :class:`~soft_gym.envs.SoftArmEnv` as
    ``self.env``; their :meth:`predict` calls :meth:`check_observation` before anything else,
    so a malformed observation is refused and leaves the policy's state as it was.
    """

    name = "baseline"

    def check_observation(self, observation: Any, name: str = "observation") -> Any:
        """``observation`` checked against the controlled env's observation space (see
        :func:`check_observation`); ``ValueError`` naming ``name`` where it does not fit."""
        return check_observation(self.env.observation_space, observation, name)

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
