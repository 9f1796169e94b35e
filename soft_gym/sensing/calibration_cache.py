"""Calibrated sensing state, reused within a process and across processes from a disk cache.

Calibrating the wang2023 sensing (vision map plus F-emp from the spiral exploration) takes about
10 s. The result depends only on what is in its key (arm, fixed scenario, settle time, sensor
configurations, sensing options, the package's source and the numerical libraries' versions), so it is
computed once and then reused: from memory in the same process, and from a file in the user's
cache directory (``platformdirs.user_cache_dir("soft-arm-gym")``) in any other, e.g. a
``SubprocVecEnv`` worker. ``SOFT_GYM_CACHE=off`` turns the disk cache off (the in-process one
stays). A file whose header does not match the key, whose payload digest does not match, or whose
value its caller cannot use (a foreign pickle), is ignored with a warning and rebuilt.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import io
import json
import os
import pickle
import warnings
from importlib import metadata
from pathlib import Path
from typing import Any, Callable

import cv2
import numpy
import platformdirs

from soft_gym._distributions import REFERENCE_ENGINE_PACKAGE
from soft_gym._threads import one_compute_thread

CACHE_ENV_VARIABLE = "SOFT_GYM_CACHE"
_FORMAT = 1
_memory: dict[str, Any] = {}


def library_versions() -> dict[str, str]:
    """Versions whose change can change a calibration (package and numerical libraries)."""
    versions = {"numpy": numpy.__version__, "opencv": cv2.__version__,
                "soft_gym source": _source_digest()}
    for name in ("soft-arm-gym", REFERENCE_ENGINE_PACKAGE):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "unknown"
    return versions


@functools.lru_cache(maxsize=1)
def _source_digest() -> str:
    """SHA-256 of the soft_gym package's source files (an edited checkout gets new keys)."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_directory() -> Path:
    """Where calibration files live (``<user cache dir>/soft-arm-gym/calibration``)."""
    return Path(platformdirs.user_cache_dir("soft-arm-gym")) / "calibration"


def disk_cache_enabled() -> bool:
    value = os.environ.get(CACHE_ENV_VARIABLE, "on").strip().lower()
    if value not in ("on", "off", "1", "0", "true", "false"):
        raise ValueError(f"{CACHE_ENV_VARIABLE} must be 'on' or 'off', got {value!r}")
    return value in ("on", "1", "true")


def cache_key(parts: dict[str, Any]) -> tuple[str, str]:
    """``(digest, description)`` of a key: ``parts`` as canonical text and its SHA-256."""
    description = json.dumps({**parts, "versions": library_versions()}, sort_keys=True,
                             default=repr)
    return hashlib.sha256(description.encode()).hexdigest(), description


def sensor_description(sensor, names: tuple[str, ...]) -> str:
    """A sensor's settings ``names`` (not its noise generator or held sample), for cache keys."""
    return repr([(name, repr(getattr(sensor, name, None))) for name in names])


_FOREIGN = (KeyError, IndexError, TypeError, ValueError, AttributeError)
"""What a cache file whose payload is not the calibration its caller wants raises when used."""


def cached(parts: dict[str, Any], compute: Callable[[], Any], use_cache: bool = True,
           use: Callable[[Any], Any] | None = None) -> Any:
    """``use(value)`` for the key ``parts``: the value from memory, from disk, or ``compute()``
    (then stored); without ``use``, the value itself.

    ``use_cache=False`` computes afresh and stores nothing (a recalibration in the moment's
    conditions is not a function of the key). ``use`` turns the value into what the caller
    needs (e.g. a model from its state): a disk file whose value it cannot use (a foreign
    pickle: a missing key, a wrong type) is ignored with a warning and rebuilt, like a file
    whose header does not match. Each call works on a deep copy, so callers may change what
    they get.

    ``compute()`` runs with one thread per numerical library
    (:func:`soft_gym._threads.one_compute_thread`): a value is a function of its key, the same
    whether a test, a suite worker or a multi-threaded training process computed it first.
    """
    use = (lambda value: value) if use is None else use
    if not use_cache:
        return use(_compute_on_one_thread(compute))
    digest, description = cache_key(parts)
    if digest in _memory:
        return use(copy.deepcopy(_memory[digest]))
    value = _load(digest, description) if disk_cache_enabled() else None
    if value is not None:
        try:
            result = use(copy.deepcopy(value))
        except _FOREIGN as error:
            warnings.warn(f"ignoring calibration cache file {str(_path(digest))!r} (its content "
                          f"is not this calibration: {type(error).__name__}: {error}); "
                          "calibrating afresh", RuntimeWarning, stacklevel=2)
        else:
            _memory[digest] = value
            return result
    value = _compute_on_one_thread(compute)
    if disk_cache_enabled():
        _store(digest, description, value)
    _memory[digest] = copy.deepcopy(value)
    return use(value)


def _compute_on_one_thread(compute: Callable[[], Any]) -> Any:
    with one_compute_thread():
        return compute()


def clear_memory() -> None:
    """Forget the in-process entries (the disk files stay)."""
    _memory.clear()


def _path(digest: str) -> Path:
    return cache_directory() / f"{digest}.pkl"


def _load(digest: str, description: str) -> Any:
    path = _path(digest)
    if not path.is_file():
        return None
    try:
        with path.open("rb") as handle:
            header = json.loads(handle.readline().decode())
            payload = handle.read()
        if (header.get("format") != _FORMAT or header.get("key") != description
                or header.get("sha256") != hashlib.sha256(payload).hexdigest()):
            raise ValueError("its header does not match this calibration")
        return pickle.loads(payload)
    except Exception as error:  # noqa: BLE001 - any unreadable file is rebuilt, never trusted
        warnings.warn(f"ignoring calibration cache file {str(path)!r} ({error}); "
                      "calibrating afresh", RuntimeWarning, stacklevel=3)
        return None


def _store(digest: str, description: str, value: Any) -> None:
    path = _path(digest)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        payload = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
        header = {"format": _FORMAT, "key": description,
                  "sha256": hashlib.sha256(payload).hexdigest()}
        buffer = io.BytesIO()
        buffer.write(json.dumps(header).encode() + b"\n")
        buffer.write(payload)
        temporary = path.with_suffix(f".{os.getpid()}.tmp")
        temporary.write_bytes(buffer.getvalue())
        os.replace(temporary, path)
    except OSError as error:
        warnings.warn(f"could not write the calibration cache {str(path)!r}: {error}",
                      RuntimeWarning, stacklevel=3)
