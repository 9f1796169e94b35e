"""3-D backbone fit through key points, Zhao et al. 2021 (zhao2021), Section III-B, eqs. (7)-(10).

A hanging two-segment arm (base at the origin, ``+z`` along the undeformed arm from base to tip) is
described by ``2N + 1 = 7`` key points ``P0..P6`` at equal arc fractions (``P0`` the fixed base).
The backbone is cut into ``N = 3`` subsegments, subsegment ``j`` through ``P_{2j-2}, P_{2j-1},
P_{2j}``, and each is written ``z = psi_j(x, y)`` and fitted in two stages (eq. (7)):

* **XOY, eq. (8).** ``y = Y_j(x) = A x^2 + B x + C`` passes through the start point, has the slope
  of the previous subsegment there, and is least-squares on the two other points. With two
  equality constraints and one free coefficient the least-squares problem has a closed form. For
  ``j = 1`` there is no previous slope: the parabola interpolates the three points.
* **XOZ, eqs. (9)-(10).** With ``t`` the horizontal coordinate, ``Z_j(t) = D log[(t - E) /
  (F - (t - E))] + G``, the inverse sigmoid (ISF), through the start point with the previous
  subsegment's slope ``dZ/dt`` (``tan(89 deg)`` at the base, ``j = 1``), least squares on the two
  other points, subject to ``D > 0``, ``E < min(t)`` and ``2 max(t - E) < F``. The two equality
  constraints leave two free parameters, ``w0 = t_start - E > 0`` and ``r = max(t - E) / F`` in
  ``(0, 1/2)``; they are found by a vectorised grid search followed by a bounded
  Levenberg-Marquardt refinement (``D`` and ``G`` follow in closed form), so every constraint
  holds by construction.

**Which frame** (``curve``, :data:`BACKBONE_CURVES`). The paper shows the fit for the first
subsegment (Fig. 6(a)) and states ``Z'_1 = tan(89 deg)`` there: the ISF's steep start (Fig. 6(b),
"tangent with the Y axis") meets a backbone leaving the base along ``+z``. Read with every
subsegment in the base frame (``"paper_base_frame"``), a later subsegment starts with the finite
slope its predecessor ended on, and the convex branch that constraint 3 keeps can only flatten
from there: a subsegment that turns back towards ``+z`` (the second segment of an S-bend, or of
bends in planes 120 deg apart, which the paper's Table II shapes are) is missed by up to 60 mm.
The default ``"paper"`` fits each subsegment as the paper fits the first, in a frame at its start
whose ``z`` is the tangent there, so slope continuity (constraint 5) is the ISF's steep start in
every subsegment. Measured on the paper's eight Table II configurations simulated on the zhao2021
arm (:mod:`eval.papers.zhao2021.table2`): mean eq. (21) error 2.0 mm at ``xi = 0`` (paper
2.4-3.2 mm) against 10.0 mm in the base frame (22-24 mm on two of the eight shapes). The
inclination of 89 deg matters (85 deg gave 1.0 mm, 89.9 deg 10 mm); the printed 89 is kept.

**Continuity.** Eqs. (8) and (10) put subsegment ``j + 1``'s start on the key point ``P_{2j}``
with the slope subsegment ``j`` ended with; where the least-squares curve of subsegment ``j``
misses ``P_{2j}`` the backbone is bridged by a straight piece (:attr:`BackboneFit.node_gaps_m`),
as printed. Starting subsegment ``j + 1`` where ``j`` ended instead (a gapless curve) measured
2.7 mm at ``xi = 0`` and 4.9-6.9 mm with noise against 2.2 and 4.0-5.9 mm: a missed key point
then shifts the rest of the backbone. ``"cubic_fallback"`` chains its curves this way.

Where the paper's parametrisation breaks down this module is explicit, and each subsegment records
the method it used (:attr:`SubsegmentFit.method`) and why (:attr:`SubsegmentFit.reason`):

(a) **Frame of the parabola.** ``y = Y(x)`` needs ``x`` monotonic along the subsegment, which
    fails for a bend towards ``+-y``. Each subsegment is therefore fitted in its frame turned
    about ``z`` so that the horizontal projection of its chord (start point to ``P_{2j}``) lies
    along ``+x``. Rotation about ``z`` leaves ``t`` unchanged, and the slope constraint of eq. (8)
    is carried over as the horizontal direction of the previous subsegment's end tangent. The
    reported ``A, B, C`` are in that turned frame (:attr:`SubsegmentFit.frame_angle_rad`). If the
    middle key point does not project strictly between the chord's ends, or the carried-over
    direction is more than 80 deg from the chord (the curve would turn back in ``x``), the
    subsegment falls back to (c). When the previous end tangent is within 1 deg of vertical
    (always, in a subsegment's own frame) its horizontal direction is undefined; then, as the
    paper does at the base, no slope constraint is imposed and the parabola interpolates the
    three points.
(b) **Horizontal coordinate t.** ``t = sqrt(x^2 + y^2)`` is not monotonic along a backbone whose
    horizontal projection does not run straight away from the axis (an S-bend crossing back
    towards the axis, any bend out of a vertical plane through the axis), and then ``Z(t)`` is
    not a function. This module uses ``t`` = horizontal path length of the fitted XOY curves from
    the start of the frame (closed form for a parabola), which equals ``sqrt(x^2 + y^2)`` for a
    curve in a vertical plane through the frame's axis and is always increasing. With this
    ``t``, ``dZ/dt`` is the cotangent of the tangent's inclination from vertical, so continuity of
    ``dZ/dt`` and of the horizontal direction is continuity of the 3-D tangent.
(c) **Fallback.** A subsegment is fitted instead by the cubic ``r(tau) = P_start + c1 tau +
    c2 tau^2 + c3 tau^3`` in the chord-length parameter ``tau`` (method ``"cubic"``), tangent to
    the previous end tangent at its start (``+z`` at the base) and through its two other key
    points, when

    * its horizontal chord is shorter than ``min_horizontal_extent_m`` (1 mm: nearly straight
      along the frame's ``z``, no usable ``t``-range), or it fails a check of (a);
    * its start tangent or key points do not rise (the ISF with ``D > 0`` only rises, so a
      backbone bent past horizontal cannot be represented);
    * with ``curve="cubic_fallback"`` only: the paper's fit misses one of its two key points by
      more than ``tolerance_m`` (1 mm), i.e. the constraints of eq. (10) bind (with the start
      slope ``tan(89 deg)`` the convex ISF part cannot pass through the first three key points
      of a constant-curvature bend: misses of 6-8 mm for 30-90 deg bends), or the ISF curve
      would be more than 1.1 times as long as the key-point polyline (a detour).

    The cubic fallback is exact through the key points (0.04-0.6 mm on constant-curvature
    shapes, 0.2 mm on the Table II shapes) but it is not the paper's method.

Eqs. (8) and (10) print the objective as a sum of residual norms; here it is the sum of squares
(closed form for eq. (8); for eq. (10) the two free parameters meet the two points exactly
whenever the constraints allow, so the choice only matters when they bind).

The fitted curve is sampled densely and resampled to ``n_points`` points evenly spaced by arc
length from ``P0`` to its end; :func:`mean_backbone_error_m` is the shape error of eq. (21).
Lengths are in metres; quaternions are scalar-last ``(x, y, z, w)``.

Measured (tests/soft_gym/papers/zhao2021/test_backbone_fit.py, bench/backbone_fit_speed.py,
``python -m eval zhao2021 --experiments table2``): see docs/architecture.md ("zhao2021 backbone
fit") for the error of each curve on constant-curvature shapes and on Table II's shapes with
key-point noise ``xi``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from soft_gym._validation import as_finite_array, require_choice, require_integer, require_positive

__all__ = ["BackboneFit", "SubsegmentFit", "fit_backbone", "mean_backbone_error_m",
           "resample_by_arc_length", "BASE_SLOPE_DEG", "BACKBONE_CURVES"]

BACKBONE_CURVES = ("paper", "paper_base_frame", "cubic_fallback")
"""The curves :func:`fit_backbone` can fit (its ``curve``):

