"""End stops of the arm's joints: how far a link can stretch, shorten, bend and twist.

A soft arm stops lengthening or bending at a limit: a braided sleeve or zhao2021's central thread
at full extension, the chamber walls folding against each other at full bend. Each joint of the
discrete beam (:mod:`soft_gym.engines.pybullet.builder`) gets that limit as a locking spring: over the last
``band`` of its range towards a limit the stiffness rises linearly from zero to ``stiffness``
(``STOP_STIFFNESS_FACTOR`` times the joint's material stiffness) and stays there beyond the limit,
like the locking stretch of a Gent hyperelastic solid. The force is smooth (C1), so the
simulator's semi-implicit update sees the stop's true tangent stiffness as the joint closes in,
and any load the arm accepts (:attr:`soft_gym.robots.spec.ArmSpec.max_load_n`) leaves every joint
within 10 % of its limit. PyBullet's own joint-limit constraint, set by the builder at the same
limits, stays in place behind the stop.

A thread (:attr:`soft_gym.robots.spec.SegmentSpec.thread_length_m`) is slack, and pulls on
nothing, until the link reaches its length; from there its stiffness builds up over a short band
of ``THREAD_BAND_FRACTION`` of the link's rest length *beyond* the limit to
``THREAD_STIFFNESS_FACTOR`` times the link's axial stiffness. The link's free range is untouched
and a segment overshoots its thread by about 0.1 mm at the largest load.
"""

from __future__ import annotations

import numpy as np

STOP_STIFFNESS_FACTOR = 100.0
"""Stiffness of a joint past its limit over the joint's small-strain material stiffness."""

THREAD_STIFFNESS_FACTOR = 300.0
"""Stiffness of a taut thread over the link's small-strain axial stiffness (a polymer thread's
``E A`` is hundreds of times a silicone body's; stiffer would outrun the simulator's
semi-implicit update as the thread snaps taut)."""

THREAD_BAND_FRACTION = 2e-3
"""Band beyond a thread's length, as a fraction of the link's rest length, over which the taut
thread's stiffness builds up (keeps the stop C1)."""

THREAD_ANTICIPATION_FRACTION = 0.05
"""A slack thread this close to taut (as a fraction of the link's rest length) already counts as
taut in the simulator's semi-implicit gains (:meth:`EndStops.implicit_stiffness_at`): it snaps
taut within a few substeps, faster than the gains are refreshed."""

STOP_BAND = 0.25
"""Fraction of a joint's range (from the straight, unstretched arm to the limit) over which the
stop's stiffness builds up."""


class EndStops:
    """Locking springs at each joint's lower and upper limit.

    Args:
        lower: lower joint limits (rad or m), shape (n_joints,), each < 0.
        upper: upper joint limits (rad or m), shape (n_joints,), each > 0 (>= 0 for a thread).
        stiffness: full stop stiffness per joint (N m/rad or N/m), shape (n_joints,).
        thread_band: shape (n_joints,) or None; where > 0 (m), the upper stop is a thread: no
            force up to ``upper``, stiffness building up over ``thread_band`` beyond it.
    """

    def __init__(self, lower: np.ndarray, upper: np.ndarray, stiffness: np.ndarray,
                 thread_band: np.ndarray | None = None) -> None:
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        thread = (np.zeros_like(self.upper) if thread_band is None
                  else np.asarray(thread_band, dtype=float))
        if (thread.shape != self.upper.shape or np.any(thread < 0)
                or not np.all(np.isfinite(thread))):
            raise ValueError("thread_band must be None or finite bands >= 0, one per joint, "
                             f"got {thread.tolist()}")
        threaded = thread > 0
        if (np.any(self.lower >= 0) or np.any(self.upper[~threaded] <= 0)
                or np.any(self.upper[threaded] < 0)):
            raise ValueError("joint limits must straddle the rest position 0: lower < 0 < upper "
                             "(0 <= upper for a thread), "
                             f"got lower {self.lower.tolist()} and upper {self.upper.tolist()}")
        self.stiffness = np.asarray(stiffness, dtype=float)
        self._band_high = np.where(threaded, thread, STOP_BAND * self.upper)
        self._band_low = STOP_BAND * -self.lower
        self._start_high = np.where(threaded, self.upper, self.upper - self._band_high)
        self._start_low = self.lower + self._band_low
        # the free range [start_low, start_high] as centre +- half width: one test per call
        self.free_centre = 0.5 * (self._start_high + self._start_low)
        self.free_half_width = 0.5 * (self._start_high - self._start_low)
        self._threaded = threaded
        self._taut_soon = self.upper - THREAD_ANTICIPATION_FRACTION / THREAD_BAND_FRACTION * thread
        self._zeros = np.zeros_like(self.lower)
        self._zeros.flags.writeable = False

    def bands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Where each stop starts to act and the band over which its stiffness builds up (rad or
        m, per joint): ``(start_low, band_low, start_high, band_high)``; the lower stop acts
        below ``start_low``, the upper above ``start_high``."""
        return (self._start_low.copy(), self._band_low.copy(), self._start_high.copy(),
                self._band_high.copy())

    def force(self, q: np.ndarray) -> np.ndarray:
        """Restoring force of the stops at ``q`` (N m or N), positive along ``q``'s sign."""
        if not (np.abs(q - self.free_centre) > self.free_half_width).any():
            return self._zeros  # every joint in its free range: no stop acts
        high = self._locking(q - self._start_high, self._band_high)
        low = self._locking(self._start_low - q, self._band_low)
        return self.stiffness * (high - low)

    def stiffness_at(self, q: np.ndarray) -> np.ndarray:
        """Tangent stiffness ``d force / d q`` at ``q``."""
        if not (np.abs(q - self.free_centre) > self.free_half_width).any():
            return self._zeros
        high = np.clip((q - self._start_high) / self._band_high, 0.0, 1.0)
        low = np.clip((self._start_low - q) / self._band_low, 0.0, 1.0)
        return self.stiffness * (high + low)

    def implicit_stiffness_at(self, q: np.ndarray) -> np.ndarray:
        """Stiffness for the semi-implicit gains at ``q``: :meth:`stiffness_at`, with a thread
        about to go taut (within ``THREAD_ANTICIPATION_FRACTION`` of its link's rest length)
        already at its full stiffness. Only damps the last stretch numerically; static shapes
        are unchanged."""
        stiffness = self.stiffness_at(q)
        soon = self._threaded & (q > self._taut_soon)
        if soon.any():
            stiffness = np.where(soon, np.maximum(stiffness, self.stiffness), stiffness)
        return stiffness

    @staticmethod
    def _locking(depth: np.ndarray, band: np.ndarray) -> np.ndarray:
        """Integral of the unit stiffness ramp: ``d^2 / (2 b)`` inside the band (``0 <= d <= b``),
        ``d - b / 2`` beyond it, 0 before it."""
        depth = np.maximum(depth, 0.0)
        inside = np.minimum(depth, band)
        return inside * inside / (2.0 * band) + (depth - inside)
