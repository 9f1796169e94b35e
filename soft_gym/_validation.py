"""Small argument checks shared across the package.

Every check raises :class:`ValueError` naming the parameter, the value received and what is
allowed, so a bad configuration fails at construction instead of producing NaNs later.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np


def require_number(name: str, value: Any) -> float:
    """Return ``value`` as float if it is a real number (not a bool, string or complex)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer,
                                                                     np.floating)):
        raise ValueError(f"{name} must be a real number, got {value!r} "
                         f"({type(value).__name__})")
    return float(value)


def require_integer(name: str, value: Any, minimum: int, maximum: int | None = None) -> int:
    """Return ``value`` as int if it is an integer (not a bool, not a float such as 2.5 or 2.0)
    within ``[minimum, maximum]`` (``maximum=None``: no upper bound)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer >= {minimum}"
                         f"{'' if maximum is None else f' and <= {maximum}'}, got {value!r} "
                         f"({type(value).__name__})")
    if value < minimum or (maximum is not None and value > maximum):
        raise ValueError(f"{name} must be an integer >= {minimum}"
                         f"{'' if maximum is None else f' and <= {maximum}'}, got {value!r}")
    return int(value)


SEED_MAX = 2**32 - 1
"""The largest seed: what every generator a seed reaches accepts (``np.random.seed`` takes
``[0, 2**32 - 1]``, ``torch.manual_seed`` less than ``2**64``)."""


MAX_LEARNING_RATE = 1.0
"""The largest learning rate of a gradient step (Adam's): beyond it the networks diverge (a
rate of 1e12 gave 1e11 m poses)."""


def require_learning_rate(name: str, value: Any) -> float:
    """Return ``value`` as float if it is a learning rate in ``(0, MAX_LEARNING_RATE]``."""
    return require_positive(name, value, maximum=MAX_LEARNING_RATE)


def require_seed(name: str, value: Any) -> int:
    """Return ``value`` as int if it is an integer seed in ``[0, SEED_MAX]``."""
    return require_integer(name, value, 0, SEED_MAX)


def require_bool(name: str, value: Any) -> bool:
    """Return ``value`` if it is a bool (``True``/``False``, numpy's included): no truthy
    strings or numbers."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r} ({type(value).__name__})")
    return bool(value)


def require_positive(name: str, value: float, maximum: float | None = None,
                     unit: str | None = None) -> float:
    """Return ``value`` as float if it is finite and > 0 (and <= ``maximum`` when given), else
    raise ``ValueError``; ``unit`` (e.g. ``"kg"``) is named in the message."""
    value = require_number(name, value)
    what = "a finite number > 0" + ("" if maximum is None else f" and <= {maximum:g}")
    if unit:
        what += f" ({unit})"
    if not np.isfinite(value) or value <= 0 or (maximum is not None and value > maximum):
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return float(value)


def require_non_negative(name: str, value: float, maximum: float | None = None,
                         unit: str | None = None) -> float:
    """Return ``value`` as float if it is finite and >= 0 (and <= ``maximum`` when given), else
    raise ``ValueError``; ``unit`` (e.g. ``"seconds"``) is named in the message."""
    value = require_number(name, value)
    what = "a finite number >= 0" + ("" if maximum is None else f" and <= {maximum:g}")
    if unit:
        what += f" ({unit})"
    if not np.isfinite(value) or value < 0 or (maximum is not None and value > maximum):
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return float(value)


def require_in_range(name: str, value: float, low: float, high: float) -> float:
    """Return ``value`` as float if it is finite and within [low, high]."""
    value = require_number(name, value)
    if not np.isfinite(value) or not (low <= value <= high):
        raise ValueError(f"{name} must be within [{low}, {high}], got {value!r}")
    return float(value)


def require_choice(name: str, value: Any, allowed: Iterable[Any]) -> Any:
    """Return ``value`` if it is one of ``allowed`` (a value of another type, an array or an
    unhashable one is simply not allowed)."""
    allowed = tuple(allowed)
    if not any(isinstance(value, type(choice)) and value == choice for choice in allowed):
        raise ValueError(f"{name} must be one of {sorted(map(str, allowed))}, got {value!r}")
    return value


def as_finite_array(name: str, value: Any, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """Convert to a float64 array, checking shape (if given) and that every entry is finite."""
    if type(value) is np.ndarray and value.dtype == np.float64:  # the hot path: as it is
        array = value
    else:
        try:
            complex_values = np.iscomplexobj(value)
            if not complex_values:
                array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as error:  # strings, ragged nesting, None, objects
            raise ValueError(f"{name} must be numeric (real numbers), got {value!r}") from error
        if complex_values:
            raise ValueError(f"{name} must be real, got complex values {value!r}")
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite (no NaN or inf), got {array.tolist()}")
    return array


def as_points(name: str, value: Any, min_points: int = 1) -> np.ndarray:
    """Convert to a float64 array of 3-D points (m), shape (n >= ``min_points``, 3), finite."""
    points = as_finite_array(name, value)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < min_points:
        raise ValueError(f"{name} must be points (m), shape (n >= {min_points}, 3), got shape "
                         f"{points.shape}")
    return points


def require_names(name: str, value: Any, allowed: Iterable[str]) -> tuple[str, ...]:
    """Return ``value`` (one name or a list/tuple of names) as a tuple of distinct names, each one
    of ``allowed``."""
    allowed = tuple(allowed)
    names = (value,) if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise ValueError(f"{name} must be a name or a list/tuple of names from "
                         f"{sorted(allowed)}, got {value!r} ({type(value).__name__})")
    unknown = [n for n in names if n not in allowed]
    if unknown or len(set(names)) != len(names):
        raise ValueError(f"{name} must be distinct names from {sorted(allowed)}, got {value!r}")
    return tuple(names)


def fields_from_options(cls: type, options: Any, what: str) -> dict[str, Any]:
    """``options`` (a dict of some of the dataclass ``cls``'s fields) checked: a ``ValueError``
    naming ``what`` and the unknown names where a key is not a field."""
    if not isinstance(options, dict):
        raise ValueError(f"{what} options must be a dict, got {options!r}")
    known = set(cls.__dataclass_fields__)
    unknown = sorted(set(options) - known)
    if unknown:
        raise ValueError(f"{what} options must be among {sorted(known)}, got {unknown}")
    return dict(options)