* ``"paper"`` (default): eqs. (7)-(10), each subsegment in its own frame, ``z`` along the tangent
  at its start, so every subsegment starts as the paper's first does (``Z' = tan(89 deg)``);
* ``"paper_base_frame"``: eqs. (7)-(10) with every subsegment in the base frame, the start slopes
  carried over from the previous subsegment there;
* ``"cubic_fallback"``: ``"paper_base_frame"``, with the cubic of choice (c) wherever the paper's
  curve misses a key point by more than ``tolerance_m`` (exact through the key points, not the
  paper's method)."""

#: Inclination of ``Z_1`` at the base: ``Z'_1(x_0, y_0) = tan(89 deg)`` (zhao2021, after eq. (10)).
BASE_SLOPE_DEG = 89.0
_BASE_SLOPE = math.tan(math.radians(BASE_SLOPE_DEG))
# Largest angle between the carried-over horizontal direction and the chord, rad (choice (a)).
_MAX_TURN_RAD = math.radians(80.0)
# Middle key point must project into (margin, 1 - margin) of the horizontal chord (choice (a)).
_MONOTONIC_MARGIN = 0.02
# Bounds of the ISF's free parameters: alpha = w0 / S (S = horizontal extent) and r = max(w) / F.
_LOG_ALPHA_BOUNDS = (math.log(1e-4), math.log(1e4))
_R_MIN = 1e-6
_R_MAX = 0.5 - 1e-9
# An ISF subsegment longer than this times its key-point polyline detours (choice (c)).
_MAX_LENGTH_RATIO = 1.1
_GRID_LOG_ALPHA = np.linspace(*_LOG_ALPHA_BOUNDS, 41)[:, None]
_GRID_R_FRACTIONS = np.concatenate([np.geomspace(1e-4, 0.9, 14), 1.0 - np.geomspace(1e-6, 0.09, 8)])
# Dense sampling of each subsegment before the arc-length resampling (uniform + clustered at the
# start, where the ISF may rise steeply).
_DENSE_FRACTIONS = np.unique(np.concatenate([np.linspace(0.0, 1.0, 81),
                                             np.geomspace(1e-5, 1.0, 40)]))


@dataclass(frozen=True)
class SubsegmentFit:
    """The fit of one subsegment ``j`` (through ``P_{2j-2}, P_{2j-1}, P_{2j}``).

    Attributes:
        method: ``"isf"`` (the paper's eqs. (8)-(10)) or ``"cubic"`` (fallback (c)).
        reason: Why a fallback was used (empty for ``"isf"``).
        start_m: Start point (3,) (``P0`` or the previous subsegment's fitted end).
        end_m: Fitted end point (3,).
        end_tangent: Unit tangent (3,) at the end.
        frame_angle_rad: Rotation about ``z`` of the frame of ``Y_j`` (choice (a)).
        parabola_abc: ``(A, B, C)`` of ``Y_j(x) = A x^2 + B x + C`` in that frame (x, y in m),
            ``None`` for the cubic.
        isf_defg: ``(D, E, F, G)`` of eq. (9) (m) with ``t`` the horizontal path length from the
            base (choice (b)), ``None`` for the cubic.
        cubic_coefficients_m: ``(c0, c1, c2, c3)`` (4, 3) of the cubic, ``None`` otherwise.
        t_start_m: Horizontal path length ``t`` of the fitted curve from the base to the start
            (choice (b)).
        t_end_m: The same at the end.
        key_point_residuals_m: Distances (2,) of ``P_{2j-1}, P_{2j}`` from the fitted curve at
            their parameter values.
        frame: Rotation (3, 3) whose columns are the fitting frame's axes in the base frame
            (before the turn about its ``z`` by ``frame_angle_rad``): the identity in the base
            frame, ``z`` along the start tangent for ``curve="paper"``. ``parabola_abc``,
            ``isf_defg``, ``t_start_m`` and ``t_end_m`` are in this frame (``t`` from the
            subsegment's start for ``curve="paper"``); points and tangents are in the base frame.
    """

    method: str
    reason: str
    start_m: np.ndarray
    end_m: np.ndarray
    end_tangent: np.ndarray
    frame_angle_rad: float
    parabola_abc: tuple[float, float, float] | None
    isf_defg: tuple[float, float, float, float] | None
    cubic_coefficients_m: np.ndarray | None
    key_point_residuals_m: np.ndarray
    t_start_m: float
    t_end_m: float
    frame: np.ndarray = field(default_factory=lambda: np.eye(3))


@dataclass(frozen=True)
class BackboneFit:
    """Result of :func:`fit_backbone`.

    Attributes:
        points_m: Backbone (n_points, 3), evenly spaced by arc length from ``P0`` to the tip.
        tip_position_m: End of the fitted curve (3,) (``P6`` up to the last subsegment's residual).
        tip_tangent: Unit tangent (3,) at the tip.
        tip_quaternion: ``(x, y, z, w)``, the smallest rotation taking ``+z`` to ``tip_tangent``.
        length_m: Arc length of the fitted curve.
        key_points_m: The key points used (7, 3), ``P0..P6``.
        subsegments: One :class:`SubsegmentFit` per subsegment.
    """

    points_m: np.ndarray
    tip_position_m: np.ndarray
    tip_tangent: np.ndarray
    tip_quaternion: np.ndarray
    length_m: float
    key_points_m: np.ndarray
    subsegments: tuple[SubsegmentFit, ...] = field(default_factory=tuple)

    @property
    def methods(self) -> tuple[str, ...]:
        """Method of each subsegment (``"isf"`` or ``"cubic"``)."""
        return tuple(sub.method for sub in self.subsegments)

    @property
    def fallback_subsegments(self) -> tuple[int, ...]:
        """1-based indices ``j`` of the subsegments not fitted by the paper's ISF."""
        return tuple(j + 1 for j, sub in enumerate(self.subsegments) if sub.method != "isf")

    @property
    def node_gaps_m(self) -> np.ndarray:
        """Distance (2,) from where subsegments 1 and 2 end to where 2 and 3 start (m): the
        straight bridges of eqs. (8) and (10), zero for ``curve="cubic_fallback"``."""
        return np.array([np.linalg.norm(after.start_m - before.end_m)
                         for before, after in zip(self.subsegments[:-1], self.subsegments[1:])])

    @property
    def key_point_residuals_m(self) -> np.ndarray:
        """Distance (7,) of each key point from the fitted curve (``P0`` is exact)."""
        return np.concatenate([[0.0]] + [sub.key_point_residuals_m for sub in self.subsegments])


# --------------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------------

def resample_by_arc_length(points_m: np.ndarray, n: int = 60) -> np.ndarray:
    """``n`` points (n, 3) evenly spaced by arc length along the polyline ``points_m`` (m, 3),
    first and last point kept (eq. (21) compares backbones sampled this way)."""
    points = as_finite_array("points_m", points_m)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
        raise ValueError(f"points_m must have shape (m, 3) with m >= 2, got shape {points.shape}")
    n = require_integer("n", n, 2)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], steps > 0.0])
    points = points[keep]
    if len(points) < 2:
        return np.repeat(points[:1], n, axis=0)
    cumulative = np.concatenate([[0.0], np.cumsum(steps[steps > 0.0])])
    targets = np.linspace(0.0, cumulative[-1], n)
    return np.stack([np.interp(targets, cumulative, points[:, k]) for k in range(3)], axis=1)


