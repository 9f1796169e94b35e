"""RSES: the constant-curvature shape from cable encoders (Zou et al. 2022, Section 3, eqs. 2-10).

Zou et al. 2022 read the three actuator lengths ``q = [l_1, l_2, l_3]`` with cable encoders and map
them to the arc parameters (eqs. 2-5),

    L = (l_1 + l_2 + l_3) / 3                                                              (2)
    kappa = 2 sqrt(l_1^2 + l_2^2 + l_3^2 - l_1 l_2 - l_1 l_3 - l_2 l_3) / (d (l_1 + l_2 + l_3))  (3)
    phi = atan(sqrt(3) (l_2 + l_3 - 2 l_1) / (3 (l_2 - l_3)))   (+ pi by eq. 5's cases)      (4-5)

and then to the backbone by the D-H product of eq. 7 (position eq. 6, orientation eq. 8, chained
over segments by eqs. 9-10). :mod:`soft_gym.kinematics` implements the same map in the
convention-free harmonic form (curvature vector ``(kx, ky) = kappa (cos phi, sin phi)``, chamber
``i`` at ``sigma_i = 2 pi i / 3`` from the base ``+x``), smooth through the straight pose where
eq. 4 is 0/0 (the singularity of the paper's Fig. 7); its ``kappa`` is eq. 3's exactly.

The RSES shape is sampled at the seven points ``P_0 .. P_6`` of the ``shape`` observation: the
material points at sixths of the arm's rest length. The CC model stretches a segment evenly, so
a point at rest fraction ``f`` of a segment is at arc ``f L`` of it: :func:`cc_shape_points`
evaluates each segment's arc (eq. 6 at partial arc lengths) there, chained through the segment
frames (eqs. 9-10).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from soft_gym._validation import require_integer
from soft_gym.kinematics import cc_segment_transform, cc_tip_pose, curvature_from_lengths

N_POINTS = 7
"""Points of the shape: ``P_0`` (base) to ``P_6`` (tip)."""


def arc_parameters(lengths_m: np.ndarray, d_m: float | Sequence[float]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eqs. 2-5: arc length ``L`` (m), curvature ``kappa`` (1/m) and bending-plane angle ``phi``
    (rad, in (-pi, pi], from the base ``+x``; 0 for a straight segment) of every segment.

    Args:
        lengths_m: chamber lengths (m), (..., 3 n_segments).
        d_m: chamber distance from the axis (m), one value or one per segment.

    Returns:
        ``(L, kappa, phi)``, each (..., n_segments).
    """
    s, kx, ky = curvature_from_lengths(lengths_m, d_m)
    return s, np.hypot(kx, ky), np.arctan2(ky, kx)


def _first_bad(name: str, array: np.ndarray, bad: np.ndarray, allowed: str) -> None:
    """Raise ``ValueError`` naming ``name`` and its first entry flagged in ``bad``, if any."""
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} must be {allowed}, got {float(array[where])!r} at index "
                         f"{where}")


def _as_real(name: str, value: object, what: str) -> np.ndarray:
    if value is None or np.iscomplexobj(value):
        raise ValueError(f"{name} must be real {what}, got {value!r}")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be {what} (numbers), got {value!r}") from error


def _check_lengths(lengths_m: object) -> np.ndarray:
    """``lengths_m`` as a float array (..., 3 n_segments) of finite lengths > 0 (m)."""
    lengths = _as_real("lengths_m", lengths_m, "chamber lengths (m)")
    if lengths.ndim == 0 or lengths.shape[-1] == 0 or lengths.shape[-1] % 3:
        raise ValueError(f"lengths_m must have shape (..., 3 n_segments) (three chamber lengths "
                         f"in m per segment), got shape {lengths.shape}")
    _first_bad("lengths_m", lengths, ~(np.isfinite(lengths) & (lengths > 0.0)),
               "finite chamber lengths > 0 (m)")
    return lengths


