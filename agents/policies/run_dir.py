"""The run directory of a trained agent: the names of its files, their writers and their readers.

``python -m train`` writes a run directory (:mod:`train.trainer`), ``train.ship`` copies the
files that loading and provenance need into a shipped agent's folder (``agents/trained/<name>/``)
and ``sb3:PATH`` (:mod:`agents.policies.sb3`) reads either back:

* :data:`MODEL_FILE` (final), :data:`BEST_MODEL_FILE` (best evaluated by return),
  :data:`BEST_TRACKING_MODEL_FILE` (best on the tracking curve) and the checkpoints
  ``<CHECKPOINTS_DIR>/<algo>_<N>_steps.zip``: stable-baselines3 model zips;
* the VecNormalize statistics of each model beside it (:func:`normalization_file`);
* :data:`CONFIG_FILE`: the resolved run (algorithm, env id and keyword arguments,
  hyperparameters, seed, envs; :func:`write_run_config`, :func:`read_run_config`);
* :data:`VERSIONS_FILE`: Python and package versions and the git revision
  (:func:`write_versions`);
* :data:`TRAINING_FILE`: one segment per training, each with its ``timesteps``
  (:func:`write_training_segments`, :func:`append_training_segment`,
  :func:`read_training_segments`);
* :data:`REPLAY_BUFFER_FILE`: an off-policy run's replay buffer, where it was asked for;
* a shipped agent's :data:`EVALUATION_FILE` (its nominal tracking) and :data:`SOURCE_FILE`
  (the run and model it was shipped from).

Every YAML file is written by ``yaml.safe_dump(..., sort_keys=False)``: keys in the order given.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from agents.policies.base import describe_value

CONFIG_FILE = "config.yaml"
VERSIONS_FILE = "versions.yaml"
TRAINING_FILE = "training.yaml"
MODEL_FILE = "model.zip"
BEST_MODEL_FILE = "best_model.zip"
BEST_TRACKING_MODEL_FILE = "best_tracking_model.zip"
NORMALIZATION_FILE = "vecnormalize.pkl"
BEST_NORMALIZATION_FILE = "best_vecnormalize.pkl"
REPLAY_BUFFER_FILE = "replay_buffer.pkl"
CHECKPOINTS_DIR = "checkpoints"
EVALUATION_FILE = "evaluation.yaml"
SOURCE_FILE = "source.txt"

_CHECKPOINT = re.compile(r"^(?P<prefix>.+)_(?P<steps>\d+)_steps\.zip$")
"""A checkpoint of stable-baselines3's ``CheckpointCallback``: ``<prefix>_<N>_steps.zip``."""


# ------------------------------------------------------------------------------------ layout
def normalization_file(model_path: str | Path) -> Path:
    """The VecNormalize statistics that belong to a model file (whether or not they exist).

    ``best_model.zip`` -> ``best_vecnormalize.pkl`` (and ``best_tracking_model.zip``, the best on
    the tracking curve, -> ``best_tracking_vecnormalize.pkl``); a checkpoint
    ``<prefix>_<N>_steps.zip``
    (``python -m train``'s ``checkpoints/``) -> ``<prefix>_vecnormalize_<N>_steps.pkl``, as
    ``CheckpointCallback`` saves them; any other model (``model.zip``) -> ``vecnormalize.pkl``;
    all in the model's directory.
    """
    model_path = Path(model_path)
    checkpoint = _CHECKPOINT.match(model_path.name)
    if checkpoint is not None:
        name = f"{checkpoint['prefix']}_vecnormalize_{checkpoint['steps']}_steps.pkl"
    elif model_path.name.startswith("best_") and model_path.name.endswith("_model.zip"):
        name = model_path.name[:-len(MODEL_FILE)] + NORMALIZATION_FILE
    elif model_path.name.startswith("best_"):
        name = BEST_NORMALIZATION_FILE
    else:
        name = NORMALIZATION_FILE
    return model_path.parent / name


def run_directory(path: Path) -> Path:
    """The run (or shipped agent's) directory of an agent's directory or model ``.zip`` (a
    checkpoint's: the directory above :data:`CHECKPOINTS_DIR`)."""
    directory = path if path.is_dir() else path.parent
    return directory.parent if directory.name == CHECKPOINTS_DIR else directory