def mean_backbone_error_m(true_points_m: np.ndarray, fitted_points_m: np.ndarray,
                          n_points: int = 60) -> float:
    """Shape error of zhao2021 eq. (21): both backbones resampled to ``n_points`` points evenly
    spaced by arc length, mean distance between corresponding points (m)."""
    n_points = require_integer("n_points", n_points, 2)
    true = resample_by_arc_length(_polyline("true_points_m", true_points_m), n_points)
    fitted = resample_by_arc_length(_polyline("fitted_points_m", fitted_points_m), n_points)
    return float(np.mean(np.linalg.norm(true - fitted, axis=1)))


def fit_backbone(key_points_m: np.ndarray, n_points: int = 60, *, curve: str = "paper",
                 tolerance_m: float = 1e-3, min_horizontal_extent_m: float = 1e-3) -> BackboneFit:
    """Fit the backbone through the key points with zhao2021 eqs. (7)-(10).

    Args:
        key_points_m: ``P0..P6`` (7, 3) in m in the base frame (``+z`` from base to tip), or
            ``P1..P6`` (6, 3) with ``P0`` at the origin. ``P0`` is the base: the backbone leaves it
            along ``+z``.
        n_points: Points of the returned backbone, evenly spaced by arc length (>= 2).
        curve: One of :data:`BACKBONE_CURVES`: ``"paper"`` (default; each subsegment in its own
            frame), ``"paper_base_frame"`` or ``"cubic_fallback"``. Only the structural
            fallbacks of (c) (no usable ``t``-range, ``x`` not monotonic, not rising) replace
            the paper's curve in the first two; :attr:`BackboneFit.methods` names the curve of
            every subsegment.
        tolerance_m: ``"cubic_fallback"`` only: the largest distance of a subsegment's two
            fitted key points from the paper's curve before the cubic replaces it.
        min_horizontal_extent_m: Horizontal chord below which a subsegment is fitted by the cubic.

    Returns:
        A :class:`BackboneFit`.
    """
    points = as_finite_array("key_points_m", key_points_m)
    if points.shape == (6, 3):
        points = np.vstack([np.zeros(3), points])
    elif points.shape != (7, 3):
        raise ValueError(f"key_points_m must have shape (7, 3) (P0..P6) or (6, 3) (P1..P6, P0 at "
                         f"the origin), got shape {points.shape}")
    n_points = require_integer("n_points", n_points, 2)
    curve = require_choice("curve", curve, BACKBONE_CURVES)
    tolerance_m = require_positive("tolerance_m", tolerance_m)
    min_horizontal_extent_m = require_positive("min_horizontal_extent_m", min_horizontal_extent_m)
    scale = float(np.max(np.linalg.norm(points - points[0], axis=1)))
    if scale <= 0.0:
        raise ValueError(f"key_points_m must not all coincide with P0, got {points.tolist()}")

    start = points[0].copy()
    tangent = np.array([0.0, 0.0, 1.0])
    t_start = 0.0
    subsegments, dense = [], [start[None]]
    for j in range(3):
        q1, q2 = points[2 * j + 1], points[2 * j + 2]
        if curve == "paper":
            sub, samples = _fit_in_own_frame(start, tangent, q1, q2, min_horizontal_extent_m)
        else:
            fallback_m = tolerance_m if curve == "cubic_fallback" else None
            sub, samples, t_start = _fit_subsegment(start, tangent, t_start, q1, q2,
                                                    min_horizontal_extent_m, fallback_m)
        subsegments.append(sub)
        dense.append(samples[1:] if j == 0 or curve == "cubic_fallback" else samples)
        tangent = sub.end_tangent
        # eqs. (8) and (10) start subsegment j + 1 on the key point P_2j (a straight bridge
        # from where subsegment j ended, if it missed it); the cubic fallback chains its curves
        start = sub.end_m if curve == "cubic_fallback" else q2.copy()
    polyline = np.vstack(dense)
    length = float(np.sum(np.linalg.norm(np.diff(polyline, axis=0), axis=1)))
    return BackboneFit(points_m=resample_by_arc_length(polyline, n_points),
                       tip_position_m=subsegments[-1].end_m.copy(), tip_tangent=tangent.copy(),
                       tip_quaternion=_quaternion_from_z(tangent), length_m=length,
                       key_points_m=points, subsegments=tuple(subsegments))


