"""Predefined actuation sequences: the exploration that initialises F-emp and drives the
estimation experiments (wang2023, Section IV-B: a spiral actuation sequence at 0.05 s steps).

The sequence is a spiral in chamber-pressure space: the bending direction turns once every
``turn_s`` seconds while the bending amplitude breathes between ``low`` and ``high`` over
``breath_s`` seconds, so the tip sweeps a spiral over the workspace and back.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import require_in_range, require_positive


def spiral_fractions(time_s: float | np.ndarray, n_segments: int = 1, turn_s: float = 8.0,
                     breath_s: float = 60.0, low: float = 0.1, high: float = 1.0,
                     common: float = 0.0, common_s: float = 17.0) -> np.ndarray:
    """Chamber pressures as fractions of the way from pre-pressure to ``p_max``.

    Chamber ``i`` of each segment gets ``a(t) (1 + cos(2 pi t / turn_s - 2 pi i / 3)) / 2`` with
    the amplitude ``a(t)`` rising from ``low`` to ``high`` and back every ``breath_s``; segment
    ``k`` turns with a phase lag of ``k pi / 2`` so a two-segment arm also bends in S shapes.
    ``common`` adds the same pressure fraction ``common (1 - cos(2 pi t / common_s)) / 2`` to every
    chamber (clipped at 1), so the arm's extension varies independently of its bending (with
    ``common = 0`` extension and bend rise and fall together).

    Returns:
        Array of shape ``(..., 3 * n_segments)`` in [0, 1].
    """
    require_positive("turn_s", turn_s)
    require_positive("breath_s", breath_s)
    require_in_range("low", low, 0.0, 1.0)
    require_in_range("high", high, low, 1.0)
    require_in_range("common", common, 0.0, 1.0)
    require_positive("common_s", common_s)
    t = np.asarray(time_s, dtype=float)[..., None]
    amplitude = low + (high - low) * 0.5 * (1.0 - np.cos(2.0 * np.pi * t / breath_s))
    chambers = np.arange(3 * n_segments)
    segment, chamber = chambers // 3, chambers % 3
    phase = 2.0 * np.pi * t / turn_s - 2.0 * np.pi * chamber / 3.0 - 0.5 * np.pi * segment
    extension = common * 0.5 * (1.0 - np.cos(2.0 * np.pi * t / common_s))
    return np.minimum(amplitude * 0.5 * (1.0 + np.cos(phase)) + extension, 1.0)
