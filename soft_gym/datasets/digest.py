"""SHA-256 digests of a dataset's data files: recorded when :func:`~soft_gym.datasets.store.
write_dataset` writes a dataset, recomputed and compared on every
:func:`~soft_gym.datasets.store.load_dataset`.

The digested files are every file under the dataset's ``data/`` (each episode's ``.arrow``
parts and its ``metadata.json``) except ``data/metadata.json``, Minari's dataset metadata,
which holds the digests themselves (``metadata["soft_arm_gym"]["data_sha256"]``, a map from
the path relative to ``data/`` to the file's hex digest) and is checked by what it states
(the id, the env, the episode and step counts).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path

DIGEST_KEY = "data_sha256"
"""The key of the digests in the ``soft_arm_gym`` metadata."""
METADATA_FILE = "metadata.json"
"""Minari's dataset metadata under ``data/`` (not digested: it holds the digests)."""
_CHUNK_BYTES = 1 << 20


def file_sha256(path: Path) -> str:
    """The SHA-256 hex digest of the bytes of ``path`` (read in 1 MiB chunks)."""
    digest = hashlib.sha256()
    with path.open("rb") as file:
        for chunk in iter(lambda: file.read(_CHUNK_BYTES), b""):
            digest.update(chunk)
    return digest.hexdigest()


def data_digests(data: Path) -> dict[str, str]:
    """The digest of every data file under ``data`` (a dataset's ``data/`` directory).

    Args:
        data: the dataset's ``data/`` directory.

    Returns:
        ``{path relative to data (POSIX form): SHA-256 hex digest}``, sorted by path, for every
        file but ``data/metadata.json``.
    """
    files = sorted(path for path in data.rglob("*")
                   if path.is_file() and path != data / METADATA_FILE)
    return {path.relative_to(data).as_posix(): file_sha256(path) for path in files}


def check_digests(dataset_id: str, data: Path, recorded: Mapping[str, str],
                  rewrite: str) -> None:
    """Refuse a dataset whose data files differ from those it was written with.

    Args:
        dataset_id: the dataset's id (named in the error).
        data: the dataset's ``data/`` directory.
        recorded: the digests stored when it was written (:func:`data_digests`).
        rewrite: how to write it again (the end of the error message).

    Raises:
        ValueError: one, naming the id and the first file that is missing, unrecorded or
            whose digest differs (both digests given).
    """
    if not isinstance(recorded, Mapping) or not recorded:
        raise ValueError(f"dataset {dataset_id!r} at {str(data.parent)!r} records no valid "
                         f"digest of its data files ({DIGEST_KEY} = {recorded!r}): {rewrite}")
    found = data_digests(data)
    for name in sorted(set(recorded) | set(found)):
        path = str(data / name)
        if name not in found:
            raise ValueError(f"dataset {dataset_id!r} is corrupt: {path!r} was deleted after "
                             f"it was written: {rewrite}")
        if name not in recorded:
            raise ValueError(f"dataset {dataset_id!r} is corrupt: {path!r} was added after it "
                             f"was written: {rewrite}")
        if found[name] != recorded[name]:
            raise ValueError(f"dataset {dataset_id!r} is corrupt: {path!r} was changed after it "
                             f"was written (sha256 {found[name]} != {recorded[name]}): "
                             f"{rewrite}")