# --------------------------------------------------------------------------------------------
# One subsegment
# --------------------------------------------------------------------------------------------

def _fit_subsegment(start: np.ndarray, tangent: np.ndarray, t_start: float, q1: np.ndarray,
                    q2: np.ndarray, min_extent_m: float, fallback_tolerance_m: float | None
                    ) -> tuple[SubsegmentFit, np.ndarray, float]:
    """Fit one subsegment; returns the fit, dense samples (k, 3) from its start, and the
    horizontal path length ``t`` at its end. With ``fallback_tolerance_m`` the cubic replaces a
    paper's curve that misses a key point by more than it (or detours); with ``None`` only the
    structural fallbacks apply."""
    keep_paper_curve = fallback_tolerance_m is None
    tolerance_m = math.inf if keep_paper_curve else fallback_tolerance_m
    reason = _isf_applicable(start, tangent, q1, q2, min_extent_m)
    if not reason:
        chord = q2[:2] - start[:2]
        angle = math.atan2(chord[1], chord[0])
        c, s = math.cos(angle), math.sin(angle)
        d1, d2 = q1 - start, q2 - start
        u1, v1 = c * d1[0] + s * d1[1], -s * d1[0] + c * d1[1]
        u2, v2 = c * d2[0] + s * d2[1], -s * d2[0] + c * d2[1]
        horizontal = math.hypot(tangent[0], tangent[1])
        inclination = math.atan2(horizontal, tangent[2])
        if inclination < math.radians(90.0 - BASE_SLOPE_DEG):
            # No usable previous horizontal direction: parabola through the three points.
            a = v1 / (u1 * (u1 - u2))
            b = -a * u2
            slope = _BASE_SLOPE
        else:
            turn = math.atan2(-s * tangent[0] + c * tangent[1], c * tangent[0] + s * tangent[1])
            b = math.tan(turn)
            a = (u1 * u1 * (v1 - b * u1) + u2 * u2 * (v2 - b * u2)) / (u1 ** 4 + u2 ** 4)
            slope = tangent[2] / horizontal
        xy_residual = max(abs(a * u1 * u1 + b * u1 - v1), abs(a * u2 * u2 + b * u2 - v2))
        if xy_residual > tolerance_m:
            reason = (f"XOY parabola misses a key point by {1e3 * xy_residual:.2f} mm "
                      f"> tolerance {1e3 * tolerance_m:.2f} mm")
        else:
            t1, t2 = _parabola_length(a, b, u1), _parabola_length(a, b, u2)
            extent = t2
            sigma1, eta1, eta2 = t1 / extent, (q1[2] - start[2]) / extent, \
                (q2[2] - start[2]) / extent
            log_alpha, r = _solve_isf(slope, sigma1, eta1, eta2)
            z_at = _isf_height(slope, log_alpha, r, np.array([sigma1, 1.0])) * extent
            fitted = np.array([[u1, a * u1 * u1 + b * u1, z_at[0]],
                               [u2, a * u2 * u2 + b * u2, z_at[1]]])
            residuals = np.linalg.norm(fitted - np.array([[u1, v1, d1[2]], [u2, v2, d2[2]]]),
                                       axis=1)
            if residuals.max() > tolerance_m:
                reason = (f"ISF misses a key point by {1e3 * residuals.max():.2f} mm > tolerance "
                          f"{1e3 * tolerance_m:.2f} mm (the constraints of eq. (10) bind)")
            else:
                sub, samples, t_end = _isf_result(start, angle, a, b, u2, extent, t_start, slope,
                                                  log_alpha, r, residuals)
                polyline = float(np.linalg.norm(q1 - start) + np.linalg.norm(q2 - q1))
                length = float(np.sum(np.linalg.norm(np.diff(samples, axis=0), axis=1)))
                if length <= _MAX_LENGTH_RATIO * polyline or keep_paper_curve:
                    return sub, samples, t_end
                reason = (f"ISF curve is {length / polyline:.2f} times as long as the key-point "
                          f"polyline (> {_MAX_LENGTH_RATIO}): it detours between the key points")
    sub, samples = _cubic(start, tangent, q1, q2, reason, t_start)
    return sub, samples, sub.t_end_m


