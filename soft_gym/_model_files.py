"""Model files: named arrays in an ``.npz`` payload behind one header line with the format name and
the payload's SHA-256, so that a file is loaded back identically and a corrupt or foreign one is
refused by name (the learned estimators and controllers save this way)."""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np


def write_model_file(path: str | Path, format_name: str, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` to ``path`` under ``format_name``."""
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    payload = buffer.getvalue()
    Path(path).write_bytes(f"{format_name} {hashlib.sha256(payload).hexdigest()}\n".encode()
                           + payload)


def read_model_file(path: str | Path, format_name: str, what: str) -> dict[str, np.ndarray]:
    """The arrays of a file written by :func:`write_model_file` with ``format_name``; any other
    file raises ``ValueError`` naming ``path`` and ``what`` it should have been."""
    path = Path(path)
    try:
        header, payload = path.read_bytes().split(b"\n", 1)
        name, digest = header.decode().rsplit(" ", 1)
        if name != format_name or hashlib.sha256(payload).hexdigest() != digest:
            raise ValueError("header or digest mismatch")
        with np.load(io.BytesIO(payload), allow_pickle=False) as arrays:
            return {key: arrays[key] for key in arrays.files}
    except (OSError, ValueError, KeyError, UnicodeDecodeError, EOFError) as error:
        raise ValueError(f"{str(path)!r} is not a readable {what} file ({error})") from None