def _check_distance(d_m: object, n_segments: int) -> np.ndarray:
    """``d_m`` as a float array of finite distances > 0 (m): one, or one per segment."""
    distance = _as_real("d_m", d_m, "chamber distances from the axis (m)")
    if distance.ndim and distance.shape[-1] not in (1, n_segments):
        raise ValueError(f"d_m must be one chamber distance (m) or one per segment "
                         f"({n_segments}), got shape {distance.shape}")
    _first_bad("d_m", distance, ~(np.isfinite(distance) & (distance > 0.0)),
               "finite distances > 0 (m)")
    return distance


def cc_shape_points(lengths_m: np.ndarray, d_m: float | Sequence[float],
                    rest_lengths_m: Sequence[float] | None = None,
                    n_points: int = N_POINTS) -> np.ndarray:
    """RSES: the CC backbone's points at equal fractions of the rest length (eqs. 2-10).

    Args:
        lengths_m: chamber lengths (m), (..., 3 n_segments), e.g. the encoders' reading.
        d_m: chamber distance from the axis (m), one value or one per segment.
        rest_lengths_m: the segments' rest lengths (m); the points are the material points at
            ``k / (n_points - 1)`` of their sum. ``None``: equal segments.
        n_points: points from the base to the tip (>= 2; 7 for ``P_0 .. P_6``).

    Returns:
        Points (m, base frame), (..., n_points, 3); the first is the base, the last the tip.
    """
    n_points = require_integer("n_points", n_points, 2)
    lengths = _check_lengths(lengths_m)
    s, kx, ky = curvature_from_lengths(lengths, _check_distance(d_m, lengths.shape[-1] // 3))
    n_segments = s.shape[-1]
    if rest_lengths_m is None:
        rest = np.ones(n_segments)
    else:
        rest = np.asarray(rest_lengths_m, dtype=float)
        if rest.shape != (n_segments,) or not np.all(np.isfinite(rest)) or np.any(rest <= 0):
            raise ValueError(f"rest_lengths_m must be {n_segments} finite lengths > 0 (one per "
                             f"segment), got {rest_lengths_m!r}")
    bounds = np.r_[0.0, np.cumsum(rest)]
    targets = np.linspace(0.0, bounds[-1], n_points)
    segment = np.clip(np.searchsorted(bounds, targets, side="right") - 1, 0, n_segments - 1)
    fraction = (targets - bounds[segment]) / rest[segment]
    batch = s.shape[:-1]
    points = np.empty(batch + (n_points, 3))
    position = np.zeros(batch + (3,))
    rotation = np.broadcast_to(np.eye(3), batch + (3, 3)).copy()
    for k in range(n_segments):
        chosen = np.flatnonzero(segment == k)
        if chosen.size:
            partial = s[..., k, None] * fraction[chosen]                      # (..., m) m
            local, _ = cc_segment_transform(partial, kx[..., k, None], ky[..., k, None])
            points[..., chosen, :] = position[..., None, :] + np.einsum(
                "...ij,...mj->...mi", rotation, local)
        tip, turn = cc_segment_transform(s[..., k], kx[..., k], ky[..., k])
        position = position + np.einsum("...ij,...j->...i", rotation, tip)
        rotation = rotation @ turn
    return points


def cc_shape(lengths_m: np.ndarray, d_m: float | Sequence[float],
             rest_lengths_m: Sequence[float] | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RSES for one reading: ``(P_0 .. P_6 (7, 3) m, tip position (3,) m, tip quaternion
    (x, y, z, w))``; the orientation is the CC tip frame (eqs. 8-9)."""
    points = cc_shape_points(lengths_m, d_m, rest_lengths_m)
    tip, quaternion = cc_tip_pose(lengths_m, d_m)
    return points, tip, quaternion


__all__ = ["N_POINTS", "arc_parameters", "cc_shape_points", "cc_shape"]
