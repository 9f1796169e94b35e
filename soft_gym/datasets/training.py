"""What every paper's dataset reader shares: the papers' datasets read back as the data their
methods train on, so that a method given a dataset (``dataset=<id>``) skips its own collection.

Each reader (in its paper's folder, ``soft_gym/papers/<key>/readers.py``) loads a dataset written by ``python -m eval datasets``
(:func:`~soft_gym.datasets.store.load_dataset`), checks that it holds the right paper's data and that
it was collected with the settings the method would collect with (:func:`check_settings`: the
arm, the sensor models, the sizes and the seed, as stored in the dataset's ``match`` metadata),
and rebuilds the procedure's own data object, equal bit for bit to what the collection returns
for the same settings:

* :func:`soft_gym.papers.zhao2021.readers.read_exploration`: ``soft-arm/zhao2021/exploration-v0`` as the ``ShapeDataset`` that
  ``strain_sr`` and ``local_ik_asdm`` learn from;
* :func:`soft_gym.papers.zou2022.readers.read_zou_dataset`: ``soft-arm/zou2022/stereo-labels-v0`` as the ``ZouDataset`` (split
  included) that ``encoder_dnn`` learns from;
* :func:`soft_gym.papers.ho2018.readers.read_pretraining_walk`: ``soft-arm/ho2018/pretraining-v0`` as the observations of
  ``lwpr_rwr``'s pre-training walk, from which it takes its transitions.

Every bad input (an unknown id, a corrupt directory, another paper's dataset, a setting that
differs) is one ``ValueError`` naming the dataset id (and the setting).
"""

from __future__ import annotations

import hashlib
import json
import os
from typing import Any

import numpy as np

from soft_gym.datasets.store import dataset_info, load_dataset

DatasetRoot = str | os.PathLike | None


def check_dataset_options(dataset: Any, dataset_root: Any) -> tuple[str | None, Any]:
    """A method's ``dataset`` (an id, or ``None`` to collect) and ``dataset_root`` (a directory,
    or ``None`` for Minari's root), checked; returns them.

    Raises:
        ValueError: a ``dataset`` that is no string, or a ``dataset_root`` that is no path.
    """
    if dataset is not None and not isinstance(dataset, str):
        raise ValueError(f"dataset must be a dataset id (str) or None, got {dataset!r}")
    if dataset_root is not None and not isinstance(dataset_root, (str, os.PathLike)):
        raise ValueError(f"dataset_root must be a directory (str or path) or None, got "
                         f"{dataset_root!r}")
    return dataset, dataset_root


def _plain(value: Any) -> Any:
    """``value`` as JSON data (tuples as lists, NumPy values as Python ones, others by repr)."""
    def default(item: Any) -> Any:
        if isinstance(item, np.ndarray):
            return item.tolist()
        if isinstance(item, np.generic):
            return item.item()
        return repr(item)

    return json.loads(json.dumps(value, default=default))


def _short(value: Any, limit: int = 160) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def check_settings(dataset_id: str, stored: dict[str, Any] | None,
                   expected: dict[str, Any]) -> None:
    """Refuse a dataset whose collection settings differ from the method's.

    :param dataset_id: the dataset's id (named in the error).
    :param stored: the dataset's ``match`` metadata (``None`` for a dataset written without it).
    :param expected: what the method's own collection would use, setting by setting (the
        arm's ``preset`` first, so that another arm is named as such).
    :raises ValueError: a setting missing from ``stored`` or different there, naming it and
        both values.
    """
    if stored is None:
        raise ValueError(f"dataset {dataset_id!r} records no collection settings to check: "
                         "write it again with `python -m eval datasets --force`")
    _compare(dataset_id, _plain(stored), _plain(expected), "")


def _compare(dataset_id: str, stored: dict[str, Any], expected: dict[str, Any],
             prefix: str) -> None:
    """:func:`check_settings` on JSON data, naming a nested setting by its dotted path."""
    for name, value in expected.items():
        path = f"{prefix}{name}"
        if name not in stored:
            raise ValueError(f"dataset {dataset_id!r} does not record the setting {path!r}: "
                             "write it again with `python -m eval datasets --force`")
        if isinstance(value, dict) and isinstance(stored[name], dict):
            _compare(dataset_id, stored[name], value, f"{path}.")
        elif stored[name] != value:
            raise ValueError(f"dataset {dataset_id!r} was collected with {path} = "
                             f"{_short(stored[name])}, but this method's is {_short(value)}")


def paper_episode(dataset_id: str, root: DatasetRoot, paper: str,
             expected: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """The single episode of ``paper``'s dataset ``dataset_id`` and its metadata, checked."""
    if not isinstance(dataset_id, str):
        raise ValueError(f"dataset must be a dataset id (str), got {dataset_id!r}")
    dataset = load_dataset(dataset_id, root)
    info = dataset_info(dataset)
    if info.get("paper") != paper:
        raise ValueError(f"dataset {dataset_id!r} holds {info.get('paper') or 'no paper'}'s "
                         f"data, not {paper}'s")
    check_settings(dataset_id, info.get("match"), expected)
    if dataset.total_episodes != 1:
        raise ValueError(f"dataset {dataset_id!r} holds {dataset.total_episodes} episodes; "
                         f"{paper}'s holds one")
    return dataset[0], info


def data_digest(*arrays: np.ndarray) -> str:
    """SHA-256 of arrays' dtypes, shapes and bytes (a cache key for data read from a dataset)."""
    digest = hashlib.sha256()
    for array in arrays:
        array = np.ascontiguousarray(array)
        digest.update(f"{array.dtype.str}{array.shape}".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def procedure_rows(column: Any) -> np.ndarray:
    """A procedure episode's column without its NaN row 0, as float64."""
    return np.asarray(column, dtype=float)[1:]


__all__ = ["check_settings", "data_digest", "paper_episode", "procedure_rows"]
