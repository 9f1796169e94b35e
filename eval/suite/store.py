"""The records of a suite on disk: ``out/records/<key>.json`` and the per-step ``<key>.npz``, each
written atomically and read back, whether a cell is finished (what ``resume`` skips), and the
provenance every record carries (library versions, git revision)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import tempfile
from collections.abc import Callable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from eval.report import to_jsonable


def library_versions() -> dict[str, str]:
    """Versions of the package and the libraries a record depends on (``"unknown"`` where a
    package is not installed)."""
    versions = {}
    for key, dist in (("soft_arm_gym", "soft-arm-gym"), ("gymnasium", "gymnasium"),
                      ("stable_baselines3", "stable-baselines3"), ("torch", "torch"),
                      ("numpy", "numpy"), ("pybullet", "pybullet")):
        try:
            versions[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[key] = "unknown"
    versions["python"] = platform.python_version()
    return versions


def git_revision(root: Path | None = None) -> str | None:
    """The checkout's commit (``-dirty`` appended when tracked files differ from it), or
    ``None`` outside a git checkout. Reads only (no index refresh)."""
    root = Path(__file__).resolve().parents[2] if root is None else root
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=20)
        if head.returncode != 0:
            return None
        status = subprocess.run(["git", "--no-optional-locks", "-C", str(root), "status",
                                 "--porcelain", "--untracked-files=no"], capture_output=True,
                                text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    revision = head.stdout.strip()
    return revision + ("-dirty" if status.returncode == 0 and status.stdout.strip() else "")


def records_dir(out: str | os.PathLike) -> Path:
    return Path(out) / "records"


def record_path(out: str | os.PathLike, key: str) -> Path:
    """The JSON record of cell ``key`` under the output directory ``out``."""
    return records_dir(out) / f"{key}.json"


def steps_path(out: str | os.PathLike, key: str) -> Path:
    """The per-step record (``.npz``) of cell ``key``."""
    return records_dir(out) / f"{key}.npz"


def read_record(out: str | os.PathLike, key: str) -> dict[str, Any] | None:
    """The JSON record of cell ``key``, or ``None`` when it is not there."""
    path = record_path(out, key)
    if not path.is_file():
        return None
    return json.loads(path.read_text(encoding="utf-8"))


def read_steps(out: str | os.PathLike, key: str) -> dict[str, np.ndarray] | None:
    """The per-step arrays of cell ``key``, or ``None`` when there are none."""
    path = steps_path(out, key)
    if not path.is_file():
        return None
    with np.load(path) as data:
        return {name: data[name] for name in data.files}


def is_finished(out: str | os.PathLike, key: str) -> bool:
    """Whether cell ``key`` has its record (and, for a run that ran, its per-step record)."""
    try:
        record = read_record(out, key)
    except (OSError, ValueError):
        return False
    if record is None or record.get("key") != key:
        return False
    return record.get("status") == "n/a" or steps_path(out, key).is_file()


def _atomic_write(path: Path, write: Callable[[Any], None], binary: bool) -> None:
    """Write through ``write(handle)`` into a temporary file beside ``path``, then rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb" if binary else "w", **({} if binary else
                                                            {"encoding": "utf-8"})) as stream:
            write(stream)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_record(out: str | os.PathLike, result: Mapping[str, Any]) -> Path:
    """Write one finished run: its per-step arrays (if any) and then its JSON record, each
    atomically. Returns the JSON record's path."""
    key = result["key"]
    steps = result.get("steps")
    record = {k: v for k, v in result.items() if k not in ("steps", "error", "traceback")}
    record["steps_file"] = None
    if steps is not None:
        arrays = {name: np.asarray(value) for name, value in steps.items()}
        _atomic_write(steps_path(out, key), lambda f: np.savez_compressed(f, **arrays),
                      binary=True)
        record["steps_file"] = steps_path(out, key).name
    text = json.dumps(to_jsonable(record), indent=2, allow_nan=False) + "\n"
    path = record_path(out, key)
    _atomic_write(path, lambda f: f.write(text), binary=False)
    return path

