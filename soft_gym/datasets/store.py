"""Writing and reading the Minari datasets of the arms (:mod:`eval.datasets`) under a root.

A dataset ``soft-arm/<group>/<name>-v<N>`` lives in ``<root>/soft-arm/<group>/<name>-v<N>/``
exactly as Minari lays it out (``data/`` in Minari's ``arrow`` format, read with pyarrow), plus
``card.md``, its data card. ``root`` defaults to Minari's own (``MINARI_DATASETS_PATH``, else
``~/.minari/datasets``), so ``minari.load_dataset(id)`` finds what was written there; with
another root, :func:`load_dataset` or ``MINARI_DATASETS_PATH=<root>`` does.

:func:`write_dataset` refuses to replace an existing dataset unless ``force=True`` and writes
into a temporary sibling directory first, so a failed write leaves the old dataset (or nothing)
behind, and records the SHA-256 digest of every data file in the metadata
(:mod:`soft_gym.datasets.digest`). :func:`load_dataset` turns every bad input (an unknown id, a
corrupt or truncated directory, a data file changed after it was written, a dataset recorded on
another env version) into one ``ValueError`` naming it.
The env ids it checks and recovers are registered by importing :mod:`soft_gym`, which
importing this module does first.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import re
import shutil
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from soft_gym.datasets.digest import DIGEST_KEY, METADATA_FILE, check_digests, data_digests

NAMESPACE = "soft-arm"
"""The Minari namespace of every dataset this package writes."""
DATA_FORMAT = "arrow"
"""Minari's storage backend (pyarrow; lossless for every array)."""
CARD_FILE = "card.md"
"""The data card written next to a dataset's ``data/``."""
FORMAT_VERSION = 2
"""Version of the layout this package writes (``metadata["soft_arm_gym"]["format"]``): 2 records
the digests of the data files, which every load checks; 1 (written before digests) records none
and still loads, unchecked."""
READABLE_FORMATS = (None, 1, FORMAT_VERSION)
"""Layout versions :func:`load_dataset` reads (``None``: no ``soft_arm_gym`` metadata)."""

_ID = re.compile(r"^soft-arm/[a-z0-9][a-z0-9_.-]*/[a-z0-9][a-z0-9_.-]*-v\d+$")


def default_root() -> Path:
    """Minari's datasets directory: ``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``."""
    configured = os.environ.get("MINARI_DATASETS_PATH")
    return Path(configured) if configured else Path.home() / ".minari" / "datasets"


def check_dataset_id(dataset_id: Any) -> str:
    """``dataset_id`` if it has this package's form ``soft-arm/<group>/<name>-v<N>``.

    Raises:
        ValueError: anything else, naming the value and the allowed form.
    """
    if not isinstance(dataset_id, str) or not _ID.match(dataset_id):
        raise ValueError(f"dataset_id must look like 'soft-arm/<group>/<name>-v<N>' (lower case "
                         f"letters, digits, '.', '_', '-'), got {dataset_id!r}")
    return dataset_id


def dataset_dir(dataset_id: str, root: str | os.PathLike | None = None) -> Path:
    """The directory of ``dataset_id`` under ``root`` (:func:`default_root` when ``None``)."""
    return (default_root() if root is None else Path(root)) / check_dataset_id(dataset_id)


def env_spec(env_id: str, env_kwargs: Mapping[str, Any]) -> gym.envs.registration.EnvSpec:
    """The registered spec of ``env_id`` with ``env_kwargs`` as its keyword arguments (what
    ``recover_environment()`` makes again).

    Raises:
        ValueError: an unregistered ``env_id`` or keyword arguments that are not JSON data.
    """
    if env_id not in gym.registry:
        raise ValueError(f"env_id must be a registered Gymnasium id, got {env_id!r}")
    registered = gym.spec(env_id)
    kwargs = _json_ready({**registered.kwargs, **dict(env_kwargs)})
    try:
        json.dumps(kwargs)
    except TypeError as error:
        raise ValueError(f"env_kwargs of {env_id} must be JSON data to be recoverable, got "
                         f"{env_kwargs!r} ({error})") from None
    return dataclasses.replace(registered, kwargs=kwargs)


