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
(off-policy action noise) are the zoo's special keys; this project adds ``arm_env_kwargs``, a
list of mappings over ``env_kwargs`` that the arms of a batch (``--vec batched``) take in turn
(arm ``i`` the entry ``i`` modulo its length), e.g. one agent trained on several feedback
sources at once; everything else goes to the algorithm's constructor. Strings such as
``"dict(net_arch=[64, 64], activation_fn=nn.ReLU)"`` are parsed without ``eval``: only literals
and ``nn.<Activation>`` names are allowed.

:func:`check_hyperparameters` refuses, before anything is built, a key the algorithm does not
take (naming the keys it does) and a value out of range (``gamma`` in (0, 1], ``learning_rate``
> 0 or ``lin_<initial>``, ``batch_size`` an integer >= 1, ``tau`` in (0, 1], ... see
:data:`VALUE_RULES`).
"""

from __future__ import annotations

import ast
import inspect
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.policies.sb3 import ALGORITHM_CLASSES, model_class
from soft_gym.engines import engines_supporting

CONFIG_DIR = Path(__file__).resolve().parent / "configs"
ALGORITHMS = tuple(ALGORITHM_CLASSES)
"""``--algo`` names, as rl-baselines3-zoo spells them: ``ppo_lstm`` is sb3-contrib's
``RecurrentPPO`` (an LSTM policy that carries a memory through the episode), the others
stable-baselines3's classes of the same name (:data:`agents.policies.sb3.ALGORITHM_CLASSES`)."""
OFF_POLICY = ("sac", "td3", "ddpg")
VEC_KINDS = ("subprocess", "batched")
"""How ``n_envs`` envs run (:func:`train.trainer.make_vec_env`)."""


def batched_engines() -> str:
    """The env keyword that ``vec="batched"`` needs, in words: the engines that step arms as one
    batch (:func:`soft_gym.engines.engines_supporting`), e.g. ``"engine=mujoco"``."""
    return " or ".join(f"engine={name}" for name in engines_supporting("batched"))

_SPECIAL = ("n_timesteps", "n_envs", "normalize", "env_kwargs", "arm_env_kwargs", "noise_type",
            "noise_std", "policy")


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float, np.integer, np.floating))
            and not isinstance(value, bool) and bool(np.isfinite(value)))


def _int_at_least(low: int):
    return (lambda v: _is_int(v) and v >= low), f"an integer >= {low}"


def _number_in(low: float, high: float | None, low_open: bool, text: str):
    def rule(value: Any) -> bool:
        if not _is_number(value):
            return False
        above = value > low if low_open else value >= low
        return above and (high is None or value <= high)

    return rule, text


def _schedule_or(rule_text: tuple) -> tuple:
    rule, text = rule_text

    def either(value: Any) -> bool:
        if isinstance(value, str):
            kind, _, initial = value.partition("_")
            try:
                return kind == "lin" and rule(float(initial))
            except ValueError:
                return False
        return rule(value)

    return either, f"{text}, or 'lin_<initial>' with such an initial value (a linear decay)"


def _train_freq(value: Any) -> bool:
    if isinstance(value, (list, tuple)):
        return (len(value) == 2 and _is_int(value[0]) and value[0] >= 1
                and value[1] in ("step", "episode"))
    return _is_int(value) and value >= 1


def _ent_coef(value: Any) -> bool:
    if isinstance(value, str):
        if value == "auto":
            return True
        kind, _, initial = value.partition("_")
        try:
            return kind == "auto" and float(initial) > 0
        except ValueError:
            return False
    return _is_number(value) and value >= 0


def _literal_or_text(kind: type):
    def rule(value: Any) -> bool:
        if isinstance(value, str):
            try:
                value = parse_python_value(value)
            except ValueError:
                return False
        return isinstance(value, kind)

    return rule


_POSITIVE = _number_in(0.0, None, True, "a finite number > 0")
_NON_NEGATIVE = _number_in(0.0, None, False, "a finite number >= 0")
_BOOL = ((lambda v: isinstance(v, bool)), "true or false")

POLICY_CLASSES = ("MlpPolicy", "MultiInputPolicy", "MlpLstmPolicy", "MultiInputLstmPolicy")
"""Policy class names a config may give; the ``Lstm`` ones are ``ppo_lstm``'s, and only its."""


