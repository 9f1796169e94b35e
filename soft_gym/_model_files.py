"""Model files: a model's state in an ``.npz`` payload behind one header line with the format name
and the payload's SHA-256, so that a file is loaded back identically and a corrupt or foreign one is
refused by name (the learned estimators and controllers save this way).

A state is a dict whose values are numbers, strings, arrays, tuples of them, or dicts of the same
(e.g. a torch ``state_dict`` as arrays); :func:`write_model_state` flattens it to named arrays
(``a/b`` for nesting, ``a#0`` for tuple items) and :func:`read_model_state` rebuilds it, numbers and
strings as Python scalars.
"""

from __future__ import annotations

import hashlib
import io
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
    except (OSError, ValueError, KeyError, IndexError, TypeError, RuntimeError,
            UnicodeDecodeError, EOFError) as error:
        raise ValueError(f"{str(path)!r} is not a readable {what} file ({error})") from None
