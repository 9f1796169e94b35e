"""A baseline's warning that its inverse cannot reach the targets it is given.

A model-based inverse (wang2023's CC model, eqs. (25)-(27); ho2018's RWR inverse; zhao2021's
local-IK network) asks for chamber pressures; the regulators hold them between the pre-pressure
and ``p_max``, and the baselines clip what they command to that range. Where every chamber's
wanted pressure lies beyond one of its bounds for a while, the arm is held still at the bounds
and the target is out of the model's reach from there (ho2018's upright arm with its default
circle below the resting tip: ``cc_model`` commands the pre-pressure on every chamber at every
step). :class:`SaturationWatch` notices this and says so once per controller, with an
:class:`InfeasibleTargetWarning` naming the target (mm) and the bounds (kPa), instead of letting
the run end at a large error without a word.
"""

from __future__ import annotations

import warnings

import numpy as np

_MM = 1000.0
_KPA = 1e-3


class InfeasibleTargetWarning(RuntimeWarning):
    """Every chamber of a baseline has been held at a pressure bound: the target is out of reach
    of its inverse."""


class SaturationWatch:
    """Counts consecutive commands whose every chamber wanted a pressure beyond its bounds, and
    warns once (an :class:`InfeasibleTargetWarning`) when ``steps`` of them come in a row.

    Args:
        name: the baseline's name (starts the message).
        low_pa, high_pa: the pressure bounds (Pa; scalars or one per chamber).
        steps: consecutive saturated commands before the warning (at least 1).
    """

    def __init__(self, name: str, low_pa, high_pa, steps: int) -> None:
        if not isinstance(steps, (int, np.integer)) or isinstance(steps, bool) or steps < 1:
            raise ValueError(f"steps must be an integer of at least 1, got {steps!r}")
        self.name = name
        self.low_pa = np.asarray(low_pa, dtype=float)
        self.high_pa = np.asarray(high_pa, dtype=float)
        self.steps = int(steps)
        self.run = 0
        self.warned = False

    def reset(self) -> None:
        """Start of an episode: the count starts again (a warning given stays given)."""
        self.run = 0

    def observe(self, wanted_pa: np.ndarray, target_m: np.ndarray) -> bool:
        """Record one command: the pressures the inverse wanted (Pa, before clipping) for the
        target ``target_m`` (m). Returns whether every chamber was beyond a bound."""
        wanted = np.asarray(wanted_pa, dtype=float)
        tolerance = 1e-6 * np.maximum(np.abs(self.high_pa), 1.0)
        below = wanted < self.low_pa - tolerance
        above = wanted > self.high_pa + tolerance
        saturated = bool(np.all(below | above))
        self.run = self.run + 1 if saturated else 0
        if self.run >= self.steps and not self.warned:
            self.warned = True
            warnings.warn(self._message(below, above, np.asarray(target_m, dtype=float)),
                          InfeasibleTargetWarning, stacklevel=3)
        return saturated

    def _message(self, below: np.ndarray, above: np.ndarray, target_m: np.ndarray) -> str:
        target = ", ".join(f"{value * _MM:.1f}" for value in target_m)
        held = []
        for mask, bound, what in ((below, self.low_pa, "the pre-pressure"),
                                  (above, self.high_pa, "p_max")):
            chambers = np.flatnonzero(mask)
            if chambers.size:
                values = np.broadcast_to(bound, mask.shape)[chambers]
                kpa = ", ".join(sorted({f"{value * _KPA:g}" for value in values}))
                held.append(f"chambers {chambers.tolist()} at {what} ({kpa} kPa)")
        return (f"{self.name}: its inverse cannot reach the target ({target}) mm: for "
                f"{self.steps} commands in a row every chamber wanted a pressure beyond its "
                f"bound, so they are held with {' and '.join(held)} and the arm does not move "
                f"towards it (the target lies outside what the arm reaches from there; this "
                f"warning is given once)")
