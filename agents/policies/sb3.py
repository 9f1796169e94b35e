"""Trained stable-baselines3 agents behind the baseline face: ``sb3:PATH`` and the shipped agents.

:class:`SB3Policy` loads a model ``.zip`` with the VecNormalize statistics that belong to it
(:func:`~agents.policies.run_dir.normalization_file`) and the env interface of its run's
``config.yaml`` (:data:`SB3_INTERFACE_KEYS`; the files of a run directory and their readers are
:mod:`agents.policies.run_dir`'s), and refuses a damaged or mismatched file with one ``ValueError``
naming the file. A model carries whether it was trained with VecNormalize (its
:data:`NORMALIZATION_MARK` attribute, saved in the zip's ``data`` entry; :func:`mark_normalization`
sets it on a model, :func:`mark_model_file` on a saved one), so a bare ``model.zip`` copied without
its statistics is refused rather than run on raw observations. :data:`SHIPPED_DIR` holds the
agents kept in the repository (:func:`shipped_agents`; ``sb3:<name>`` loads one,
:func:`resolve_sb3_path`).
"""

from __future__ import annotations

import json
import pickle
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from agents.policies.base import BaselinePolicy, PolicyRefusal, check_observation, describe_value
from soft_gym.engines import REFERENCE_ENGINE
from agents.policies.run_dir import (CONFIG_FILE, MODEL_FILE, NORMALIZATION_FILE,
                                     has_normalization_files, normalization_file,
                                     read_run_config, read_training_segments, run_config_file,
                                     run_directory, write_run_config)

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "trained"
"""Trained agents kept in the repository, one directory each (``sb3:<name>`` loads one)."""


def shipped_agents(env_id: str | None = None) -> dict[str, Path]:
    """Name -> directory of every shipped agent (those holding a ``model.zip``); with ``env_id``
    only those trained on that env id (their ``config.yaml``'s ``env_id``)."""
    if not SHIPPED_DIR.is_dir():
        return {}
    agents = {path.name: path for path in sorted(SHIPPED_DIR.iterdir())
              if (path / MODEL_FILE).is_file()}
    if env_id is None:
        return agents
    return {name: path for name, path in agents.items()
            if read_run_config(path / CONFIG_FILE).get("env_id") == env_id}


def training_budget(path: str | Path) -> dict[str, Any] | None:
    """What training an agent took, from the ``training.yaml`` and ``config.yaml`` beside it
    (``python -m train`` writes them; ``train.ship`` ships them); ``None`` without a
    ``training.yaml``.

    ``path``: an agent's directory, its model ``.zip``, or a shipped agent's name. Returns
    ``timesteps`` (env steps, all segments of a resumed run), ``wall_s`` (s, demonstrations
    included), ``n_envs``, ``engine`` (the training env's, ``pybullet`` where unset),
    ``feedback`` (the training env's), ``plateau`` (whether the last segment stopped at the
    tracking curve's plateau, :mod:`train.tracking_curve`), ``interrupted`` (whether it was
    stopped by hand, Ctrl-C), ``demonstrations`` (whether it started from a baseline's
    episodes) and ``trained_agent`` (the agent it was fine-tuned from, ``python -m train
    --trained-agent``, whose steps and time the totals include, as do those of the agents that
    agent came from; ``None`` where it started anew).
    """
    segments = training_segments(path)
    if segments is None:
        return None
    env_kwargs = read_run_config(run_config_file(_run_directory(path) / MODEL_FILE)).get(
        "env_kwargs") or {}
    return {"timesteps": int(sum(segment["timesteps"] for segment in segments)),
            "wall_s": float(sum(segment.get("wall_s", 0.0) + segment.get("demo_wall_s", 0.0)
                                for segment in segments)),
            "n_envs": int(segments[-1].get("n_envs", 1)),
            "engine": str(env_kwargs.get("engine", REFERENCE_ENGINE)),
            "feedback": env_kwargs.get("feedback"),
            "plateau": bool(segments[-1].get("stopped_at_plateau", False)),
            "interrupted": bool(segments[-1].get("interrupted", False)),
            "demonstrations": any("demonstrations" in segment for segment in segments),
            "trained_agent": next((str(segment["trained_agent"]) for segment in reversed(segments)
                                   if segment.get("trained_agent")), None)}


