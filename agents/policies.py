"""The baseline-policy protocol and a registry of baselines by name.

Every baseline has stable-baselines3's face, so the benchmark runner drives baselines and SB3
models alike (docs/architecture.md, "Baselines"):

* ``reset()`` at the start of an episode;
* ``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)``;
* ``update(obs, action, reward, next_obs, info)`` after each step (online learners learn here);
* ``save(path)`` / ``load(path)``.

A baseline made by :func:`make_policy` with an env is ready to predict in a plain
``obs -> predict -> step`` loop: one that needs a calibration runs it on its first ``predict``,
on a private copy of the env (see :mod:`agents.controllers.cc_model`).

Baselines read only what the real robot gives them: the observation (whose ``pose`` part is the
env's feedback source) and sensor signals; never privileged simulator state. Baselines that
decide chamber pressures turn them into actions with the env's own map,
:class:`soft_gym.robots.actuation.Actuation` (``Actuation.of_env(env)``), in either action mode.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path
from typing import Any

import numpy as np

from soft_gym._registry import build, parse_spec

BASELINES: dict[str, str] = {
    "cc_model": "agents.controllers.cc_model:CCModelController",
    "hybrid_gpr": "agents.controllers.hybrid_gpr:HybridGPRController",
    "lwpr_rwr": "agents.controllers.lwpr_rwr:LWPRRWRController",
    "local_ik_asdm": "agents.controllers.local_ik_asdm:LocalIKASDMController",
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


SHIPPED_DIR = Path(__file__).resolve().parent / "trained"
"""Trained agents kept in the repository, one directory each (``sb3:<name>`` loads one)."""


def shipped_agents() -> dict[str, Path]:
    """Name -> directory of every shipped agent (those holding a ``model.zip``)."""
    if not SHIPPED_DIR.is_dir():
        return {}
    return {path.name: path for path in sorted(SHIPPED_DIR.iterdir())
            if (path / "model.zip").is_file()}


def resolve_sb3_path(path: str | Path) -> Path:
    """A model path as given, or the shipped agent of that name."""
    candidate = Path(path)
    if not candidate.exists() and str(path) in shipped_agents():
        return shipped_agents()[str(path)]
    return candidate


SB3_INTERFACE_KEYS = ("obs", "obs_format", "action_mode", "delta_fraction")
"""Env keyword arguments that fix what an SB3 agent reads and writes (kept from its training)."""

_CHECKPOINT = re.compile(r"^(?P<prefix>.+)_(?P<steps>\d+)_steps\.zip$")
"""A checkpoint of stable-baselines3's ``CheckpointCallback``: ``<prefix>_<N>_steps.zip``."""


def normalization_file(model_path: str | Path) -> Path:
    """The VecNormalize statistics that belong to a model file (whether or not they exist).

    ``best_model.zip`` -> ``best_vecnormalize.pkl``; a checkpoint ``<prefix>_<N>_steps.zip``
    (``python -m train``'s ``checkpoints/``) -> ``<prefix>_vecnormalize_<N>_steps.pkl``, as
    ``CheckpointCallback`` saves them; any other model (``model.zip``) -> ``vecnormalize.pkl``;
    all in the model's directory.
    """
    model_path = Path(model_path)
    checkpoint = _CHECKPOINT.match(model_path.name)
    if checkpoint is not None:
        name = f"{checkpoint['prefix']}_vecnormalize_{checkpoint['steps']}_steps.pkl"
    elif model_path.name.startswith("best_"):
        name = "best_vecnormalize.pkl"
    else:
        name = "vecnormalize.pkl"
    return model_path.parent / name


def _run_config_file(model_path: Path) -> Path | None:
    """The ``config.yaml`` of a model: beside it, or in the run directory above a
    ``checkpoints/`` directory; ``None`` when there is none."""
    candidates = [model_path.parent / "config.yaml"]
    if model_path.parent.name == "checkpoints":
        candidates.append(model_path.parent.parent / "config.yaml")
    return next((path for path in candidates if path.is_file()), None)


def _trained_with_normalization(model_path: Path, config: dict) -> bool:
    """Whether the model was trained on normalised observations: its config's ``normalize``
    hyperparameter is set (as ``train.config`` reads it), or, without a config, statistics of
    other models lie beside it or in its run directory."""
    hyperparameters = config.get("hyperparameters")
    if isinstance(hyperparameters, dict):
        return hyperparameters.get("normalize", False) not in (False, None, "False", "false")
    directories = [model_path.parent]
    if model_path.parent.name == "checkpoints":
        directories.append(model_path.parent.parent)
    return any(any(directory.glob("*vecnormalize*.pkl")) for directory in directories)