def _fit_in_own_frame(start: np.ndarray, tangent: np.ndarray, q1: np.ndarray, q2: np.ndarray,
                      min_extent_m: float) -> tuple[SubsegmentFit, np.ndarray]:
    """``curve="paper"``: the subsegment fitted as the paper fits the first, in a frame at its
    start whose ``z`` is the tangent there (the smallest rotation from the base frame's ``+z``;
    the turn about ``z`` does not matter, choice (a) turns the frame to the chord)."""
    frame = _rotation_from_z(tangent)
    local_q1, local_q2 = (q1 - start) @ frame, (q2 - start) @ frame
    sub, samples, _ = _fit_subsegment(np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.0, local_q1,
                                      local_q2, min_extent_m, None)
    samples = start + samples @ frame.T
    end_tangent = frame @ sub.end_tangent
    return replace(sub, start_m=start.copy(), end_m=samples[-1].copy(),
                   end_tangent=end_tangent / np.linalg.norm(end_tangent), frame=frame), samples


def _isf_applicable(start: np.ndarray, tangent: np.ndarray, q1: np.ndarray, q2: np.ndarray,
                    min_extent_m: float) -> str:
    """Empty string if the paper's two-stage fit can be tried, else the reason it cannot."""
    chord = q2[:2] - start[:2]
    extent = math.hypot(chord[0], chord[1])
    if extent < min_extent_m:
        return (f"horizontal extent {1e3 * extent:.2f} mm < {1e3 * min_extent_m:.2f} mm "
                f"(nearly vertical)")
    if tangent[2] <= 0.0:
        return "start tangent does not rise (dZ/dt <= 0): the ISF cannot bend past horizontal"
    if q2[2] <= start[2] or q1[2] <= start[2]:
        return "key points do not rise above the start: z is not increasing in t"
    u1 = float((q1[:2] - start[:2]) @ chord) / extent
    if not (_MONOTONIC_MARGIN * extent < u1 < (1.0 - _MONOTONIC_MARGIN) * extent):
        return "middle key point does not project inside the horizontal chord (x not monotonic)"
    horizontal = math.hypot(tangent[0], tangent[1])
    if math.atan2(horizontal, tangent[2]) >= math.radians(90.0 - BASE_SLOPE_DEG):
        cosine = float(tangent[:2] @ chord) / (horizontal * extent)
        if cosine < math.cos(_MAX_TURN_RAD):
            return "horizontal direction turns more than 80 deg from the chord"
    return ""