def training_feedbacks(path: str | Path) -> tuple[str, ...] | None:
    """The feedback sources an agent was trained on, from the ``config.yaml`` of its run
    (``path`` as :func:`training_budget`'s): its training env's ``feedback`` (``None`` in the
    tuple where the env's default was used), then those of the envs it was trained on beside it
    (``hyperparameters.arm_env_kwargs``, a run on several feedback sources at once), each once;
    ``None`` where the run has no ``config.yaml``."""
    config_file = run_config_file(_run_directory(path) / MODEL_FILE)
    if config_file is None:
        return None
    config = read_run_config(config_file)
    base = (config.get("env_kwargs") or {}).get("feedback")
    found = [base]
    hyperparameters = config.get("hyperparameters")
    extra = hyperparameters.get("arm_env_kwargs") if isinstance(hyperparameters, dict) else None
    for kwargs in extra if isinstance(extra, list) else ():
        if isinstance(kwargs, dict):
            found.append(kwargs.get("feedback", base))
    return tuple(dict.fromkeys(found))


def _run_directory(path: str | Path) -> Path:
    """The run (or shipped agent's) directory of an agent's directory, model ``.zip``
    (a checkpoint's included) or shipped name."""
    return run_directory(resolve_sb3_path(path))


def training_segments(path: str | Path) -> list[dict[str, Any]] | None:
    """The segments of the ``training.yaml`` beside an agent (``path`` as
    :func:`training_budget`'s), one per training, each with its ``timesteps``; ``None``
    without one, ``ValueError`` naming the file where it is unreadable or malformed."""
    return read_training_segments(_run_directory(path))


REPOSITORY_DIR = SHIPPED_DIR.parents[1]
"""The repository's root: a relative ``sb3:`` path not found from the working directory is looked
up here (``sb3:agents/studies/demos/...``, the agents of a study kept beside the shipped ones)."""


def resolve_sb3_path(path: str | Path) -> Path:
    """A model path as given (from the working directory, else from the repository's root), or
    the shipped agent of that name."""
    candidate = Path(path)
    if candidate.exists():
        return candidate
    if str(path) in shipped_agents():
        return shipped_agents()[str(path)]
    if not candidate.is_absolute() and (REPOSITORY_DIR / candidate).exists():
        return REPOSITORY_DIR / candidate
    return candidate


SB3_INTERFACE_KEYS = ("obs", "obs_format", "action_mode", "delta_fraction")
"""Env keyword arguments that fix what an SB3 agent reads and writes (kept from its training)."""

NORMALIZATION_MARK = "trained_with_vecnormalize"
"""The model attribute that says whether it was trained in a VecNormalize wrapper (``True``: its
statistics, :func:`~agents.policies.run_dir.normalization_file`, belong with it).
stable-baselines3 saves every plain attribute of a model in the zip's ``data`` entry and restores
it on load, so the mark travels with the file wherever it is copied."""


def _check_mark(normalized: Any) -> bool:
    """``normalized`` if it is a bool; ``TypeError`` naming it otherwise."""
    if not isinstance(normalized, bool):
        raise TypeError(f"normalized must be a bool, got {describe_value(normalized)}")
    return normalized


def mark_normalization(model, normalized: bool) -> None:
    """Set :data:`NORMALIZATION_MARK` on an SB3 ``model`` (before it is saved)."""
    setattr(model, NORMALIZATION_MARK, _check_mark(normalized))


def mark_model_file(model_path: str | Path, normalized: bool) -> None:
    """Write :data:`NORMALIZATION_MARK` into a saved model ``.zip``'s ``data`` entry, leaving its
    other entries (the network weights) as they are; ``ValueError`` naming the file where it is
    no stable-baselines3 model."""
    model_path = Path(model_path)
    data = _check_model_archive(model_path)
    data[NORMALIZATION_MARK] = _check_mark(normalized)
    with zipfile.ZipFile(model_path) as archive:
        entries = [(info, archive.read(info.filename)) for info in archive.infolist()]
    with zipfile.ZipFile(model_path, "w") as archive:
        for info, content in entries:
            if info.filename == "data":
                content = json.dumps(data, indent=4).encode()
            archive.writestr(info, content)