class SB3Policy(BaselinePolicy):
    """A stable-baselines3 model behind the baseline face (loaded from ``sb3:PATH``).

    ``PATH`` is a run directory of ``python -m train`` (its ``model.zip``), a shipped agent's
    directory, or a model ``.zip`` (``best_model.zip``, a checkpoint
    ``checkpoints/<algo>_<N>_steps.zip``, ...). The observation normalisation that belongs to
    the model (:func:`normalization_file`) is applied before the network; a model trained with
    normalisation whose statistics are missing is refused with a ``ValueError`` naming the file.
    The run's ``config.yaml`` (beside the model, or above ``checkpoints/``) gives the env
    interface the agent was trained with (:data:`SB3_INTERFACE_KEYS`).
    """

    name = "sb3"

    def __init__(self, model, normalization=None, config: dict | None = None) -> None:
        self.model = model
        self.normalization = normalization
        self.config = dict(config or {})

    @property
    def env_interface(self) -> dict:
        """The training env's observation and action settings (``SB3_INTERFACE_KEYS``)."""
        env_kwargs = self.config.get("env_kwargs", {})
        return {key: env_kwargs[key] for key in SB3_INTERFACE_KEYS if key in env_kwargs}

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        if self.normalization is not None:
            observation = self.normalization.normalize_obs(observation)
        return self.model.predict(observation, state=state, episode_start=episode_start,
                                  deterministic=deterministic)

    def save(self, path: str | Path) -> None:
        """Save as a directory: ``model.zip``, ``vecnormalize.pkl`` and ``config.yaml``."""
        import pickle

        import yaml

        directory = Path(path)
        directory.mkdir(parents=True, exist_ok=True)
        self.model.save(directory / "model.zip")
        if self.normalization is not None:
            with open(directory / "vecnormalize.pkl", "wb") as handle:
                pickle.dump(self.normalization, handle)
        (directory / "config.yaml").write_text(yaml.safe_dump(self.config, sort_keys=False))

    @classmethod
    def load(cls, path: str | Path, env=None) -> "SB3Policy":
        import pickle

        import yaml

        path = resolve_sb3_path(path)
        model_path = path / "model.zip" if path.is_dir() else path
        if not model_path.is_file():
            raise ValueError(f"sb3 path {str(path)!r} is neither a model .zip, a directory "
                             f"holding model.zip, nor a shipped agent {sorted(shipped_agents())}")
        config_path = _run_config_file(model_path)
        config = (yaml.safe_load(config_path.read_text()) or {}) if config_path else {}
        normalization_path = normalization_file(model_path)
        if not normalization_path.is_file() and _trained_with_normalization(model_path, config):
            raise ValueError(
                f"sb3 path {str(path)!r}: the model was trained on normalised observations but "
                f"its VecNormalize statistics {str(normalization_path)!r} are missing")
        algorithm = str(config.get("algo") or _guess_algorithm(model_path)).upper()
        module = importlib.import_module("stable_baselines3")
        model = getattr(module, algorithm).load(model_path, device="cpu")
        normalization = None
        if normalization_path.is_file():
            with open(normalization_path, "rb") as handle:
                normalization = pickle.load(handle)
            normalization.training = False
            # what VecNormalize drops when pickled, so that this copy can be saved again
            normalization.class_attributes, normalization.returns = {}, np.zeros(1)
        policy = cls(model, normalization, config)
        if env is not None:
            policy.check_env(env)
        return policy

    def check_env(self, env) -> None:
        """Raise ``ValueError`` unless ``env`` gives observations of the shape the agent reads."""
        expected = self.model.observation_space.shape
        if env.observation_space.shape != expected:
            raise ValueError(
                f"the agent reads observations of shape {expected}, the env gives "
                f"{env.observation_space.shape}: make the env with the agent's interface "
                f"{self.env_interface}")


def _guess_algorithm(model_path: Path) -> str:
    """The SB3 algorithm of a bare model ``.zip`` from the attributes it saved."""
    import json
    import zipfile

    with zipfile.ZipFile(model_path) as archive:
        data = json.loads(archive.read("data").decode())
    if "n_epochs" in data:
        return "PPO"
    if "target_entropy" in data:
        return "SAC"
    if "policy_delay" in data:
        return "TD3"  # DDPG is TD3 with a delay of 1 and no target noise: it loads the same
    if "normalize_advantage" in data:
        return "A2C"
    raise ValueError(f"path {str(model_path)!r} holds no stable-baselines3 model this loader knows")


def make_policy(name: str, env=None, **params: Any) -> BaselinePolicy:
    """Build a baseline by name (see :data:`BASELINES`), or load ``"sb3:PATH"``.

    ``name`` is parsed by :func:`soft_gym._registry.parse_spec` (a name string only).
    """
    if isinstance(name, str) and name.startswith("sb3:"):
        return SB3Policy.load(name[4:], env=env)
    (spec,) = parse_spec(name, "policy", BASELINES, forms=("name",), also=("sb3:PATH",))
    module_name, class_name = BASELINES[spec.name].split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    return build("policy", spec.name, lambda **kwargs: cls(env, **kwargs), params)

