"""How near the tip of a resting arm gets to a point: a pressure search on the static arm.

:func:`closest_reach` searches the chamber pressures (within ``[0, p_max]``) that bring the tip of
:class:`~soft_gym.robots.statics.StaticArm` nearest a point, with a tip weight hung on, by
``scipy.optimize.least_squares`` from a few starts (all chambers at mid pressure, and the chambers
facing away from the point at three levels, so the arm bends towards it). Each evaluation is a
static equilibrium (milliseconds), not seconds of simulated settling, so a whole reach test of
an arm takes seconds; the rest shapes agree with the settled simulators
(``tests/soft_gym/robots/test_statics.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from soft_gym._validation import as_finite_array, require_non_negative
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.robots.statics import StaticArm

START_LEVELS = (0.35, 0.7, 1.0)
"""Pressure levels (fractions of ``p_max``) of the starts that bend the arm towards the point."""


@dataclass(frozen=True)
class Reach:
    """The nearest the resting tip gets to a point.

    Attributes:
        distance_m: distance from the point to the nearest tip found (m).
        tip_m: that tip (m, base frame).
        pressures_pa: the chamber pressures that put it there (Pa).
    """

    distance_m: float
    tip_m: np.ndarray
    pressures_pa: np.ndarray


def search_starts(arm: StaticArm, point_m: np.ndarray) -> list[np.ndarray]:
    """Pressure fractions (of ``p_max``) to start the search from: all chambers at half, and
    each segment's chambers weighted by how far they face away from the point's azimuth (a
    pressurised chamber bends its segment away from itself) at :data:`START_LEVELS`."""
    azimuth = float(np.arctan2(point_m[1], point_m[0]))
    facing_away = np.clip(np.cos(CHAMBER_ANGLES_RAD - azimuth - np.pi), 0.0, None)
    weights = np.tile(facing_away / facing_away.max(), arm.spec.n_segments)
    starts = [np.full(arm.spec.n_chambers, 0.5)]
    starts += [np.clip(level * weights + 0.05, 0.0, 1.0) for level in START_LEVELS]
    return starts


def closest_reach(arm: StaticArm, point_m: np.ndarray, tip_mass_kg: float = 0.0,
                  starts: list[np.ndarray] | None = None, tolerance_m: float = 1e-4) -> Reach:
    """The nearest the resting tip gets to ``point_m`` with ``tip_mass_kg`` hung at the tip.

    Args:
        arm: the static arm.
        point_m: the point (m, base frame), shape (3,).
        tip_mass_kg: mass hung at the tip (kg).
        starts: pressure fractions of ``p_max`` to search from (default :func:`search_starts`).
        tolerance_m: a start that gets this near ends the search (m).

    Returns:
        The best :class:`Reach` of all starts.

    Raises:
        ValueError: a bad point or mass.
    """
    point = as_finite_array("point_m", point_m, shape=(3,))
    mass = require_non_negative("tip_mass_kg", tip_mass_kg)
    p_max = arm.spec.p_max_pa
    warm = {"q": None}

    def tip(fractions: np.ndarray) -> np.ndarray:
        state = arm.equilibrium(np.clip(fractions, 0.0, 1.0) * p_max, tip_mass_kg=mass,
                                q_start=warm["q"])
        warm["q"] = state.q
        return state.tip_m

    best = None
    for start in (starts if starts is not None else search_starts(arm, point)):
        fit = least_squares(lambda x: tip(x) - point, np.clip(start, 0.0, 1.0),
                            bounds=(0.0, 1.0), diff_step=1e-4, xtol=1e-6, ftol=1e-10,
                            max_nfev=60)
        distance = float(np.linalg.norm(fit.fun))
        if best is None or distance < best.distance_m:
            best = Reach(distance, point + fit.fun, np.clip(fit.x, 0.0, 1.0) * p_max)
        if distance < tolerance_m:
            break
    return best