def model_normalization_mark(model_path: str | Path) -> bool | None:
    """A saved model's :data:`NORMALIZATION_MARK` (``None`` for a model saved without one)."""
    mark = _check_model_archive(Path(model_path)).get(NORMALIZATION_MARK)
    return mark if isinstance(mark, bool) else None


def _trained_with_normalization(model_path: Path, config: dict, data: dict) -> bool:
    """Whether the model was trained on normalised observations: its own
    :data:`NORMALIZATION_MARK` where it carries one; else (a model saved before the mark) its
    config's ``normalize`` hyperparameter (as ``train.config`` reads it), or, without a config,
    whether statistics of other models lie beside it or in its run directory."""
    if isinstance(data.get(NORMALIZATION_MARK), bool):
        return data[NORMALIZATION_MARK]
    hyperparameters = config.get("hyperparameters")
    if isinstance(hyperparameters, dict):
        return hyperparameters.get("normalize", False) not in (False, None, "False", "false")
    return has_normalization_files(model_path)


ALGORITHM_CLASSES = {"sac": "SAC", "td3": "TD3", "ppo": "PPO", "a2c": "A2C", "ddpg": "DDPG",
                     "ppo_lstm": "RecurrentPPO"}
"""``python -m train --algo`` name (rl-baselines3-zoo's spelling, as a run config's ``algo``) ->
the model class: stable-baselines3's, and sb3-contrib's ``RecurrentPPO`` for ``ppo_lstm``."""

SB3_ALGORITHMS = tuple(dict.fromkeys(ALGORITHM_CLASSES.values()))
"""Model classes this loader knows."""


def model_class(algorithm: str):
    """The model class named ``algorithm`` (one of :data:`SB3_ALGORITHMS`)."""
    # lazy: stable-baselines3 costs 1.2 s (-X importtime) that the baselines never need
    if algorithm == "RecurrentPPO":
        import sb3_contrib

        return sb3_contrib.RecurrentPPO
    import stable_baselines3

    return getattr(stable_baselines3, algorithm)


def _space_shapes(space: Any) -> Any:
    """What an agent's interface depends on in a space: its kind and shape (for a ``Dict``, those
    of every part), so that spaces differing only in bounds still match."""
    if isinstance(space, spaces.Dict):
        return {key: _space_shapes(part) for key, part in space.spaces.items()}
    return type(space).__name__, tuple(getattr(space, "shape", None) or ())


def _describe_space(space: Any) -> str:
    """A space in a few words on one line: its kind and shape (``Box (16,)``), or for a
    ``Dict`` those of each part."""
    shapes = _space_shapes(space)
    if isinstance(shapes, dict):
        return "Dict(" + ", ".join(f"{key}: {_describe_space(part)}"
                                   for key, part in space.spaces.items()) + ")"
    kind, shape = shapes
    return f"{kind} {shape}"


def _check_model_archive(model_path: Path) -> dict:
    """The attributes (``data`` entry) of a stable-baselines3 model ``.zip``; ``ValueError``
    naming the file where it is no zip, a damaged one, or a zip SB3 did not write."""
    what = f"sb3 model file {str(model_path)!r}"
    try:
        with zipfile.ZipFile(model_path) as archive:
            names = archive.namelist()
            missing = [name for name in ("data", "policy.pth") if name not in names]
            if missing:
                raise ValueError(f"{what} is not a stable-baselines3 model (truncated, or a "
                                 f"zip SB3 did not write): it lacks the entries {missing} "
                                 f"(it holds {names[:4]}{' ...' if len(names) > 4 else ''})")
            damaged = archive.testzip()
            if damaged is not None:
                raise ValueError(f"{what} is damaged: its entry {damaged!r} fails its CRC check")
            data = json.loads(archive.read("data").decode())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:  # before ValueError: subclasses
        raise ValueError(f"{what} has a corrupt 'data' entry ({error})") from None
    except ValueError:
        raise
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError,
            RuntimeError) as error:
        size = model_path.stat().st_size if model_path.is_file() else 0
        raise ValueError(f"{what} is not a stable-baselines3 model: "
                         f"{'it is empty' if size == 0 else 'not a readable zip archive'} "
                         f"({type(error).__name__}: {error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} has a 'data' entry that is not a mapping of attributes")
    return data


