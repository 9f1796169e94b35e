"""Hyperparameter files in rl-baselines3-zoo's format, so a file works with both tools.

``train/configs/<algo>.yml`` maps an env id (or ``default``) to its hyperparameters:

.. code-block:: yaml

    SoftArmTrackWang2023-v0:
      n_timesteps: !!float 2e5
      policy: MlpPolicy
      normalize: "dict(norm_obs=True, norm_reward=True)"
      n_envs: 1
      env_kwargs: {feedback: em, randomization: true}
      policy_kwargs: "dict(net_arch=[128, 128])"
      learning_rate: !!float 7e-4      # or "lin_7e-4" for a linear decay to 0
      gamma: 0.9

``n_timesteps``, ``n_envs``, ``normalize``, ``env_kwargs``, ``noise_type`` / ``noise_std``
(off-policy action noise) are the zoo's special keys; everything else goes to the algorithm's
constructor. Strings such as ``"dict(net_arch=[64, 64], activation_fn=nn.ReLU)"`` are parsed
without ``eval``: only literals and ``nn.<Activation>`` names are allowed.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

CONFIG_DIR = Path(__file__).resolve().parent / "configs"
ALGORITHMS = ("sac", "td3", "ppo", "a2c", "ddpg")
OFF_POLICY = ("sac", "td3", "ddpg")
_SPECIAL = ("n_timesteps", "n_envs", "normalize", "env_kwargs", "noise_type", "noise_std",
            "policy")


def algorithm_class(algo: str):
    """The stable-baselines3 class of ``algo`` (``sac``, ``td3``, ``ppo``, ``a2c``, ``ddpg``)."""
    if algo not in ALGORITHMS:
        raise ValueError(f"algo must be one of {list(ALGORITHMS)}, got {algo!r}")
    import stable_baselines3

    return getattr(stable_baselines3, algo.upper())


def read_hyperparameters(algo: str, env_id: str, config_file: str | Path | None = None) -> dict:
    """The hyperparameters of ``env_id`` (or the file's ``default``) for ``algo``."""
    path = Path(config_file) if config_file is not None else CONFIG_DIR / f"{algo}.yml"
    if not path.is_file():
        raise ValueError(f"config file {str(path)!r} does not exist (algo {algo!r})")
    table = yaml.safe_load(path.read_text()) or {}
    if env_id in table:
        return dict(table[env_id])
    if "default" in table:
        return dict(table["default"])
    raise ValueError(f"config file {str(path)!r} has no entry for env {env_id!r} and no "
                     f"'default' (entries: {sorted(table)})")


def parse_python_value(text: str) -> Any:
    """A literal, or a ``dict(...)`` call of literals and ``nn.<Activation>`` names, from a string."""
    try:
        node = ast.parse(text, mode="eval").body
    except SyntaxError as error:
        raise ValueError(f"cannot parse {text!r}: {error}") from error
    return _evaluate(node, text)


def _evaluate(node: ast.AST, text: str) -> Any:
    import torch.nn as nn

    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict":
        if node.args:
            raise ValueError(f"only keyword arguments are allowed in dict(...), got {text!r}")
        return {keyword.arg: _evaluate(keyword.value, text) for keyword in node.keywords}
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
            and node.value.id == "nn":
        activation = getattr(nn, node.attr, None)
        if not (isinstance(activation, type) and issubclass(activation, nn.Module)):
            raise ValueError(f"nn.{node.attr} is not a torch.nn module (in {text!r})")
        return activation
    if isinstance(node, ast.List):
        return [_evaluate(item, text) for item in node.elts]
    if isinstance(node, ast.Dict):
        return {_evaluate(k, text): _evaluate(v, text) for k, v in zip(node.keys, node.values)}
    try:
        return ast.literal_eval(node)
    except ValueError as error:
        raise ValueError(f"only literals, dict(...) and nn.<Module> are allowed, got {text!r}") \
            from error


@dataclass
class TrainSettings:
    """Hyperparameters split into what the trainer uses and what the algorithm takes."""

    n_timesteps: int
    n_envs: int = 1
    policy: str = "MlpPolicy"
    normalize: dict | None = None
    env_kwargs: dict = field(default_factory=dict)
    algo_kwargs: dict = field(default_factory=dict)


def split_hyperparameters(algo: str, hyperparameters: dict) -> TrainSettings:
    """Turn a zoo-format entry into :class:`TrainSettings` (schedules and noise built)."""
    hp = dict(hyperparameters)
    if "n_timesteps" not in hp:
        raise ValueError(f"hyperparameters must give n_timesteps, got keys {sorted(hp)}")
    n_timesteps = int(float(hp["n_timesteps"]))
    n_envs = int(hp.get("n_envs", 1))
    if n_timesteps < 1 or n_envs < 1:
        raise ValueError(f"n_timesteps and n_envs must be >= 1, got {n_timesteps}, {n_envs}")
    normalize = hp.get("normalize", False)
    if isinstance(normalize, str):
        normalize = parse_python_value(normalize)
    if normalize is True:
        normalize = {}
    if normalize is False:
        normalize = None
    if normalize is not None and not isinstance(normalize, dict):
        raise ValueError(f"normalize must be a bool, a dict or a 'dict(...)' string, "
                         f"got {hp['normalize']!r}")
    if normalize is not None and "gamma" in hp:
        normalize = {**normalize, "gamma": hp["gamma"]}  # as the zoo does
    env_kwargs = hp.get("env_kwargs") or {}
    if isinstance(env_kwargs, str):
        env_kwargs = parse_python_value(env_kwargs)
    algo_kwargs = {key: value for key, value in hp.items() if key not in _SPECIAL}
    for key in ("policy_kwargs", "replay_buffer_kwargs"):
        if isinstance(algo_kwargs.get(key), str):
            algo_kwargs[key] = parse_python_value(algo_kwargs[key])
    for key in ("learning_rate", "clip_range"):
        value = algo_kwargs.get(key)
        if isinstance(value, str):
            algo_kwargs[key] = _linear_schedule(key, value)
    if "train_freq" in algo_kwargs and isinstance(algo_kwargs["train_freq"], list):
        algo_kwargs["train_freq"] = tuple(algo_kwargs["train_freq"])
    noise_type = hp.get("noise_type")
    if noise_type is not None:
        if algo not in OFF_POLICY:
            raise ValueError(f"noise_type applies to {list(OFF_POLICY)} only, not {algo!r}")
        algo_kwargs["action_noise"] = (noise_type, float(hp.get("noise_std", 0.1)))
    return TrainSettings(n_timesteps=n_timesteps, n_envs=n_envs, policy=hp.get("policy", "MlpPolicy"),
                         normalize=normalize, env_kwargs=dict(env_kwargs), algo_kwargs=algo_kwargs)


def _linear_schedule(key: str, text: str):
    from stable_baselines3.common.utils import LinearSchedule

    kind, _, value = text.partition("_")
    if kind != "lin" or not value:
        raise ValueError(f"{key} must be a number or 'lin_<initial>', got {text!r}")
    return LinearSchedule(float(value), 0.0, 1.0)


def build_action_noise(spec: tuple[str, float], n_actions: int):
    """``("normal" | "ornstein-uhlenbeck", std)`` -> an SB3 action-noise object."""
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    kind, std = spec
    sigma = std * np.ones(n_actions)
    if kind == "normal":
        return NormalActionNoise(mean=np.zeros(n_actions), sigma=sigma)
    if kind == "ornstein-uhlenbeck":
        return OrnsteinUhlenbeckActionNoise(mean=np.zeros(n_actions), sigma=sigma)
    raise ValueError(f"noise_type must be 'normal' or 'ornstein-uhlenbeck', got {kind!r}")


def parse_key_values(items: list[str] | None, name: str) -> dict:
    """``["a=1", "b=[x, y]", "c=em"]`` -> ``{"a": 1, "b": ["x", "y"], "c": "em"}`` (YAML values)."""
    result = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{name} entries must be KEY=VALUE, got {item!r}")
        result[key] = yaml.safe_load(value)
    return result