def _isf_result(start: np.ndarray, angle: float, a: float, b: float, u2: float, extent: float,
                t_start: float, slope: float, log_alpha: float, r: float, residuals: np.ndarray
                ) -> tuple[SubsegmentFit, np.ndarray, float]:
    """The accepted ISF subsegment: dense samples, end tangent and the paper's parameters."""
    c, s = math.cos(angle), math.sin(angle)
    u = u2 * _DENSE_FRACTIONS
    v = a * u * u + b * u
    t = _parabola_length(a, b, u)
    z = start[2] + extent * _isf_height(slope, log_alpha, r, t / extent)
    samples = np.stack([start[0] + c * u - s * v, start[1] + s * u + c * v, z], axis=1)
    samples[0] = start
    # End tangent: d/du of (u, v, z) = (1, q, dZ/dt * sqrt(1 + q^2)).
    q = 2.0 * a * u2 + b
    alpha = math.exp(log_alpha)
    big_f = (alpha + 1.0) / r
    d = slope * alpha * (big_f - alpha) / big_f
    end_slope = d * big_f / ((alpha + 1.0) * (big_f - alpha - 1.0))
    local = np.array([1.0, q, end_slope * math.sqrt(1.0 + q * q)])
    end_tangent = np.array([c * local[0] - s * local[1], s * local[0] + c * local[1], local[2]])
    end_tangent /= np.linalg.norm(end_tangent)
    # Paper parameters: Y(x) = A x^2 + B x + C in the turned frame, Z(t) with t from the base.
    x0 = c * start[0] + s * start[1]
    y0 = -s * start[0] + c * start[1]
    abc = (a, b - 2.0 * a * x0, a * x0 * x0 - b * x0 + y0)
    w0 = alpha * extent
    big_e = t_start - w0
    big_f_m = big_f * extent
    big_g = start[2] - d * extent * math.log(w0 / (big_f_m - w0))
    defg = (d * extent, big_e, big_f_m, big_g)
    sub = SubsegmentFit(method="isf", reason="", start_m=start.copy(),
                        end_m=samples[-1].copy(), end_tangent=end_tangent,
                        frame_angle_rad=angle, parabola_abc=abc, isf_defg=defg,
                        cubic_coefficients_m=None, key_point_residuals_m=residuals,
                        t_start_m=t_start, t_end_m=t_start + extent)
    return sub, samples, t_start + extent


