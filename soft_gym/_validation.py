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


def require_integer(name: str, value: Any, minimum: int) -> int:
    """Return ``value`` as int if it is an integer (not a bool) and at least ``minimum``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def require_positive(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and > 0, else raise ``ValueError``."""
    value = require_number(name, value)
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def require_non_negative(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and >= 0, else raise ``ValueError``."""
    value = require_number(name, value)
    if not np.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def require_in_range(name: str, value: float, low: float, high: float) -> float:
    """Return ``value`` as float if it is finite and within [low, high]."""
    value = require_number(name, value)
    if not np.isfinite(value) or not (low <= value <= high):
        raise ValueError(f"{name} must be within [{low}, {high}], got {value!r}")
    return float(value)


def require_choice(name: str, value: Any, allowed: Iterable[Any]) -> Any:
    """Return ``value`` if it is one of ``allowed``."""
    allowed = tuple(allowed)
    if value not in allowed:
        raise ValueError(f"{name} must be one of {sorted(map(str, allowed))}, got {value!r}")
    return value


def as_finite_array(name: str, value: Any, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """Convert to a float64 array, checking shape (if given) and that every entry is finite."""
    if np.iscomplexobj(value):
        raise ValueError(f"{name} must be real, got complex values {value!r}")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numeric, got {value!r}") from error
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {array.tolist()}")
    return array


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