def _algorithm(model_path: Path, config: dict, data: dict) -> str:
    """The SB3 algorithm class name of a model: the run config's ``algo``, else guessed from the
    attributes it saved; ``ValueError`` naming the file where neither gives a known one."""
    algorithm = config.get("algo")
    if algorithm is None:
        return _guess_algorithm(model_path, data)
    if not isinstance(algorithm, str) or algorithm.lower() not in ALGORITHM_CLASSES:
        raise ValueError(f"sb3 model file {str(model_path)!r}: its run config names the algo "
                         f"{algorithm!r}, not one of {list(ALGORITHM_CLASSES)}")
    return ALGORITHM_CLASSES[algorithm.lower()]


def _load_normalization(path: Path, model) -> Any:
    """The VecNormalize statistics in ``path`` for ``model``, ready to normalise (not training);
    ``ValueError`` naming the file where it is unreadable, not VecNormalize statistics, or
    statistics of other observations."""
    # lazy: stable-baselines3 costs 1.2 s (-X importtime) that the baselines never need
    from stable_baselines3.common.vec_env import VecNormalize

    what = f"VecNormalize statistics {str(path)!r}"
    try:
        with open(path, "rb") as handle:
            normalization = pickle.load(handle)
    except Exception as error:  # a damaged pickle raises almost anything
        raise ValueError(f"{what} cannot be read: "
                         f"{'the file is empty' if path.stat().st_size == 0 else 'not a pickle'} "
                         f"or damaged ({type(error).__name__}: {error})") from None
    if not isinstance(normalization, VecNormalize):
        raise ValueError(f"{what} hold a {type(normalization).__name__}, not a pickled "
                         "stable-baselines3 VecNormalize")
    space = getattr(normalization, "observation_space", None)
    if _space_shapes(space) != _space_shapes(model.observation_space):
        raise ValueError(f"{what} are for observations {space}, the model reads "
                         f"{model.observation_space}")
    if getattr(normalization, "norm_obs", False):
        rms = getattr(normalization, "obs_rms", None)
        mean = getattr(rms, "mean", None)
        if isinstance(mean, np.ndarray) and (
                mean.shape != tuple(model.observation_space.shape or mean.shape)
                or not np.all(np.isfinite(mean)) or not np.all(np.isfinite(rms.var))
                or np.any(rms.var < 0)):
            raise ValueError(f"{what} hold a running mean of shape {mean.shape} or non-finite "
                             f"or negative statistics, for observations of shape "
                             f"{model.observation_space.shape}")
    normalization.training = False
    # what VecNormalize drops when pickled, so that this copy can be saved again
    normalization.class_attributes, normalization.returns = {}, np.zeros(1)
    return normalization