def _cubic(start: np.ndarray, tangent: np.ndarray, q1: np.ndarray, q2: np.ndarray,
           reason: str, t_start: float) -> tuple[SubsegmentFit, np.ndarray]:
    """Fallback (c): cubic in the chord-length parameter, tangent at the start, through q1, q2."""
    l1, l2 = float(np.linalg.norm(q1 - start)), float(np.linalg.norm(q2 - q1))
    total = max(l1 + l2, 1e-12)
    tau1 = min(max(l1 / total, 0.1), 0.9)
    c1 = total * tangent
    r1 = q1 - start - c1 * tau1
    r2 = q2 - start - c1
    c3 = (r1 - tau1 * tau1 * r2) / (tau1 * tau1 * (tau1 - 1.0))
    c2 = r2 - c3
    tau = _DENSE_FRACTIONS[:, None]
    samples = start + tau * (c1 + tau * (c2 + tau * c3))
    end_tangent = c1 + 2.0 * c2 + 3.0 * c3
    norm = float(np.linalg.norm(end_tangent))
    end_tangent = end_tangent / norm if norm > 0.0 else tangent.copy()
    residuals = np.array([np.linalg.norm(start + tau1 * (c1 + tau1 * (c2 + tau1 * c3)) - q1),
                          np.linalg.norm(samples[-1] - q2)])
    sub = SubsegmentFit(method="cubic", reason=reason, start_m=start.copy(),
                        end_m=samples[-1].copy(), end_tangent=end_tangent, frame_angle_rad=0.0,
                        parabola_abc=None, isf_defg=None,
                        cubic_coefficients_m=np.stack([start, c1, c2, c3]),
                        key_point_residuals_m=residuals, t_start_m=t_start,
                        t_end_m=t_start + float(np.sum(np.linalg.norm(
                            np.diff(samples[:, :2], axis=0), axis=1))))
    return sub, samples


# --------------------------------------------------------------------------------------------
# Closed forms and the ISF solve
# --------------------------------------------------------------------------------------------

def _parabola_length(a: float, b: float, u):
    """Arc length of ``v = a u^2 + b u`` from 0 to ``u`` (closed form; ``u`` float or array)."""
    u = np.asarray(u, dtype=float)
    root_b = math.sqrt(1.0 + b * b)
    if abs(a) * float(np.max(np.abs(u))) < 1e-6:
        out = u * root_b + a * b * u * u / root_b
    else:
        q = 2.0 * a * u + b
        out = (_h(q) - _h(b)) / (2.0 * a)
    return float(out) if out.ndim == 0 else out


def _h(q):
    return 0.5 * (q * np.sqrt(1.0 + q * q) + np.arcsinh(q))


def _isf_height(slope: float, log_alpha, r, sigma) -> np.ndarray:
    """Nondimensional ISF rise ``(Z(t) - z_start) / S`` at ``sigma = (t - t_start) / S`` for
    ``alpha = w0 / S``, ``r = (w0 + S) / F`` and start slope ``slope`` (eqs. (9)-(10) with the
    start value and slope constraints solved for ``D`` and ``G``). Broadcasts."""
    alpha = np.exp(log_alpha)
    big_f = (alpha + 1.0) / r
    rest = big_f - alpha
    d = slope * alpha * rest / big_f
    return d * (np.log1p(sigma / alpha) - np.log1p(-sigma / rest))


def _isf_residuals(slope: float, log_alpha: float, r: float, sigma1: float, eta1: float,
                   eta2: float) -> tuple[float, float]:
    """Scalar version of :func:`_isf_height` minus the targets at ``sigma1`` and 1 (fast)."""
    alpha = math.exp(log_alpha)
    big_f = (alpha + 1.0) / r
    rest = big_f - alpha
    d = slope * alpha * rest / big_f
    return (d * (math.log1p(sigma1 / alpha) - math.log1p(-sigma1 / rest)) - eta1,
            d * (math.log1p(1.0 / alpha) - math.log1p(-1.0 / rest)) - eta2)