VALUE_RULES: dict[str, tuple] = {
    "n_timesteps": ((lambda v: _is_number(v) and float(v).is_integer() and v >= 1),
                    "a whole number >= 1"),
    "n_envs": _int_at_least(1),
    "policy": ((lambda v: isinstance(v, str) and v in POLICY_CLASSES),
               "'MlpPolicy' (flat observations) or 'MultiInputPolicy' (obs_format=dict), "
               "'MlpLstmPolicy' or 'MultiInputLstmPolicy' for ppo_lstm"),
    "normalize": ((lambda v: isinstance(v, (bool, dict)) or _literal_or_text(dict)(v)),
                  "true, false, a mapping or a 'dict(...)' string of VecNormalize arguments"),
    "env_kwargs": (_literal_or_text(dict), "a mapping or a 'dict(...)' string"),
    "arm_env_kwargs": ((lambda v: isinstance(v, list) and len(v) >= 1
                        and all(isinstance(item, dict) for item in v)),
                       "a list of one or more mappings (each arm's env keyword arguments over "
                       "env_kwargs, taken in turn)"),
    "policy_kwargs": (_literal_or_text(dict), "a mapping or a 'dict(...)' string"),
    "replay_buffer_kwargs": (_literal_or_text(dict), "a mapping or a 'dict(...)' string"),
    "noise_type": ((lambda v: v in ("normal", "ornstein-uhlenbeck")),
                   "'normal' or 'ornstein-uhlenbeck'"),
    "noise_std": _NON_NEGATIVE,
    "learning_rate": _schedule_or(_POSITIVE),
    "clip_range": _schedule_or(_POSITIVE),
    "clip_range_vf": ((lambda v: v is None or _POSITIVE[0](v)), "null or a finite number > 0"),
    "gamma": _number_in(0.0, 1.0, True, "a number in (0, 1]"),
    "tau": _number_in(0.0, 1.0, True, "a number in (0, 1]"),
    "gae_lambda": _number_in(0.0, 1.0, False, "a number in [0, 1]"),
    "batch_size": _int_at_least(1),
    "buffer_size": _int_at_least(1),
    "n_steps": _int_at_least(1),
    "n_epochs": _int_at_least(1),
    "learning_starts": _int_at_least(0),
    "policy_delay": _int_at_least(1),
    "target_update_interval": _int_at_least(1),
    "train_freq": (_train_freq, "an integer >= 1 or [N, 'step' | 'episode']"),
    "gradient_steps": ((lambda v: _is_int(v) and (v >= 1 or v == -1)),
                       "an integer >= 1, or -1 (as many as env steps)"),
    "ent_coef": (_ent_coef, "a finite number >= 0, 'auto' or 'auto_<initial>'"),
    "vf_coef": _NON_NEGATIVE,
    "max_grad_norm": _POSITIVE,
    "target_policy_noise": _NON_NEGATIVE,
    "target_noise_clip": _NON_NEGATIVE,
    "rms_prop_eps": _POSITIVE,
    "sde_sample_freq": ((lambda v: _is_int(v) and v >= -1), "an integer >= -1"),
    "use_sde": _BOOL, "use_sde_at_warmup": _BOOL, "normalize_advantage": _BOOL,
    "use_rms_prop": _BOOL, "optimize_memory_usage": _BOOL,
}
"""Hyperparameter -> (its check, what is allowed); keys without a rule are checked by the
algorithm itself."""


def allowed_hyperparameters(algo: str) -> list[str]:
    """The keys a config entry or ``-hp`` may set for ``algo``: the zoo's special keys and the
    keyword arguments of the algorithm's constructor (but ``policy``'s ``env``)."""
    names = inspect.signature(algorithm_class(algo).__init__).parameters
    own = [name for name in names if name not in ("self", "env", "policy", "seed", "verbose",
                                                  "device", "tensorboard_log", "_init_setup_model",
                                                  "action_noise")]
    return sorted(set(own) | set(_SPECIAL))


