"""Model files: a model's state in an ``.npz`` payload behind one header line with the format name
and the payload's SHA-256, so that a file is loaded back identically and a corrupt or foreign one is
refused by name (the learned estimators and controllers save this way).

Models kept as plain ``.npz`` archives use :func:`write_npz` (exactly the path given, no ``.npz``
appended) and :func:`read_npz` (one ``ValueError`` naming the file for anything that is not a
readable archive of plain arrays).

A state is a dict whose values are numbers, strings, arrays, tuples of them, or dicts of the same
(e.g. a torch ``state_dict`` as arrays); :func:`write_model_state` flattens it to named arrays
(``a/b`` for nesting, ``a#0`` for tuple items) and :func:`read_model_state` rebuilds it, numbers and
strings as Python scalars.
"""

from __future__ import annotations

import hashlib
import io
import zipfile
import zlib
from pathlib import Path
from typing import Any, Callable, TypeVar

import numpy as np

T = TypeVar("T")


def _flatten(state: dict[str, Any], prefix: str = "") -> dict[str, np.ndarray]:
    arrays: dict[str, np.ndarray] = {}
    for key, value in state.items():
        name = f"{prefix}{key}"
        if "/" in str(key) or "#" in str(key):
            raise ValueError(f"state keys must not hold '/' or '#', got {key!r}")
        if isinstance(value, dict):
            arrays.update(_flatten(value, f"{name}/"))
        elif isinstance(value, tuple):
            arrays.update({f"{name}#{i}": np.asarray(item) for i, item in enumerate(value)})
        else:
            arrays[name] = np.asarray(value)
    return arrays


def _unflatten(arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    state: dict[str, Any] = {}
    tuples: list[tuple[dict, str]] = []
    for name, array in arrays.items():
        *parents, leaf = name.split("/")
        node = state
        for parent in parents:
            node = node.setdefault(parent, {})
        value = array.item() if array.ndim == 0 else array
        if "#" in leaf:
            leaf, index = leaf.rsplit("#", 1)
            node.setdefault(leaf, {})[int(index)] = value
            tuples.append((node, leaf))
        else:
            node[leaf] = value
    for node, leaf in tuples:
        if isinstance(node[leaf], dict):
            node[leaf] = tuple(node[leaf][i] for i in range(len(node[leaf])))
    return state


def write_model_state(path: str | Path, format_name: str, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` under ``format_name``."""
    buffer = io.BytesIO()
    np.savez(buffer, **_flatten(state))
    payload = buffer.getvalue()
    Path(path).write_bytes(f"{format_name} {hashlib.sha256(payload).hexdigest()}\n".encode()
                           + payload)


def read_model_state(path: str | Path, format_name: str, what: str,
                     build: Callable[[dict[str, Any]], T]) -> T:
    """``build(state)`` of a file written by :func:`write_model_state` with ``format_name``; any
    other file, or a state ``build`` cannot use, raises ``ValueError`` naming ``path`` and ``what``
    it should have been."""
    path = Path(path)
    try:
        header, payload = path.read_bytes().split(b"\n", 1)
        name, digest = header.decode().rsplit(" ", 1)
        if name != format_name or hashlib.sha256(payload).hexdigest() != digest:
            raise ValueError("header or digest mismatch")
        with np.load(io.BytesIO(payload), allow_pickle=False) as arrays:
            state = _unflatten({key: arrays[key] for key in arrays.files})
        return build(state)
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, RuntimeError,
            UnicodeDecodeError, EOFError, zipfile.BadZipFile, zlib.error) as error:
        raise ValueError(f"{str(path)!r} is not a readable {what} file ({error})") from None


def write_npz(path: str | Path, arrays: dict[str, Any]) -> None:
    """Write ``arrays`` as an ``.npz`` archive to exactly ``path`` (``numpy.savez`` given a name
    would append ``.npz`` to one without it, and the file would not load back by that name)."""
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


def read_npz(path: str | Path, what: str) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` archive ``path`` (no pickled objects); a missing file, or one
    that is no such archive (empty, truncated, a single ``.npy`` array, text, damaged), raises
    one ``ValueError`` naming ``what`` and ``path`` and what is wrong."""
    label = f"{what} file {str(path)!r}"
    try:
        with open(path, "rb") as handle:
            start = handle.read(6)
            if start and not start.startswith((b"PK", b"\x93NUMPY")):
                raise ValueError(f"it is neither an .npz archive nor a .npy array (it starts "
                                 f"with {start!r})")
            handle.seek(0)
            archive = np.load(handle, allow_pickle=False)
            if not isinstance(archive, np.lib.npyio.NpzFile):
                raise ValueError("it holds a single .npy array, not an .npz archive")
            with archive:
                return {name: archive[name] for name in archive.files}
    except FileNotFoundError:
        raise ValueError(f"{label} does not exist") from None
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as error:
        empty = Path(path).is_file() and Path(path).stat().st_size == 0
        raise ValueError(f"{label} is not a readable .npz archive"
                         f"{' (the file is empty)' if empty else ''} "
                         f"({type(error).__name__}: {error})") from None
