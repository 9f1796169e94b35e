"""The three chambers of a segment: their angles about the segment axis (one copy for all).

Chamber ``i`` of a segment sits at ``sigma_i = 2 pi i / 3`` (rad, counter-clockwise from the
segment base's ``+x``); see docs/architecture.md, "Chambers". :mod:`soft_gym.robots.actuation`
re-exports these with the action <-> pressure maps.
"""

from __future__ import annotations

import numpy as np


def _read_only(values: np.ndarray) -> np.ndarray:
    values.flags.writeable = False
    return values


CHAMBER_ANGLES_RAD: np.ndarray = _read_only(2.0 * np.pi * np.arange(3) / 3.0)
"""Angles ``sigma_i = 2 pi i / 3`` (rad) of a segment's three chambers (read-only)."""

CHAMBER_COS: np.ndarray = _read_only(np.array([1.0, -0.5, -0.5]))
"""Exact ``cos(sigma_i)``: equal chamber lengths then give exactly zero curvature
(``np.cos(2 pi / 3)`` is not exactly -1/2 in floating point)."""

CHAMBER_SIN: np.ndarray = _read_only(np.array([0.0, 0.5 * np.sqrt(3.0), -0.5 * np.sqrt(3.0)]))
"""Exact ``sin(sigma_i)`` (see :data:`CHAMBER_COS`)."""
