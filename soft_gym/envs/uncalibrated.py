"""Envs built to check a configuration, not to run it: every argument check and the simulator,
but no feedback calibration (the runs calibrate, cached on disk).

The evaluation runners and suites (:mod:`eval.runner`, :mod:`eval.suite`) and the training
command line (:mod:`train.cli_options`) build these to refuse a bad configuration before any
work.
"""

from __future__ import annotations

import copy
import functools
from typing import Any

import gymnasium as gym

from soft_gym.envs.soft_arm_env import SoftArmEnv


def make_uncalibrated_env(env_id: str, kwargs: dict[str, Any]) -> gym.Env:
    """The env of ``env_id`` with ``kwargs``, with every argument check and its simulator but no
    feedback calibration (the runs calibrate, cached on disk).

    Args:
        env_id: a registered Gymnasium id; an alias id (one arm's) keeps its preset.
        kwargs: the env's keyword arguments (copied, never changed).

    Returns:
        The env (:func:`uncalibrated_env_class`), unwrapped; close it after use.

    Raises:
        ValueError: an unregistered ``env_id``, another ``preset`` than an alias id's, or any
            argument the env refuses.
    """
    try:
        spec = gym.spec(env_id)
    except gym.error.Error as error:
        raise ValueError(f"env id must be a registered id, got {env_id!r} ({error})") from None
    entry = dict(spec.kwargs or {})
    alias = entry.pop("alias_preset", None)
    kwargs = copy.deepcopy(dict(kwargs))
    if alias is not None:
        if kwargs.get("preset", alias) != alias:
            raise ValueError(f"preset must be {alias!r} on {env_id}, got {kwargs['preset']!r}")
        kwargs["preset"] = alias
    return uncalibrated_env_class()(**{**entry, **kwargs})


@functools.lru_cache(maxsize=None)
def uncalibrated_env_class():
    """:class:`SoftArmEnv` with every argument check and its simulator but no feedback
    calibration: what the runners and :mod:`eval.suite` build to check configurations."""
    class UncalibratedEnv(SoftArmEnv):
        def _calibrate(self, use_cache: bool) -> None:  # the runs calibrate (cached on disk)
            pass

    return UncalibratedEnv
