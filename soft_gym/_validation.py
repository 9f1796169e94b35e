"""Small argument checks shared across the package.

Every check raises :class:`ValueError` naming the parameter, the value received and what is
allowed, so a bad configuration fails at construction instead of producing NaNs later.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np


def require_positive(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and > 0, else raise ``ValueError``."""
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def require_non_negative(name: str, value: float) -> float:
    """Return ``value`` as float if it is finite and >= 0, else raise ``ValueError``."""
    if not np.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def require_in_range(name: str, value: float, low: float, high: float) -> float:
    """Return ``value`` as float if it is finite and within [low, high]."""
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
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numeric, got {value!r}") from error
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {array.tolist()}")
    return array