def run_config_file(model_path: Path) -> Path | None:
    """The :data:`CONFIG_FILE` of a model: beside it, or in the run directory above a
    :data:`CHECKPOINTS_DIR`; ``None`` when there is none."""
    candidates = [model_path.parent / CONFIG_FILE]
    if model_path.parent.name == CHECKPOINTS_DIR:
        candidates.append(model_path.parent.parent / CONFIG_FILE)
    return next((path for path in candidates if path.is_file()), None)


def has_normalization_files(model_path: Path) -> bool:
    """Whether VecNormalize statistics of any model lie beside ``model_path`` or in its run
    directory (above a :data:`CHECKPOINTS_DIR`)."""
    directories = [model_path.parent]
    if model_path.parent.name == CHECKPOINTS_DIR:
        directories.append(model_path.parent.parent)
    return any(any(directory.glob("*vecnormalize*.pkl")) for directory in directories)


# ----------------------------------------------------------------------------------- writers
def _write_yaml(path: Path, data: Any) -> None:
    """``data`` as YAML in ``path``, keys in the order given."""
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def write_run_config(directory: Path, config: dict[str, Any]) -> None:
    """Write a run's :data:`CONFIG_FILE` into ``directory`` (replacing it)."""
    _write_yaml(directory / CONFIG_FILE, config)


def write_versions(directory: Path, versions: dict[str, str]) -> None:
    """Write a run's :data:`VERSIONS_FILE` into ``directory`` (replacing it)."""
    _write_yaml(directory / VERSIONS_FILE, versions)


def write_training_segments(directory: Path, segments: list[dict[str, Any]]) -> None:
    """Start a run's :data:`TRAINING_FILE` in ``directory`` with ``segments`` (replacing it)."""
    _write_yaml(directory / TRAINING_FILE, segments)


def append_training_segment(directory: Path, segment: dict[str, Any]) -> None:
    """Add one training's segment at the end of the :data:`TRAINING_FILE` in ``directory``
    (made where there is none)."""
    with open(directory / TRAINING_FILE, "a") as handle:
        yaml.safe_dump([segment], handle, sort_keys=False)


# ----------------------------------------------------------------------------------- readers
def read_run_config(config_path: Path | None) -> dict:
    """A run's :data:`CONFIG_FILE` as a dict.

    Args:
        config_path: the file, or ``None`` (a model without its run's config).

    Returns:
        The config (``{}`` for ``None`` or an empty file).

    Raises:
        ValueError: naming the file, where it is not YAML, not a mapping, or its ``env_kwargs``
            is not a mapping.
    """
    if config_path is None:
        return {}
    try:
        config = yaml.safe_load(config_path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        detail = " ".join(str(error).split())
        raise ValueError(f"sb3 run config {str(config_path)!r} is not readable YAML "
                         f"({type(error).__name__}: {detail})") from None
    config = {} if config is None else config
    if not isinstance(config, dict):
        raise ValueError(f"sb3 run config {str(config_path)!r} must hold a mapping (algo, "
                         f"env_kwargs, ...), got {describe_value(config)}")
    if not isinstance(config.get("env_kwargs", {}), dict):
        raise ValueError(f"sb3 run config {str(config_path)!r}: env_kwargs must be a mapping, "
                         f"got {describe_value(config['env_kwargs'])}")
    return config


def read_training_segments(directory: Path) -> list[dict[str, Any]] | None:
    """The segments of the :data:`TRAINING_FILE` in ``directory``.

    Args:
        directory: a run (or shipped agent's) directory.

    Returns:
        One segment per training, each with its ``timesteps``; ``None`` without the file.

    Raises:
        ValueError: naming the file, where it is unreadable or not a list of segments.
    """
    record = directory / TRAINING_FILE
    if not record.is_file():
        return None
    try:
        segments = yaml.safe_load(record.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        raise ValueError(f"training record {str(record)!r} is not readable YAML "
                         f"({type(error).__name__})") from None
    if not isinstance(segments, list) or not segments or not all(
            isinstance(segment, dict) and "timesteps" in segment for segment in segments):
        raise ValueError(f"training record {str(record)!r} must be a list of training "
                         f"segments, each with its timesteps")
    return segments