def check_hyperparameters(algo: str, hyperparameters: dict) -> None:
    """Refuse a key ``algo`` does not take or a value out of range, before anything is built.

    Raises:
        ValueError: one line naming the key, the value and what is allowed.
    """
    allowed = allowed_hyperparameters(algo)
    for key, value in hyperparameters.items():
        if key not in allowed:
            raise ValueError(f"unknown hyperparameter {key!r} for {algo}; allowed: {allowed}")
        if key in VALUE_RULES:
            rule, text = VALUE_RULES[key]
            if not rule(value):
                raise ValueError(f"{key} must be {text}, got {value!r}")
    policy = hyperparameters.get("policy")
    if isinstance(policy, str) and ("Lstm" in policy) != (algo == "ppo_lstm"):
        wanted = ("'MlpLstmPolicy' or 'MultiInputLstmPolicy'" if algo == "ppo_lstm"
                  else "'MlpPolicy' or 'MultiInputPolicy'")
        raise ValueError(f"policy must be {wanted} for {algo}, got {policy!r}")
    if isinstance(hyperparameters.get("ent_coef"), str) and algo != "sac":
        raise ValueError(f"ent_coef must be a finite number >= 0 for {algo} ('auto' is SAC's "
                         f"only), got {hyperparameters['ent_coef']!r}")
    if "noise_type" in hyperparameters and algo not in OFF_POLICY:
        raise ValueError(f"noise_type applies to {list(OFF_POLICY)} only, not {algo!r}")


def algorithm_class(algo: str):
    """The model class of ``algo`` (:data:`ALGORITHMS`; imported on first use)."""
    if algo not in ALGORITHMS:
        raise ValueError(f"algo must be one of {list(ALGORITHMS)}, got {algo!r}")
    return model_class(ALGORITHM_CLASSES[algo])


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
    # lazy: PyTorch costs 1.0 s (-X importtime) that python -m train --help skips
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
    arm_env_kwargs: list[dict] | None = None

    def per_arm_env_kwargs(self) -> list[dict] | None:
        """Each of the ``n_envs`` arms' keyword arguments over :attr:`env_kwargs` (arm ``i``
        takes entry ``i`` modulo the length of :attr:`arm_env_kwargs`); ``None`` without."""
        if not self.arm_env_kwargs:
            return None
        return [dict(self.arm_env_kwargs[i % len(self.arm_env_kwargs)])
                for i in range(self.n_envs)]

    def arm_variants(self) -> list[dict]:
        """The distinct entries of :attr:`arm_env_kwargs` in order (``[{}]`` without): each
        env the arms train on differs from :attr:`env_kwargs` by one of these."""
        variants: list[dict] = []
        for entry in self.arm_env_kwargs or [{}]:
            if entry not in variants:
                variants.append(dict(entry))
        return variants


def split_hyperparameters(algo: str, hyperparameters: dict) -> TrainSettings:
    """Turn a zoo-format entry into :class:`TrainSettings` (schedules and noise built)."""
    hp = dict(hyperparameters)
    check_hyperparameters(algo, hp)
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
    arm_env_kwargs = hp.get("arm_env_kwargs")
    return TrainSettings(n_timesteps=n_timesteps, n_envs=n_envs, policy=hp.get("policy", "MlpPolicy"),
                         normalize=normalize, env_kwargs=dict(env_kwargs), algo_kwargs=algo_kwargs,
                         arm_env_kwargs=(None if arm_env_kwargs is None
                                         else [dict(entry) for entry in arm_env_kwargs]))


def _linear_schedule(key: str, text: str):
    # lazy: stable-baselines3 costs 1.2 s (-X importtime) that python -m train --help skips
    from stable_baselines3.common.utils import LinearSchedule

    kind, _, value = text.partition("_")
    if kind != "lin" or not value:
        raise ValueError(f"{key} must be a number or 'lin_<initial>', got {text!r}")
    return LinearSchedule(float(value), 0.0, 1.0)


def build_action_noise(spec: tuple[str, float], n_actions: int):
    """``("normal" | "ornstein-uhlenbeck", std)`` -> an SB3 action-noise object."""
    # lazy: stable-baselines3 costs 1.2 s (-X importtime) that python -m train --help skips
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
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError as error:
            problem = getattr(error, "problem", None) or str(error).splitlines()[0]
            raise ValueError(f"{name} {item!r}: the value is not YAML ({problem}); quote "
                             f"strings with brackets or colons") from None
        if isinstance(parsed, str) and _SCIENTIFIC.match(parsed):
            parsed = float(parsed)  # YAML 1.1 reads 1e-3 as text; it is meant as a number
        result[key] = parsed
    return result


_SCIENTIFIC = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)[eE][+-]?\d+$")
