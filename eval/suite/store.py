"""The records of a suite on disk: ``out/records/<key>.json`` and the per-step ``<key>.npz``, each
written atomically and verified when read back (:func:`read_record`: its key, its config's hash,
its metrics, the digest of its arrays), whether a cell is finished (what ``resume`` skips; a bad
record is not), and the provenance every record carries (library versions, git revision)."""

from __future__ import annotations

import hashlib
import json
import math
import os
import pickle
import platform
import subprocess
import tempfile
import zipfile
import zlib
from collections.abc import Callable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from eval.metrics import MM_PER_M, summarize
from eval.report import to_jsonable
from eval.suite.grid import canonical_json, cell_key
from soft_gym._distributions import REFERENCE_ENGINE_PACKAGE


def cell_metrics(record: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """The summary metrics of one run's per-step record (mm; :mod:`eval.suite`, "Running")."""
    summary = summarize(record)
    track, deviation = summary["tracking"], summary["deviation"]
    feedback = np.linalg.norm(np.asarray(record["feedback_m"]) - np.asarray(record["tip_m"]),
                              axis=1) * MM_PER_M
    finite = feedback[np.isfinite(feedback)]
    return {
        "last_cycle_error_mm": track["per_cycle"]["mean_mm"][-1],
        "mean_error_mm": track["mean_mm"],
        "max_error_mm": track["max_mm"],
        "rmse_error_mm": track["rmse_mm"],
        "final_error_mm": track["final_mm"],
        "last_cycle_max_error_mm": track["per_cycle"]["max_mm"][-1],
        "path_deviation_mm": deviation["mean_mm"],
        "last_cycle_path_deviation_mm": deviation["per_cycle"]["mean_mm"][-1],
        "feedback_error_mm": float(np.mean(finite)) if finite.size else math.nan,
        "per_cycle_error_mm": list(track["per_cycle"]["mean_mm"]),
        "per_cycle_path_deviation_mm": list(deviation["per_cycle"]["mean_mm"]),
        "n_steps": summary["n_steps"],
        "n_cycles": summary["n_cycles"],
    }


def library_versions() -> dict[str, str]:
    """Versions of the package and the libraries a record depends on (``"unknown"`` where a
    package is not installed)."""
    versions = {}
    for key, dist in (("soft_arm_gym", "soft-arm-gym"), ("gymnasium", "gymnasium"),
                      ("stable_baselines3", "stable-baselines3"), ("torch", "torch"),
                      ("numpy", "numpy"),
                      (REFERENCE_ENGINE_PACKAGE, REFERENCE_ENGINE_PACKAGE)):
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


class RecordError(ValueError):
    """A record on disk that cannot be trusted: its ``path`` and the ``problem``."""

    def __init__(self, path: Path, problem: str) -> None:
        self.path, self.problem = Path(path), " ".join(str(problem).split())
        super().__init__(f"bad record {self.path}: {self.problem}")

    def __reduce__(self):  # a pool worker's error reaches the parent whole
        return type(self), (self.path, self.problem)


REQUIRED_METRICS = ("last_cycle_error_mm", "mean_error_mm", "max_error_mm", "path_deviation_mm")
"""Metrics a finished record must hold as finite numbers >= 0 (mm): the score and what the
leaderboard shows beside it."""

_STATUSES = ("done", "n/a")


def check_records_dir(out: str | os.PathLike) -> None:
    """Refuse an output directory whose ``out`` or ``out/records`` is not a directory.

    Raises:
        ValueError: naming the path that is in the way.
    """
    for path in (Path(out), records_dir(out)):
        if path.exists() and not path.is_dir():
            raise ValueError(f"{path} is a file, not a directory: the suite keeps its records "
                             f"in {records_dir(out)}/ (move the file away or give another "
                             "output directory)")


def steps_digest(arrays: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of per-step arrays: every array's name, dtype, shape and bytes, in name
    order. Independent of how the ``.npz`` was compressed, so equal runs have equal digests."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(canonical_json([name, array.dtype.str, list(array.shape)]).encode("ascii"))
        digest.update(array.tobytes())
    return digest.hexdigest()


def _load_arrays(path: Path) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` (no pickles); :class:`RecordError` when it cannot be read."""
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise RecordError(path, "not an .npz archive of named arrays")
        with data:
            return {name: data[name] for name in data.files}
    except RecordError:
        raise
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as error:
        raise RecordError(path, f"the per-step arrays cannot be read (truncated or damaged: "
                                f"{type(error).__name__}: {error})") from None


def read_json_object(path: Path) -> dict[str, Any]:
    """The JSON object a record file at ``path`` holds.

    Raises:
        RecordError: naming ``path``: not a regular file, not readable UTF-8 JSON (truncated or
            damaged), or JSON that is not an object.
    """
    if not path.is_file():
        raise RecordError(path, "not a regular file")
    try:
        record = json.loads(path.read_bytes().decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise RecordError(path, f"not readable JSON (truncated or damaged: "
                                f"{type(error).__name__}: {error})") from None
    if not isinstance(record, dict):
        raise RecordError(path, f"must hold a JSON object, got {type(record).__name__}")
    return record


def _check_metrics(path: Path, metrics: Any) -> None:
    if not isinstance(metrics, Mapping):
        raise RecordError(path, f"status 'done' without metrics (got {_short(metrics)})")
    for name in REQUIRED_METRICS:
        value = metrics.get(name)
        if (not isinstance(value, (int, float)) or isinstance(value, bool)
                or not math.isfinite(value) or value < 0):
            raise RecordError(path, f"metric {name!r} must be a finite number >= 0 (mm), got "
                                    f"{_short(value)}")


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def read_record(out: str | os.PathLike, key: str) -> dict[str, Any] | None:
    """The verified JSON record of cell ``key``, or ``None`` when it is not there.

    Verified: readable UTF-8 JSON holding an object; its ``key`` is the file's and the hash of
    its ``config`` (:func:`eval.suite.grid.cell_key`), so a record copied over another's is
    caught; its ``status`` is ``done`` (with :data:`REQUIRED_METRICS`) or ``n/a`` (with a
    reason and no metrics); its per-step file, when it names one, is ``<key>.npz``, readable,
    and its arrays match the record's ``steps_sha256`` (:func:`steps_digest`).

    Raises:
        RecordError: (a ``ValueError``) naming the record's path and what is wrong.
    """
    path = record_path(out, key)
    if not os.path.lexists(path):
        return None
    record = read_json_object(path)
    if record.get("key") != key:
        raise RecordError(path, f"holds the record of cell {_short(record.get('key'))}, not "
                                f"{key!r} (copied over another record?)")
    config = record.get("config")
    try:
        config_key = cell_key(config) if isinstance(config, dict) else None
    except (TypeError, ValueError):
        config_key = None
    if config_key != key:
        raise RecordError(path, f"its config does not hash to its key {key!r} (edited or "
                                "copied from another run)")
    versions = record.get("versions")
    if not (isinstance(versions, dict) and all(isinstance(v, str) for v in versions.values())):
        raise RecordError(path, f"versions must map library names to version text, got "
                                f"{_short(versions)}")
    wall_s = record.get("wall_s")
    if wall_s is not None and (not isinstance(wall_s, (int, float)) or isinstance(wall_s, bool)
                               or not math.isfinite(wall_s) or wall_s < 0):
        raise RecordError(path, f"wall_s must be a finite number >= 0 (s) or null, got "
                                f"{_short(wall_s)}")
    if not isinstance(record.get("git_revision"), (str, type(None))):
        raise RecordError(path, f"git_revision must be text or null, got "
                                f"{_short(record.get('git_revision'))}")
    status = record.get("status")
    if status not in _STATUSES:
        raise RecordError(path, f"status must be one of {list(_STATUSES)}, got {_short(status)}")
    if status == "n/a":
        if not isinstance(record.get("reason"), str) or record.get("metrics") is not None:
            raise RecordError(path, "status 'n/a' needs a reason (text) and null metrics")
    else:
        _check_metrics(path, record.get("metrics"))
    steps_file = record.get("steps_file")
    if steps_file is not None:
        if status != "done" or steps_file != steps_path(out, key).name:
            raise RecordError(path, f"steps_file must be {steps_path(out, key).name!r} (or null "
                                    f"when no steps were recorded), got {_short(steps_file)}")
        digest = record.get("steps_sha256")
        if not isinstance(digest, str):
            raise RecordError(path, "no steps_sha256 digest of its per-step arrays")
        steps = steps_path(out, key)
        if not steps.is_file():
            raise RecordError(steps, "missing: its JSON record names it")
        arrays = _load_arrays(steps)
        if steps_digest(arrays) != digest:
            raise RecordError(steps, "its arrays do not match the digest in its JSON record "
                                     "(changed or copied from another run)")
        _check_metrics_of(path, record["metrics"], arrays)
    return record


def _check_metrics_of(path: Path, metrics: Mapping[str, Any],
                      arrays: Mapping[str, np.ndarray]) -> None:
    """The record's metrics against those computed again from its arrays (:func:`cell_metrics`,
    to 1e-9 relative: another numpy may round the last digits differently)."""
    try:
        expected = to_jsonable(cell_metrics(arrays))
    except (KeyError, ValueError, IndexError, TypeError) as error:
        raise RecordError(path, f"its per-step arrays give no metrics ({type(error).__name__}: "
                                f"{error})") from None
    for name, value in expected.items():
        if not _close(metrics.get(name), value):
            raise RecordError(path, f"metric {name!r} is {_short(metrics.get(name))}, but its "
                                    f"per-step arrays give {_short(value)}")


def _close(given: Any, expected: Any) -> bool:
    if isinstance(expected, list):
        return (isinstance(given, list) and len(given) == len(expected)
                and all(_close(g, e) for g, e in zip(given, expected)))
    if expected is None or given is None:
        return given is None and expected is None
    if isinstance(given, bool) or not isinstance(given, (int, float)):
        return False
    return math.isclose(given, expected, rel_tol=1e-9, abs_tol=1e-12)


def record_problem(out: str | os.PathLike, key: str) -> RecordError | None:
    """Why the record of cell ``key`` cannot be trusted, or ``None`` (absent or sound)."""
    try:
        read_record(out, key)
    except RecordError as error:
        return error
    return None


def read_steps(out: str | os.PathLike, key: str) -> dict[str, np.ndarray] | None:
    """The per-step arrays of cell ``key`` (checked against its record's digest), or ``None``
    when its record names none.

    Raises:
        RecordError: the record or its arrays are bad (see :func:`read_record`).
    """
    record = read_record(out, key)
    if record is None or record.get("steps_file") is None:
        return None
    return _load_arrays(steps_path(out, key))


def is_finished(out: str | os.PathLike, key: str) -> bool:
    """Whether cell ``key`` has a sound record (see :func:`read_record`) and, for a run that
    ran, its per-step record: what ``resume`` skips. A bad record is not finished."""
    try:
        record = read_record(out, key)
    except RecordError:
        return False
    return record is not None and (record["status"] == "n/a"
                                   or record.get("steps_file") is not None)


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


EPISODES_DIR = "episodes"
"""Where ``run_suite(..., record=True)`` keeps each run's recorded episode (``<key>.pkl``, the
arrays of :meth:`soft_gym.datasets.episodes.EpisodeRecorder.episode_arrays` with the env's id,
keyword arguments and observation layout), for the datasets of ``--record minari``."""


def episode_path(out: str | os.PathLike, key: str) -> Path:
    """The recorded episode of run ``key`` (see :data:`EPISODES_DIR`)."""
    return Path(out) / EPISODES_DIR / f"{key}.pkl"


def write_episode(out: str | os.PathLike, key: str, episode: Mapping[str, Any]) -> Path:
    """Write run ``key``'s recorded episode atomically (pickle); returns its path."""
    path = episode_path(out, key)
    path.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write(path, lambda f: pickle.dump(dict(episode), f, protocol=4), binary=True)
    return path


def write_record(out: str | os.PathLike, result: Mapping[str, Any]) -> Path:
    """Write one finished run: its per-step arrays (if any), its recorded episode (if any,
    :func:`write_episode`; not part of the record) and then its JSON record, each
    atomically. Returns the JSON record's path."""
    key = result["key"]
    steps = result.get("steps")
    if result.get("episode") is not None:
        write_episode(out, key, result["episode"])
    record = {k: v for k, v in result.items()
              if k not in ("steps", "error", "traceback", "episode")}
    record["steps_file"], record["steps_sha256"] = None, None
    if steps is not None:
        arrays = {name: np.asarray(value) for name, value in steps.items()}
        _atomic_write(steps_path(out, key), lambda f: np.savez_compressed(f, **arrays),
                      binary=True)
        record["steps_file"] = steps_path(out, key).name
        record["steps_sha256"] = steps_digest(arrays)
    else:
        steps_path(out, key).unlink(missing_ok=True)  # a stale one of an earlier, bad record
    text = json.dumps(to_jsonable(record), indent=2, allow_nan=False) + "\n"
    path = record_path(out, key)
    _atomic_write(path, lambda f: f.write(text), binary=False)
    return path