def _solve_isf(slope: float, sigma1: float, eta1: float, eta2: float,
               r_max: float = _R_MAX) -> tuple[float, float]:
    """Least-squares ``(log alpha, r)`` of the ISF through ``(sigma1, eta1)``, ``(1, eta2)`` with
    ``log alpha`` in its bounds and ``r`` in ``[_R_MIN, r_max]``: grid search, then a projected
    Levenberg-Marquardt refinement (variables at a bound that the gradient pushes outwards are
    held there)."""
    r_grid = (r_max * _GRID_R_FRACTIONS)[None, :]
    heights = _isf_height(slope, _GRID_LOG_ALPHA[..., None], r_grid[..., None],
                          np.array([sigma1, 1.0]))
    cost = np.sum((heights - np.array([eta1, eta2])) ** 2, axis=-1)
    i, k = np.unravel_index(int(np.argmin(cost)), cost.shape)
    p = [float(_GRID_LOG_ALPHA[i, 0]), float(r_grid[0, k])]
    low = (_LOG_ALPHA_BOUNDS[0], _R_MIN)
    high = (_LOG_ALPHA_BOUNDS[1], r_max)
    f = _isf_residuals(slope, p[0], p[1], sigma1, eta1, eta2)
    best = f[0] * f[0] + f[1] * f[1]
    damping = 1e-3
    for _ in range(50):
        if best < 1e-24:
            break
        jac = [[0.0, 0.0], [0.0, 0.0]]
        for col in range(2):
            h = 1e-7 * max(1.0, abs(p[col]))
            if p[col] + h > high[col]:
                h = -h
            shifted = list(p)
            shifted[col] += h
            g = _isf_residuals(slope, shifted[0], shifted[1], sigma1, eta1, eta2)
            jac[0][col] = (g[0] - f[0]) / h
            jac[1][col] = (g[1] - f[1]) / h
        n00 = jac[0][0] ** 2 + jac[1][0] ** 2
        n11 = jac[0][1] ** 2 + jac[1][1] ** 2
        n01 = jac[0][0] * jac[0][1] + jac[1][0] * jac[1][1]
        g0 = jac[0][0] * f[0] + jac[1][0] * f[1]
        g1 = jac[0][1] * f[0] + jac[1][1] * f[1]
        free = [not ((p[c] <= low[c] and g > 0.0) or (p[c] >= high[c] and g < 0.0))
                for c, g in enumerate((g0, g1))]
        if not any(free):
            break
        improved, gain = False, 0.0
        for _ in range(10):
            a00 = n00 * (1.0 + damping) + 1e-18
            a11 = n11 * (1.0 + damping) + 1e-18
            if free[0] and free[1]:
                det = a00 * a11 - n01 * n01
                if det <= 0.0:
                    damping *= 10.0
                    continue
                step = [-(a11 * g0 - n01 * g1) / det, -(a00 * g1 - n01 * g0) / det]
            elif free[0]:
                step = [-g0 / a00, 0.0]
            else:
                step = [0.0, -g1 / a11]
            trial = [min(max(p[c] + step[c], low[c]), high[c]) for c in range(2)]
            f_trial = _isf_residuals(slope, trial[0], trial[1], sigma1, eta1, eta2)
            cost_trial = f_trial[0] * f_trial[0] + f_trial[1] * f_trial[1]
            if cost_trial < best:  # NaN compares False
                gain = best - cost_trial
                p, f, best = trial, f_trial, cost_trial
                damping = max(damping / 3.0, 1e-9)
                improved = True
                break
            damping *= 4.0
        if not improved or gain < 1e-12 * best:
            break
    return p[0], p[1]


def _rotation_from_z(direction: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking ``+z`` to the unit vector ``direction`` (Rodrigues;
    the identity for ``+z`` itself, a half turn about ``x`` for ``-z``)."""
    x, y, z = direction
    if z < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    k = 1.0 / (1.0 + z)
    return np.array([[1.0 - k * x * x, -k * x * y, x],
                     [-k * x * y, 1.0 - k * y * y, y],
                     [-x, -y, z]])


def _quaternion_from_z(direction: np.ndarray) -> np.ndarray:
    """Smallest rotation (x, y, z, w) taking ``+z`` to the unit vector ``direction``."""
    x, y, z = direction
    if z < -1.0 + 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    quaternion = np.array([-y, x, 0.0, 1.0 + z])
    return quaternion / np.linalg.norm(quaternion)


def _polyline(name: str, value: np.ndarray) -> np.ndarray:
    points = as_finite_array(name, value)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
        raise ValueError(f"{name} must have shape (m, 3) with m >= 2, got shape {points.shape}")
    return points