def _json_ready(value: Any) -> Any:
    """Tuples as lists, NumPy scalars and arrays as Python numbers and lists (recursively)."""
    if isinstance(value, Mapping):
        return {str(key): _json_ready(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(item) for item in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_dataset(dataset_id: str, episodes: Iterable[Any], *, env_id: str,
                  env_kwargs: Mapping[str, Any], observation_space: gym.Space,
                  action_space: gym.Space, description: str, algorithm_name: str,
                  card: str, info: Mapping[str, Any] | None = None,
                  episode_metadata: list[dict[str, Any]] | None = None,
                  root: str | os.PathLike | None = None, force: bool = False) -> Path:
    """Write one Minari dataset (and its data card) and return its directory.

    Args:
        dataset_id: ``soft-arm/<group>/<name>-v<N>``.
        episodes: :class:`minari.data_collector.EpisodeBuffer` objects (see
            :mod:`soft_gym.datasets.episodes`).
        env_id, env_kwargs: the env ``recover_environment()`` makes (its registered id and
            keyword arguments).
        observation_space, action_space: the spaces of the stored observations and actions.
        description: Minari's one-paragraph description.
        algorithm_name: what produced the actions (a procedure or a policy's name).
        card: the data card (Markdown), written to ``card.md``.
        info: more metadata, stored under ``metadata["soft_arm_gym"]`` (JSON data).
        episode_metadata: per episode, metadata merged into Minari's (e.g. the policy's name).
        root: the datasets root (:func:`default_root` when ``None``).
        force: replace an existing dataset of that id.

    Raises:
        ValueError: a bad id, an env that cannot be recovered, or an existing dataset without
            ``force`` (naming its directory).
    """
    from minari import __version__ as minari_version
    from minari.dataset.minari_storage import MinariStorage


    target = dataset_dir(dataset_id, root)
    spec = env_spec(env_id, env_kwargs)
    if target.exists() and not force:
        raise ValueError(f"dataset {dataset_id!r} already exists at {str(target)!r}: give "
                         "force=True (--force) to replace it")
    staging = target.with_name(f".{target.name}.{uuid.uuid4().hex[:8]}.partial")
    staging.mkdir(parents=True)
    try:
        storage = MinariStorage.new(staging / "data", observation_space=observation_space,
                                    action_space=action_space, env_spec=spec,
                                    data_format=DATA_FORMAT)
        storage.update_metadata({
            "dataset_id": dataset_id, "minari_version": minari_version,
            "algorithm_name": algorithm_name, "description": description,
            "author": {"soft-arm-gym"}, "code_permalink": "https://github.com/soft-arm-gym",
            "requirements": _requirements()})
        episodes = list(episodes)
        storage.update_episodes(episodes)
        if episode_metadata is not None:
            if len(episode_metadata) != len(episodes):
                raise ValueError(f"episode_metadata must hold one dict per episode "
                                 f"({len(episodes)}), got {len(episode_metadata)}")
            storage.update_episode_metadata([_json_ready(m) for m in episode_metadata],
                                            range(len(episodes)))
        _write_extra_metadata(staging / "data", {
            "format": FORMAT_VERSION, "env_id": env_id, **_json_ready(dict(info or {})),
            DIGEST_KEY: data_digests(staging / "data")})
        (staging / CARD_FILE).write_text(card)
        if target.exists():
            shutil.rmtree(target)
        staging.rename(target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return target


def _requirements() -> list[str]:
    """Pip requirements that recover the env (this package and Minari, at their versions)."""
    from importlib.metadata import PackageNotFoundError, version

    pins = []
    for name in ("soft-arm-gym", "minari", "gymnasium"):
        try:
            pins.append(f"{name}=={version(name)}")
        except PackageNotFoundError:
            continue
    return pins


def _write_extra_metadata(data_path: Path, extra: dict[str, Any]) -> None:
    """Add ``extra`` to Minari's ``metadata.json`` under ``soft_arm_gym`` (Minari keeps
    unknown keys and returns them in ``dataset.storage.metadata``)."""
    path = data_path / METADATA_FILE
    metadata = json.loads(path.read_text())
    metadata["soft_arm_gym"] = json.dumps(extra)
    path.write_text(json.dumps(metadata))


def dataset_info(dataset) -> dict[str, Any]:
    """The ``soft_arm_gym`` metadata that :func:`write_dataset` stored in ``dataset``."""
    raw = dataset.storage.metadata.get("soft_arm_gym")
    return {} if raw is None else json.loads(raw)


def list_datasets(root: str | os.PathLike | None = None) -> list[str]:
    """Ids of this package's datasets under ``root`` (directories holding ``data/``)."""
    base = (default_root() if root is None else Path(root)) / NAMESPACE
    if not base.is_dir():
        return []
    return sorted(f"{NAMESPACE}/{group.name}/{name.name}" for group in base.iterdir()
                  if group.is_dir() and not group.name.startswith(".")
                  for name in group.iterdir()
                  if (name / "data").is_dir() and not name.name.startswith("."))


def load_dataset(dataset_id: str, root: str | os.PathLike | None = None):
    """Load ``dataset_id`` from ``root`` as a :class:`minari.MinariDataset`, checked.

    Raises:
        ValueError: one, naming the id or the directory: an id not of this package's form or
            not under ``root`` (listing those there), a directory whose metadata or episodes are
            missing, unreadable or short of what its metadata counts (corrupt or truncated),
            a data file whose SHA-256 digest is not the one recorded when it was written (or a
            dataset of the digest layout that records none), or a dataset recorded on an env id
            this installation does not register (another env version).
    """
    import minari


    directory = dataset_dir(dataset_id, root)
    if not (directory / "data").is_dir():
        there = list_datasets(root)
        raise ValueError(f"dataset_id {dataset_id!r} is not under {str(directory.parents[2])!r}"
                         f" (datasets there: {there or 'none'})")
    try:
        dataset = minari.MinariDataset(directory / "data")
    except Exception as error:  # noqa: BLE001 - every failure to read is one ValueError
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} is corrupt: its "
                         f"metadata does not load ({type(error).__name__}: {error})") from None
    check_dataset(dataset, dataset_id, directory)
    return dataset


def check_dataset(dataset, dataset_id: str, directory: Path) -> None:
    """Refuse (``ValueError``) a dataset whose episodes are missing or short, whose data files
    changed after it was written, or whose env id is not registered here (see
    :func:`load_dataset`)."""
    metadata = dataset.storage.metadata
    if metadata.get("dataset_id") != dataset_id:
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} is corrupt: its "
                         f"metadata names {metadata.get('dataset_id')!r}")
    spec = dataset.env_spec
    if spec is None:
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} holds no env spec: "
                         "its env cannot be recovered")
    if spec.id not in gym.registry:
        registered = sorted(name for name in gym.registry
                            if name.split("-v")[0] == spec.id.split("-v")[0])
        raise ValueError(f"dataset {dataset_id!r} was recorded on env {spec.id!r}, which this "
                         f"installation does not register (registered versions: "
                         f"{registered or 'none'}): another env version")
    info = dataset_info(dataset)
    if info.get("format") not in READABLE_FORMATS:
        raise ValueError(f"dataset {dataset_id!r} has layout version {info.get('format')!r}; "
                         f"this installation reads versions "
                         f"{[v for v in READABLE_FORMATS if v is not None]}")
    total = int(metadata.get("total_episodes", -1))
    data = directory / "data"
    missing = [str(i) for i in range(total) if not (data / str(i)).is_dir()
               or not any(p.suffix == f".{DATA_FORMAT}" for p in (data / str(i)).iterdir())]
    if total < 1 or missing:
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} is truncated: episodes "
                         f"{missing[:5] or '(none counted)'} of {max(total, 0)} are missing")
    if info.get("format") == FORMAT_VERSION:
        check_digests(dataset_id, data, info.get(DIGEST_KEY), rewrite_hint(info))
    try:
        steps = sum(len(episode) for episode in dataset.iterate_episodes())
    except Exception as error:  # noqa: BLE001 - a damaged episode file is one ValueError
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} is corrupt: its episodes"
                         f" do not read ({type(error).__name__}: {error})") from None
    if steps != int(metadata.get("total_steps", -1)):
        raise ValueError(f"dataset {dataset_id!r} at {str(directory)!r} is truncated: "
                         f"{steps} steps of the {metadata.get('total_steps')} its metadata "
                         "counts")


def rewrite_hint(info: Mapping[str, Any]) -> str:
    """How to write a dataset with the ``soft_arm_gym`` metadata ``info`` again (the end of an
    error message): the command that wrote it, from what its metadata names."""
    if info.get("paper"):
        return f"write it again with `python -m eval datasets --papers {info['paper']} --force`"
    if info.get("suite"):
        return "write it again with `python -m eval suite SPEC --record minari`"
    if info.get("policy"):
        return f"write it again with `python -m train --demos {info['policy']}`"
    return "write it again (write_dataset(..., force=True))"


def recover_env(dataset, **kwargs) -> gym.Env:
    """``dataset.recover_environment(**kwargs)`` with this package's ids registered."""

    return dataset.recover_environment(**kwargs)


def copy_spec_kwargs(dataset) -> dict[str, Any]:
    """The keyword arguments of the env that produced ``dataset`` (a copy)."""
    return copy.deepcopy(dict(dataset.env_spec.kwargs))