class SB3Policy(BaselinePolicy):
    """A stable-baselines3 model behind the baseline face (loaded from ``sb3:PATH``).

    ``PATH`` is a run directory of ``python -m train`` (its ``model.zip``), a shipped agent's
    directory, or a model ``.zip`` (``best_model.zip``, a checkpoint
    ``checkpoints/<algo>_<N>_steps.zip``, ...). The observation normalisation that belongs to
    the model (:func:`~agents.policies.run_dir.normalization_file`) is applied before the
    network; a model trained with normalisation whose statistics are missing is refused with a
    ``ValueError`` naming the file.
    The run's ``config.yaml`` (beside the model, or above ``checkpoints/``) gives the env
    interface the agent was trained with (:data:`SB3_INTERFACE_KEYS`).

    A path that does not exist, a directory without ``model.zip``, a model file that is not one
    (empty, truncated, random bytes, a zip SB3 did not write), a damaged ``config.yaml`` and
    VecNormalize statistics that are not (or are for other observations) are each refused with
    one ``ValueError`` naming the file and what is wrong with it.
    """

    name = "sb3"

    def __init__(self, model, normalization=None, config: dict | None = None,
                 model_path: str | Path | None = None) -> None:
        self.model = model
        self.normalization = normalization
        self.config = dict(config or {})
        self.model_path = None if model_path is None else Path(model_path)
        self._memory: Any = None        # a recurrent policy's LSTM state in this episode
        self._episode_start = True

    @property
    def recurrent(self) -> bool:
        """Whether the agent carries a memory through the episode (sb3-contrib's
        ``RecurrentPPO``): :meth:`predict` then keeps its LSTM state between calls, and
        :meth:`reset` clears it."""
        return type(self.model).__name__ == "RecurrentPPO"

    def reset(self) -> None:
        """Start of an episode: a recurrent agent forgets its memory."""
        self._memory, self._episode_start = None, True

    @property
    def trained_preset(self) -> str | None:
        """The arm preset the agent was trained on (its run's ``config.yaml``: the env keyword
        ``preset``, else the env id's arm), ``None`` where the run does not say."""
        env_kwargs = self.config.get("env_kwargs") or {}
        if isinstance(env_kwargs.get("preset"), str):
            return env_kwargs["preset"]
        env_id = self.config.get("env_id")
        if not isinstance(env_id, str):
            return None
        from soft_gym.envs.config import EnvConfig
        from soft_gym.envs.registration import TASK_IDS, preset_env_id
        from soft_gym.robots.presets import PRESETS

        if env_id in TASK_IDS.values():
            return EnvConfig.__dataclass_fields__["preset"].default
        return next((preset for preset in PRESETS for task in TASK_IDS
                     if preset_env_id(task, preset) == env_id), None)

    def other_arm(self, env) -> str | None:
        """The preset the agent was trained on where ``env``'s arm is another (``None`` where it
        is the same or either is unknown)."""
        arm = getattr(getattr(env, "unwrapped", env), "arm", None)
        trained = self.trained_preset
        name = getattr(arm, "name", None)
        return trained if trained is not None and name is not None and name != trained else None

    @property
    def env_interface(self) -> dict:
        """The training env's observation and action settings (``SB3_INTERFACE_KEYS``)."""
        env_kwargs = self.config.get("env_kwargs", {})
        return {key: env_kwargs[key] for key in SB3_INTERFACE_KEYS if key in env_kwargs}

    def check_observation(self, observation: Any, name: str = "observation") -> Any:
        """``observation`` (or a stack of them) checked against the observation space the model
        reads (see :func:`check_observation`)."""
        return check_observation(self.model.observation_space, observation, name, batch=True)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The action for ``observation`` (and SB3's ``state``). A recurrent agent called
        without ``state`` continues its own memory from the last call of the episode (cleared by
        :meth:`reset`), as it ran in training; given ``state``, it uses that instead."""
        observation = self.check_observation(observation)
        if self.normalization is not None:
            observation = self.normalization.normalize_obs(observation)
        if self.recurrent and state is None:
            starts = np.full(np.asarray(observation).shape[0] if np.ndim(observation) > 1 else 1,
                             self._episode_start)
            action, self._memory = self.model.predict(observation, state=self._memory,
                                                      episode_start=starts,
                                                      deterministic=deterministic)
            self._episode_start = False
            return action, self._memory
        return self.model.predict(observation, state=state, episode_start=episode_start,
                                  deterministic=deterministic)

    def save(self, path: str | Path) -> None:
        """Save as a directory: ``model.zip``, ``vecnormalize.pkl`` and ``config.yaml``
        (:mod:`agents.policies.run_dir`)."""
        directory = Path(path)
        directory.mkdir(parents=True, exist_ok=True)
        self.model.save(directory / MODEL_FILE)
        if self.normalization is not None:
            with open(directory / NORMALIZATION_FILE, "wb") as handle:
                pickle.dump(self.normalization, handle)
        write_run_config(directory, self.config)

    @classmethod
    def load(cls, path: str | Path, env=None) -> "SB3Policy":
        """Load ``path`` (see the class docstring); with ``env``, check that the agent reads its
        observations and writes its actions (:meth:`check_env`)."""
        if not isinstance(path, (str, Path)) or str(path) == "":
            raise ValueError(f"sb3 path must be a model .zip, a directory holding model.zip or a "
                             f"shipped agent {sorted(shipped_agents())}, got {path!r}")
        path = resolve_sb3_path(path)
        if not path.exists():
            raise ValueError(f"sb3 path {str(path)!r} does not exist and is no shipped agent "
                             f"{sorted(shipped_agents())}")
        model_path = path / MODEL_FILE if path.is_dir() else path
        if not model_path.is_file():
            raise ValueError(f"sb3 path {str(path)!r} is a directory without model.zip: give a "
                             "run directory of python -m train, a model .zip or a shipped agent "
                             f"{sorted(shipped_agents())}")
        config = read_run_config(run_config_file(model_path))
        data = _check_model_archive(model_path)
        normalization_path = normalization_file(model_path)
        normalized = _trained_with_normalization(model_path, config, data)
        if normalized and not normalization_path.is_file():
            raise ValueError(
                f"sb3 path {str(path)!r}: the model was trained on normalised observations but "
                f"its VecNormalize statistics {str(normalization_path)!r} are missing: copy them "
                f"beside {model_path.name} (without them it would act on raw observations)")
        algorithm = _algorithm(model_path, config, data)
        try:
            model = model_class(algorithm).load(model_path, device="cpu")
        except Exception as error:  # SB3 and torch raise many kinds on a damaged model
            raise ValueError(f"sb3 model file {str(model_path)!r} does not load as a "
                             f"stable-baselines3 {algorithm} model "
                             f"({type(error).__name__}: {error})") from None
        normalization = None
        if normalized:
            normalization = _load_normalization(normalization_path, model)
        mark_normalization(model, normalization is not None)  # kept by save()
        policy = cls(model, normalization, config, model_path=model_path)
        if env is not None:
            policy.check_env(env)
        return policy

    def check_env(self, env) -> None:
        """Raise ``ValueError`` unless ``env`` gives observations of the shape the agent reads
        and takes actions of the shape it writes, naming the model file and both spaces.

        The refusal is a :class:`PolicyRefusal`; where ``env``'s arm is not the one the agent
        was trained on it names that arm, also as its ``trained_preset`` (else ``None``)."""
        if not (hasattr(env, "observation_space") and hasattr(env, "action_space")):
            raise ValueError(f"env must be a gymnasium environment, got {describe_value(env)}")
        model_spaces = (self.model.observation_space, self.model.action_space)
        env_spaces = (env.observation_space, env.action_space)
        wrong = [what for what, ours, theirs in zip(("observations", "actions"), model_spaces,
                                                    env_spaces)
                 if _space_shapes(ours) != _space_shapes(theirs)]
        if wrong:
            source = "" if self.model_path is None else f" {str(self.model_path)!r}"
            other_arm = self.other_arm(env)
            refusal = PolicyRefusal(
                f"the sb3 model{source} does not fit the env's {' and '.join(wrong)}: the agent "
                f"reads observations {_describe_space(model_spaces[0])} and writes actions "
                f"{_describe_space(model_spaces[1])}, the env gives observations "
                f"{_describe_space(env_spaces[0])} and takes actions "
                f"{_describe_space(env_spaces[1])}" + (
                    f": make the env with the agent's interface {self.env_interface}"
                    if self.env_interface else
                    " (an agent's interface is the arm and observation layout it was trained on)")
                + (f"; it was trained on the {other_arm} arm (preset={other_arm!r})"
                   if other_arm else ""))
            refusal.trained_preset = other_arm
            raise refusal


def _guess_algorithm(model_path: Path, data: dict | None = None) -> str:
    """The SB3 algorithm of a bare model ``.zip`` from the attributes it saved (its ``data``
    entry, read from the file unless given)."""
    if data is None:
        data = _check_model_archive(model_path)
    if "n_epochs" in data:
        return "RecurrentPPO" if "Lstm" in str(data.get("policy_class", "")) else "PPO"
    if "target_entropy" in data:
        return "SAC"
    if "policy_delay" in data:
        return "TD3"  # DDPG is TD3 with a delay of 1 and no target noise: it loads the same
    if "normalize_advantage" in data:
        return "A2C"
    raise ValueError(f"sb3 model file {str(model_path)!r} holds no stable-baselines3 model this "
                     f"loader knows (one of {list(SB3_ALGORITHMS)}) and no run config names "
                     "its algo")
