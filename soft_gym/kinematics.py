"""Constant-curvature kinematics of multi-segment, three-chamber soft continuum arms.

Every function is vectorised over arbitrary leading batch dimensions ``...`` and uses SI
units throughout: lengths and positions in metres (m), curvatures in 1/m, angles in radians.

Model
-----
The constant-curvature (CC) model follows Wang et al. 2023 (wang2023), eqs. (19)-(24), and
Zou et al. 2022 (zou2022), eqs. (2)-(10).

* **Base frame.** Origin at the centre of the arm's base, ``+z`` along the undeformed arm
  from base to tip.
* **Chambers.** Segment ``k`` owns chambers ``3k, 3k+1, 3k+2``; chamber ``i`` of a segment
  sits at angle ``sigma_i = 2*pi*i/3`` (counter-clockwise from the segment base ``+x``) at
  distance ``d`` (m) from the segment axis.
* **Segment shape.** The segment arc length ``s`` (m) is the mean of its three chamber lengths.
  With curvature ``kappa`` (1/m) and bending-plane angle ``phi`` (rad), chamber ``i`` has length
  ``l_i = s * (1 - d * kappa * cos(sigma_i - phi))``, so a lengthened chamber bends the segment
  away from itself.  The curvature is handled as the Cartesian vector
  ``(kx, ky) = kappa * (cos(phi), sin(phi))``, obtained from the first harmonic of the chamber
  lengths::

      kx = -2 / (3 d s) * sum_i l_i cos(sigma_i)
      ky = -2 / (3 d s) * sum_i l_i sin(sigma_i)

  ``phi`` itself is never computed (no ``atan2``), which keeps every map smooth through the
  straight pose ``kappa = 0``.
* **Segment pose.** With ``theta = kappa * s`` (bending angle, rad) the segment tip relative
  to the segment base is::

      p = (kx s^2/2 sinc^2(theta/2), ky s^2/2 sinc^2(theta/2), s sinc(theta)),
      sinc(x) = sin(x) / x,

  i.e. the exact arc ``((1 - cos theta)/kappa * (cos phi, sin phi), sin(theta)/kappa)``.  The
  tip orientation is the rotation with rotation vector ``s * (-ky, kx, 0)`` (axis
  ``(-sin phi, cos phi, 0)``, angle ``theta``), evaluated with a smooth Rodrigues formula.
* **Serial chain.** The base frame of segment ``k + 1`` is the tip frame of segment ``k``
  (no torsion between segments).

Quaternions are scalar-last ``(x, y, z, w)`` and returned with ``w >= 0``.
"""

from __future__ import annotations

from typing import (
    Any,
    Dict,
    Literal,
    NamedTuple,
    Optional,
    Sequence,
    Tuple,
    Union,
    overload,
)

import numpy as np
from numpy.typing import ArrayLike, NDArray

from soft_gym._quaternion import quaternion_multiply
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD, CHAMBER_COS, CHAMBER_SIN

__all__ = [
    "CHAMBER_ANGLES",
    "curvature_from_lengths",
    "lengths_from_curvature",
    "cc_segment_transform",
    "cc_forward",
    "cc_backbone",
    "cc_tip_pose",
    "cc_jacobian",
    "cc_inverse_single",
    "cc_inverse",
]

FloatArray = NDArray[np.float64]
#: Chamber distance from the segment axis: a scalar or one value per segment (m).
DistanceLike = Union[float, Sequence[float], FloatArray]

#: Angular positions ``sigma_i = 2*pi*i/3`` (rad) of the three chambers of a segment: the
#: library's one copy, :data:`soft_gym.robots.actuation.CHAMBER_ANGLES_RAD` (read-only).
CHAMBER_ANGLES: FloatArray = CHAMBER_ANGLES_RAD
# Exact cosines / sines of CHAMBER_ANGLES, so that equal chamber lengths give exactly zero
# curvature (np.cos(2*pi/3) is not exactly -1/2 in floating point).
_COS_SIGMA: FloatArray = CHAMBER_COS
_SIN_SIGMA: FloatArray = CHAMBER_SIN

# Below this value of u = theta^2 the derivatives of the sinc terms use Taylor series.
_SERIES_U = 1e-2
# Taylor coefficients in u = theta^2 of dH/du (H = sinc(theta)), dG/du (G = sinc^2(theta/2))
# and B = (theta - sin theta)/theta^3; the first omitted terms are below 1e-20 for u < 1e-2.
_DH_SERIES = (-1.0 / 6.0, 1.0 / 60.0, -1.0 / 1680.0, 1.0 / 90720.0, -1.0 / 7983360.0)
_DG_SERIES = (-1.0 / 12.0, 1.0 / 180.0, -1.0 / 6720.0, 1.0 / 453600.0, -1.0 / 47900160.0)
_B_SERIES = (1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0, 1.0 / 39916800.0)
# Lower bound applied to chamber lengths by ``cc_inverse`` when no ``min_lengths`` is given (m).
_DEFAULT_MIN_LENGTH = 1e-6
# Largest change per damped-least-squares iteration of a segment's bending angle (rad) and,
# relative to its value, of its arc length (trust region of ``cc_inverse``).
_MAX_BEND_STEP = 0.5
_MAX_ARC_STEP = 0.2
# Per-iteration decay of the null-space gain of ``cc_inverse``.
_REGULARISATION_DECAY = 0.8


# --------------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------------


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _as_float(name: str, value: ArrayLike) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numeric array-like, got {value!r}") from error
    return array


def _first_bad(array: FloatArray, mask: NDArray[np.bool_]) -> Tuple[float, Tuple[int, ...]]:
    index = tuple(int(i) for i in np.argwhere(mask)[0])
    return float(array[index]), index


def _check_finite(name: str, array: FloatArray) -> None:
    bad = ~np.isfinite(array)
    if np.any(bad):
        value, index = _first_bad(array, bad)
        raise ValueError(f"{name} must be finite (no NaN or inf), got {value!r} at index {index}")


def _check_positive(name: str, array: FloatArray) -> None:
    _check_finite(name, array)
    bad = array <= 0.0
    if np.any(bad):
        value, index = _first_bad(array, bad)
        raise ValueError(f"{name} must be > 0, got {value!r} at index {index}")


def _validate_lengths(lengths: ArrayLike) -> Tuple[FloatArray, int]:
    """Return ``lengths`` as float array of shape (..., 3n) and ``n``, or raise ValueError."""
    array = _as_float("lengths", lengths)
    if array.ndim == 0 or array.shape[-1] == 0 or array.shape[-1] % 3 != 0:
        size = "a scalar" if array.ndim == 0 else f"last dimension {array.shape[-1]}"
        raise ValueError(
            "lengths must have shape (..., 3*n_segments) with n_segments >= 1 "
            f"(last dimension a positive multiple of 3), got {size} (shape {array.shape})"
        )
    _check_positive("lengths", array)
    return array, array.shape[-1] // 3


def _validate_d(d: DistanceLike, n_segments: int) -> FloatArray:
    """Return ``d`` as an array broadcastable against (..., n_segments)."""
    array = _as_float("d", d)
    if array.ndim == 0:
        array = array[None]
    if array.shape[-1] not in (1, n_segments):
        raise ValueError(
            f"d must be a float or have one value per segment (last dimension 1 or "
            f"{n_segments}), got shape {array.shape}"
        )
    _check_positive("d", array)
    return array


def _validate_per_segment(name: str, value: ArrayLike, n_segments: int) -> FloatArray:
    array = _as_float(name, value)
    if array.ndim == 0:
        array = array[None]
    if array.ndim != 1 or array.shape[0] not in (1, n_segments):
        raise ValueError(
            f"{name} must be a float or a sequence of {n_segments} values (one per segment), "
            f"got shape {array.shape}"
        )
    _check_positive(name, array)
    return np.broadcast_to(array, (n_segments,)).copy()


def _validate_target(target_position: ArrayLike) -> FloatArray:
    array = _as_float("target_position", target_position)
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(
            f"target_position must have shape (..., 3), got shape {array.shape}"
        )
    _check_finite("target_position", array)
    return array


def _validate_curvature(
    s: ArrayLike, kx: ArrayLike, ky: ArrayLike, allow_zero_s: bool
) -> Tuple[FloatArray, FloatArray, FloatArray]:
    s_arr = _as_float("s", s)
    kx_arr = _as_float("kx", kx)
    ky_arr = _as_float("ky", ky)
    _check_finite("s", s_arr)
    _check_finite("kx", kx_arr)
    _check_finite("ky", ky_arr)
    bad = s_arr < 0.0 if allow_zero_s else s_arr <= 0.0
    if np.any(bad):
        value, index = _first_bad(s_arr, bad)
        rule = ">= 0" if allow_zero_s else "> 0"
        raise ValueError(f"s must be {rule} (arc length in m), got {value!r} at index {index}")
    try:
        s_arr, kx_arr, ky_arr = np.broadcast_arrays(s_arr, kx_arr, ky_arr)
    except ValueError as error:
        raise ValueError(
            f"s, kx and ky must have broadcastable shapes, got {s_arr.shape}, "
            f"{kx_arr.shape} and {ky_arr.shape}"
        ) from error
    return s_arr, kx_arr, ky_arr


# --------------------------------------------------------------------------------------------
# Smooth sinc-type functions of u = theta^2
# --------------------------------------------------------------------------------------------


def _sinc_terms(u: FloatArray) -> Tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return ``(theta, H, G, sinc(theta/2))`` for ``u = theta^2``.

    ``H = sinc(theta)`` and ``G = sinc^2(theta/2) = 2 (1 - cos theta) / theta^2``.
    """
    theta = np.sqrt(u)
    h = np.sinc(theta / np.pi)
    half = np.sinc(theta / (2.0 * np.pi))
    return theta, h, half * half, half


def _horner(u: FloatArray, coefficients: Tuple[float, ...]) -> FloatArray:
    """Evaluate ``sum_k coefficients[k] * u**k``."""
    result = np.full_like(u, coefficients[-1])
    for c in coefficients[-2::-1]:
        result = result * u + c
    return result


def _sinc_derivatives(
    u: FloatArray, theta: FloatArray, h: FloatArray, g: FloatArray
) -> Tuple[FloatArray, FloatArray, FloatArray]:
    """Return ``dH/du``, ``dG/du`` and ``B = (1 - H)/u = (theta - sin theta)/theta^3``.

    Taylor series are used for ``u < 1e-2`` where the closed forms lose precision.
    """
    small = u < _SERIES_U
    us = np.where(small, 1.0, u)
    dh_closed = (np.cos(theta) - h) / (2.0 * us)
    dg_closed = (h - g) / us
    b_closed = (1.0 - h) / us
    return (
        np.where(small, _horner(u, _DH_SERIES), dh_closed),
        np.where(small, _horner(u, _DG_SERIES), dg_closed),
        np.where(small, _horner(u, _B_SERIES), b_closed),
    )


def _skew_xy(wx: FloatArray, wy: FloatArray) -> FloatArray:
    """Skew-symmetric matrix of the in-plane vector ``(wx, wy, 0)``, shape (..., 3, 3)."""
    zero = np.zeros_like(wx)
    return np.stack(
        [
            np.stack([zero, zero, wy], axis=-1),
            np.stack([zero, zero, -wx], axis=-1),
            np.stack([-wy, wx, zero], axis=-1),
        ],
        axis=-2,
    )


# --------------------------------------------------------------------------------------------
# Unchecked core maps
# --------------------------------------------------------------------------------------------


def _curvature(lengths: FloatArray, d: FloatArray) -> Tuple[FloatArray, FloatArray, FloatArray]:
    per_seg = lengths.reshape(lengths.shape[:-1] + (-1, 3))
    l0, l1, l2 = per_seg[..., 0], per_seg[..., 1], per_seg[..., 2]
    s = (l0 + l1 + l2) / 3.0
    scale = -2.0 / (3.0 * d * s)
    # sum_i l_i cos(sigma_i) and sum_i l_i sin(sigma_i), written so that equal lengths give
    # exactly zero.
    kx = scale * (l0 - 0.5 * (l1 + l2))
    ky = scale * (_SIN_SIGMA[1] * (l1 - l2))
    return s, kx, ky


def _lengths(s: FloatArray, kx: FloatArray, ky: FloatArray, d: FloatArray) -> FloatArray:
    s, kx, ky, d = np.broadcast_arrays(s, kx, ky, d)
    harmonic = kx[..., None] * _COS_SIGMA + ky[..., None] * _SIN_SIGMA
    per_seg = s[..., None] * (1.0 - d[..., None] * harmonic)
    return per_seg.reshape(per_seg.shape[:-2] + (-1,))


def _segment_position(s: FloatArray, kx: FloatArray, ky: FloatArray) -> FloatArray:
    u = s * s * (kx * kx + ky * ky)
    _, h, g, _ = _sinc_terms(u)
    half_s2g = 0.5 * s * s * g
    return np.stack([kx * half_s2g, ky * half_s2g, s * h], axis=-1)


def _segment_transform(
    s: FloatArray, kx: FloatArray, ky: FloatArray
) -> Tuple[FloatArray, FloatArray]:
    u = s * s * (kx * kx + ky * ky)
    _, h, g, _ = _sinc_terms(u)
    half_s2g = 0.5 * s * s * g
    position = np.stack([kx * half_s2g, ky * half_s2g, s * h], axis=-1)
    # Rodrigues: R = I + sinc(theta) W + (1 - cos theta)/theta^2 W^2, W = [s(-ky, kx, 0)]_x.
    w = _skew_xy(-s * ky, s * kx)
    rotation = np.eye(3) + h[..., None, None] * w + (0.5 * g)[..., None, None] * (w @ w)
    return position, rotation


def _segment_quaternion(s: FloatArray, kx: FloatArray, ky: FloatArray) -> FloatArray:
    u = s * s * (kx * kx + ky * ky)
    theta, _, _, half = _sinc_terms(u)
    factor = 0.5 * half * s  # sin(theta/2)/theta * s
    return np.stack([-ky * factor, kx * factor, np.zeros_like(s), np.cos(0.5 * theta)], axis=-1)


def _chain(
    s: FloatArray, kx: FloatArray, ky: FloatArray
) -> Tuple[FloatArray, FloatArray, FloatArray]:
    """Compose segments; return per-segment tip positions (..., n, 3), tip rotations
    (..., n, 3, 3) and base rotations (..., n, 3, 3), all in the arm base frame."""
    positions, rotations = _segment_transform(s, kx, ky)
    batch = s.shape[:-1]
    n_segments = s.shape[-1]
    tips = np.empty(batch + (n_segments, 3))
    tip_rot = np.empty(batch + (n_segments, 3, 3))
    base_rot = np.empty(batch + (n_segments, 3, 3))
    current_p = np.zeros(batch + (3,))
    current_r = np.broadcast_to(np.eye(3), batch + (3, 3))
    for k in range(n_segments):
        base_rot[..., k, :, :] = current_r
        current_p = current_p + np.einsum("...ij,...j->...i", current_r, positions[..., k, :])
        current_r = current_r @ rotations[..., k, :, :]
        tips[..., k, :] = current_p
        tip_rot[..., k, :, :] = current_r
    return tips, tip_rot, base_rot


def _forward(lengths: FloatArray, d: FloatArray) -> FloatArray:
    s, kx, ky = _curvature(lengths, d)
    tips, _, _ = _chain(s, kx, ky)
    return tips[..., -1, :]


def _jacobian(lengths: FloatArray, d: FloatArray) -> Tuple[FloatArray, FloatArray]:
    """Return (tip position (..., 3), d tip / d lengths (..., 3, 3n))."""
    s, kx, ky = _curvature(lengths, d)
    d = np.broadcast_to(d, s.shape)
    tips, _, base_rot = _chain(s, kx, ky)
    tip = tips[..., -1, :]

    # Local derivatives of the segment map w.r.t. q = (s, kx, ky); arrays have shape (..., n).
    kappa2 = kx * kx + ky * ky
    u = s * s * kappa2
    theta, h, g, _ = _sinc_terms(u)
    dh, dg, b = _sinc_derivatives(u, theta, h, g)
    s2 = s * s
    du = (2.0 * s * kappa2, 2.0 * s2 * kx, 2.0 * s2 * ky)
    zero = np.zeros_like(s)
    # Position derivatives, columns (s, kx, ky).
    dpx = (
        kx * s * g + 0.5 * kx * s2 * dg * du[0],
        0.5 * s2 * g + 0.5 * kx * s2 * dg * du[1],
        0.5 * kx * s2 * dg * du[2],
    )
    dpy = (
        ky * s * g + 0.5 * ky * s2 * dg * du[0],
        0.5 * ky * s2 * dg * du[1],
        0.5 * s2 * g + 0.5 * ky * s2 * dg * du[2],
    )
    dpz = (h + s * dh * du[0], s * dh * du[1], s * dh * du[2])
    dp = np.stack([np.stack(dpx, -1), np.stack(dpy, -1), np.stack(dpz, -1)], axis=-2)
    # Angular velocity (segment base frame) from the left Jacobian of SO(3):
    # omega = J_l(w) dw/dq, J_l = I + (1 - cos t)/t^2 W + (t - sin t)/t^3 W^2, w = s(-ky, kx, 0).
    w_mat = _skew_xy(-s * ky, s * kx)
    j_left = np.eye(3) + (0.5 * g)[..., None, None] * w_mat + b[..., None, None] * (w_mat @ w_mat)
    dw = np.stack(
        [
            np.stack([-ky, zero, -s], axis=-1),
            np.stack([kx, s, zero], axis=-1),
            np.stack([zero, zero, zero], axis=-1),
        ],
        axis=-2,
    )
    omega = j_left @ dw  # (..., n, 3, 3), columns (s, kx, ky)

    # Into the arm base frame; the rotation of segment k moves everything distal to its tip.
    dp_world = base_rot @ dp
    omega_world = base_rot @ omega
    lever = tip[..., None, :] - tips  # (..., n, 3)
    rot_part = np.cross(np.swapaxes(omega_world, -1, -2), lever[..., None, :])
    j_q = dp_world + np.swapaxes(rot_part, -1, -2)  # (..., n, 3, 3)

    # Chain with d q / d lengths for each segment (rows s, kx, ky; columns chambers).
    inv_3s = 1.0 / (3.0 * s)
    coef = -2.0 / (3.0 * d * s)
    dq_dl = np.stack(
        [
            np.broadcast_to((1.0 / 3.0) * np.ones(3), s.shape + (3,)),
            coef[..., None] * _COS_SIGMA - (kx * inv_3s)[..., None],
            coef[..., None] * _SIN_SIGMA - (ky * inv_3s)[..., None],
        ],
        axis=-2,
    )
    blocks = j_q @ dq_dl  # (..., n, 3, 3): (xyz, chambers)
    jac = np.swapaxes(blocks, -3, -2).reshape(blocks.shape[:-3] + (3, -1))
    return tip, jac


# --------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------


def curvature_from_lengths(
    lengths: ArrayLike, d: DistanceLike
) -> Tuple[FloatArray, FloatArray, FloatArray]:
    """Arc length and curvature vector of every segment from its chamber lengths.

    Implements the length-to-configuration map of the CC model, Wang et al. 2023 (wang2023),
    eqs. (19)-(24), and Zou et al. 2022 (zou2022), eqs. (2)-(10), in the convention-free
    harmonic form ``s = mean(l)``, ``kx = -2/(3 d s) sum_i l_i cos(sigma_i)``,
    ``ky = -2/(3 d s) sum_i l_i sin(sigma_i)``.

    Args:
        lengths: Chamber lengths (m), shape (..., 3*n_segments), all finite and > 0.
        d: Chamber distance from the segment axis (m), a float or one value per segment.

    Returns:
        ``(s, kx, ky)``, each of shape (..., n_segments): arc length (m) and the curvature
        vector ``kappa * (cos phi, sin phi)`` (1/m).

    Raises:
        ValueError: on non-finite or non-positive ``lengths``, a last dimension that is not a
            multiple of 3, or ``d`` that is not finite and > 0.
    """
    array, n_segments = _validate_lengths(lengths)
    return _curvature(array, _validate_d(d, n_segments))


def lengths_from_curvature(
    s: ArrayLike, kx: ArrayLike, ky: ArrayLike, d: DistanceLike
) -> FloatArray:
    """Chamber lengths realising given segment arc lengths and curvature vectors.

    Exact inverse of :func:`curvature_from_lengths`:
    ``l_i = s * (1 - d * (kx cos(sigma_i) + ky sin(sigma_i)))``
    (Wang et al. 2023 (wang2023), eqs. (19)-(24); Zou et al. 2022 (zou2022), eqs. (2)-(10)).

    Args:
        s: Segment arc lengths (m), shape (..., n_segments), > 0.
        kx: Curvature component ``kappa cos(phi)`` (1/m), broadcastable with ``s``.
        ky: Curvature component ``kappa sin(phi)`` (1/m), broadcastable with ``s``.
        d: Chamber distance from the segment axis (m), float or one value per segment.

    Returns:
        Chamber lengths (m), shape (..., 3*n_segments).

    Raises:
        ValueError: on non-finite inputs, ``s <= 0``, ``d <= 0`` or a curvature so large that
            a chamber length would be non-positive (``d * kappa >= 1``).
    """
    s_arr, kx_arr, ky_arr = _validate_curvature(s, kx, ky, allow_zero_s=False)
    if s_arr.ndim == 0:
        s_arr, kx_arr, ky_arr = s_arr[None], kx_arr[None], ky_arr[None]
    d_arr = _validate_d(d, s_arr.shape[-1])
    lengths = _lengths(s_arr, kx_arr, ky_arr, d_arr)
    if np.any(lengths <= 0.0):
        kappa = np.hypot(kx_arr, ky_arr)
        dk = np.broadcast_to(d_arr, kappa.shape) * kappa
        raise ValueError(
            "kx, ky give a curvature too large for d: every chamber length "
            "s * (1 - d * kappa * cos(sigma_i - phi)) must be > 0, got a chamber length of "
            f"{float(np.min(lengths))!r} m with d * kappa up to {float(np.max(dk))!r}"
        )
    return lengths


def cc_segment_transform(
    s: ArrayLike, kx: ArrayLike, ky: ArrayLike
) -> Tuple[FloatArray, FloatArray]:
    """Tip pose of a single constant-curvature segment in its own base frame.

    Position ``(kx s^2/2 sinc^2(theta/2), ky s^2/2 sinc^2(theta/2), s sinc(theta))`` with
    ``theta = kappa s``; orientation = rotation by the rotation vector ``s (-ky, kx, 0)``
    (Wang et al. 2023 (wang2023), eqs. (19)-(24); Zou et al. 2022 (zou2022), eqs. (2)-(10)).
    Both are smooth through ``kappa = 0``.

    Args:
        s: Arc length (m), >= 0 (``s = 0`` gives the identity transform).
        kx: Curvature component ``kappa cos(phi)`` (1/m).
        ky: Curvature component ``kappa sin(phi)`` (1/m).
            ``s``, ``kx`` and ``ky`` are broadcast together to a shape ``(...)``.

    Returns:
        ``(position, rotation)`` with shapes (..., 3) in m and (..., 3, 3).
    """
    s_arr, kx_arr, ky_arr = _validate_curvature(s, kx, ky, allow_zero_s=True)
    return _segment_transform(s_arr, kx_arr, ky_arr)


@overload
def cc_forward(
    lengths: ArrayLike, d: DistanceLike, return_frames: Literal[False] = ...
) -> FloatArray: ...


@overload
def cc_forward(
    lengths: ArrayLike, d: DistanceLike, return_frames: Literal[True]
) -> Tuple[FloatArray, FloatArray, FloatArray]: ...


def cc_forward(
    lengths: ArrayLike, d: DistanceLike, return_frames: bool = False
) -> Union[FloatArray, Tuple[FloatArray, FloatArray, FloatArray]]:
    """Tip position of a multi-segment arm from its chamber lengths (forward kinematics).

    Each segment follows the CC model of Wang et al. 2023 (wang2023), eqs. (19)-(24), and
    Zou et al. 2022 (zou2022), eqs. (2)-(10); segment ``k+1`` starts at the tip frame of
    segment ``k``.

    Args:
        lengths: Chamber lengths (m), shape (..., 3*n_segments).
        d: Chamber distance from the segment axis (m), float or one value per segment.
        return_frames: Also return the tip rotation and every segment's tip position.

    Returns:
        Tip position (..., 3) in m, or, with ``return_frames=True``, the tuple
        ``(tip_position (..., 3), tip_rotation (..., 3, 3), segment_tip_positions
        (..., n_segments, 3))``, all expressed in the arm base frame.
    """
    array, n_segments = _validate_lengths(lengths)
    s, kx, ky = _curvature(array, _validate_d(d, n_segments))
    tips, tip_rot, _ = _chain(s, kx, ky)
    if return_frames:
        return tips[..., -1, :], tip_rot[..., -1, :, :], tips
    return tips[..., -1, :]


def cc_backbone(
    lengths: ArrayLike, d: DistanceLike, points_per_segment: int = 10
) -> FloatArray:
    """Points along the arm's backbone curve from base to tip.

    Within each segment the points are equally spaced in arc length, obtained by evaluating
    the CC segment map (Wang et al. 2023 (wang2023), eqs. (19)-(24)) at partial arc lengths
    ``j * s / points_per_segment`` with the segment's constant curvature.

    Args:
        lengths: Chamber lengths (m), shape (..., 3*n_segments).
        d: Chamber distance from the segment axis (m), float or one value per segment.
        points_per_segment: Number of intervals per segment, integer >= 1.

    Returns:
        Backbone points (m), shape (..., n_segments * points_per_segment + 1, 3); the first
        point is the base origin and the last one the tip.
    """
    if not _is_int(points_per_segment) or points_per_segment < 1:
        raise ValueError(
            f"points_per_segment must be an integer >= 1, got {points_per_segment!r}"
        )
    array, n_segments = _validate_lengths(lengths)
    s, kx, ky = _curvature(array, _validate_d(d, n_segments))
    tips, _, base_rot = _chain(s, kx, ky)
    fractions = np.arange(1, points_per_segment + 1) / points_per_segment
    batch = s.shape[:-1]
    points = [np.zeros(batch + (1, 3))]
    for k in range(n_segments):
        partial = s[..., k, None] * fractions  # (..., m)
        local = _segment_position(partial, kx[..., k, None], ky[..., k, None])  # (..., m, 3)
        base_p = np.zeros(batch + (3,)) if k == 0 else tips[..., k - 1, :]
        world = np.einsum("...ij,...mj->...mi", base_rot[..., k, :, :], local)
        points.append(world + base_p[..., None, :])
    return np.concatenate(points, axis=-2)


def cc_tip_pose(lengths: ArrayLike, d: DistanceLike) -> Tuple[FloatArray, FloatArray]:
    """Tip position and orientation quaternion of the arm.

    The orientation is the product of the segment rotations (rotation vectors
    ``s_k (-ky_k, kx_k, 0)``; Wang et al. 2023 (wang2023), eqs. (19)-(24); Zou et al. 2022
    (zou2022), eqs. (2)-(10)), composed as quaternions.

    Args:
        lengths: Chamber lengths (m), shape (..., 3*n_segments).
        d: Chamber distance from the segment axis (m), float or one value per segment.

    Returns:
        ``(position (..., 3) in m, quaternion (..., 4))``; the quaternion is scalar-last
        ``(x, y, z, w)``, unit-norm, with ``w >= 0``.
    """
    array, n_segments = _validate_lengths(lengths)
    s, kx, ky = _curvature(array, _validate_d(d, n_segments))
    tips, _, _ = _chain(s, kx, ky)
    quats = _segment_quaternion(s, kx, ky)
    quat = quats[..., 0, :]
    for k in range(1, n_segments):
        quat = quaternion_multiply(quat, quats[..., k, :])
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    quat = np.where(quat[..., 3:] < 0.0, -quat, quat)
    return tips[..., -1, :], quat


def cc_jacobian(lengths: ArrayLike, d: DistanceLike) -> FloatArray:
    """Analytic Jacobian of the tip position with respect to the chamber lengths.

    The derivative of the single-segment map (Wang et al. 2023 (wang2023), eqs. (19)-(24);
    Zou et al. 2022 (zou2022), eqs. (2)-(10)) with respect to ``(s, kx, ky)`` is written in
    terms of ``u = theta^2`` with Taylor series of the sinc terms near ``theta = 0``, so it is
    smooth and finite at the straight pose.  Orientation derivatives use the left Jacobian of
    SO(3).  These are chained with the linear-over-``s`` map lengths -> ``(s, kx, ky)``
    (including the ``1/s`` dependence of ``kx, ky``) and with the serial composition of the
    segment frames.

    Args:
        lengths: Chamber lengths (m), shape (..., 3*n_segments).
        d: Chamber distance from the segment axis (m), float or one value per segment.

    Returns:
        ``d tip_position / d lengths`` (dimensionless, m/m), shape (..., 3, 3*n_segments).
    """
    array, n_segments = _validate_lengths(lengths)
    _, jac = _jacobian(array, _validate_d(d, n_segments))
    return jac


def _single_arc(
    target: FloatArray,
) -> Tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Closed-form CC arc through the origin (tangent to +z) ending at ``target``.

    Returns ``(s, kx, ky, valid)``; ``valid`` is False where no finite arc exists (target at
    the origin or on the closed negative z half-axis).
    """
    px, py, pz = target[..., 0], target[..., 1], target[..., 2]
    chord2 = px * px + py * py + pz * pz
    r = np.hypot(px, py)
    half_theta = np.arctan2(r, pz)  # the chord makes half the bending angle with +z
    half_sinc = np.sinc(half_theta / np.pi)
    valid = (chord2 > 0.0) & (half_sinc > 0.0) & ~((r == 0.0) & (pz <= 0.0))
    chord2_safe = np.where(valid, chord2, 1.0)
    s = np.where(valid, np.sqrt(chord2_safe) / np.where(valid, half_sinc, 1.0), 1.0)
    kx = np.where(valid, 2.0 * px / chord2_safe, 0.0)
    ky = np.where(valid, 2.0 * py / chord2_safe, 0.0)
    return s, kx, ky, valid


def _limit_step(step: FloatArray, lengths: FloatArray, d: FloatArray) -> FloatArray:
    """Scale each length step so no segment changes its bending angle by more than
    ``_MAX_BEND_STEP`` rad or its arc length by more than ``_MAX_ARC_STEP`` of its value."""
    per_seg = step.reshape(step.shape[:-1] + (-1, 3))
    d_seg = np.broadcast_to(d, per_seg.shape[:-1])
    ds = per_seg.mean(axis=-1)
    harmonic_x = per_seg[..., 0] - 0.5 * (per_seg[..., 1] + per_seg[..., 2])
    harmonic_y = _SIN_SIGMA[1] * (per_seg[..., 1] - per_seg[..., 2])
    dtheta = np.hypot(harmonic_x, harmonic_y) * (2.0 / (3.0 * d_seg))
    s = lengths.reshape(per_seg.shape).mean(axis=-1)
    ratio = np.maximum(dtheta / _MAX_BEND_STEP, np.abs(ds) / (_MAX_ARC_STEP * s))
    scale = 1.0 / np.maximum(1.0, ratio.max(axis=-1))
    return step * scale[..., None]


def cc_inverse_single(target_position: ArrayLike, d: float) -> FloatArray:
    """Closed-form inverse kinematics of a single CC segment.

    The arc through the base origin, tangent to ``+z``, that ends at ``p`` has
    ``kappa = 2 r / |p|^2`` (``r = sqrt(px^2 + py^2)``), bending-plane direction ``(px, py)/r``
    and bending angle ``theta = 2 atan2(r, pz)``, hence ``kx = 2 px / |p|^2``,
    ``ky = 2 py / |p|^2`` and ``s = |p| / sinc(theta / 2)`` (``s = pz`` when straight).  The
    chamber lengths then follow from :func:`lengths_from_curvature` (Wang et al. 2023
    (wang2023), eqs. (19)-(24); Zou et al. 2022 (zou2022), eqs. (2)-(10)).

    Args:
        target_position: Desired tip position (m) in the base frame, shape (..., 3).
        d: Chamber distance from the segment axis (m), > 0.

    Returns:
        Chamber lengths (m), shape (..., 3).

    Raises:
        ValueError: if ``target_position`` is not finite, ``d <= 0``, or a target cannot be
            reached by one CC arc with positive chamber lengths (target at the origin or on the
            negative z half-axis, or ``d * kappa >= 1``).
    """
    target = _validate_target(target_position)
    d_arr = _validate_d(d, 1)
    s, kx, ky, valid = _single_arc(target)
    if not np.all(valid):
        value, index = _first_bad(target[..., 0], ~valid)
        raise ValueError(
            "target_position must not lie at the origin or on the negative z half-axis "
            f"(unreachable by a constant-curvature arc), got {target[index].tolist()} at "
            f"batch index {index}"
        )
    lengths = _lengths(s[..., None], kx[..., None], ky[..., None], d_arr)
    bad = np.any(lengths <= 0.0, axis=-1)
    if np.any(bad):
        _, index = _first_bad(target[..., 0], bad)
        raise ValueError(
            "target_position requires a curvature with d * kappa >= 1 (a non-positive chamber "
            f"length), got {target[index].tolist()} at batch index {index}"
        )
    return lengths


# --------------------------------------------------------------------------------------------
# cc_inverse: argument checks, initial guess, damped least squares, result
# --------------------------------------------------------------------------------------------

# Damping above which a target is given up (every recent step was rejected).
_MAX_DAMPING = 1e8
_EYE3: FloatArray = np.eye(3)


class _InverseProblem(NamedTuple):
    """The checked arguments of :func:`cc_inverse`, with the batch flattened to one axis."""

    target: FloatArray
    """Desired tip positions (m), shape (n_items, 3)."""
    batch: Tuple[int, ...]
    """The caller's batch shape (``target_position.shape[:-1]``)."""
    n_chambers: int
    """Chambers of the arm, ``3 * n_segments``."""
    d: FloatArray
    """Chamber distance from the segment axis (m), shape (n_items, n_segments)."""
    rest: FloatArray
    """Rest (straight) segment lengths (m), shape (n_segments,)."""
    lower: FloatArray
    """Lower bound on the chamber lengths (m), shape (n_items, n_chambers)."""
    upper: FloatArray
    """Upper bound on the chamber lengths (m), shape (n_items, n_chambers); may be ``inf``."""


def _validate_n_segments(n_segments: Any) -> int:
    """``n_segments`` as an int; raises ``ValueError`` unless it is an integer >= 1."""
    if not _is_int(n_segments) or n_segments < 1:
        raise ValueError(f"n_segments must be an integer >= 1, got {n_segments!r}")
    return int(n_segments)


def _broadcast_d(d: DistanceLike, n_segments: int, batch: Tuple[int, ...]) -> FloatArray:
    """Chamber distance ``d`` (m), checked and broadcast to one row per target: shape
    (prod(batch), n_segments)."""
    d_arr = _validate_d(d, n_segments)
    try:
        return np.broadcast_to(d_arr, batch + (n_segments,)).reshape(-1, n_segments)
    except ValueError as error:
        raise ValueError(
            f"d must be a float, one value per segment, or broadcastable to "
            f"{batch + (n_segments,)}, got shape {d_arr.shape}"
        ) from error


def _check_iteration_settings(
    damping: Any, max_iterations: Any, tolerance: Any, regularisation: Any
) -> None:
    """Raise ``ValueError`` unless ``damping >= 0`` (m/m), ``max_iterations >= 0`` (an
    integer), ``tolerance > 0`` (m) and ``regularisation`` in [0, 1]."""
    if not (_is_real(damping) and np.isfinite(damping) and damping >= 0.0):
        raise ValueError(f"damping must be a finite number >= 0, got {damping!r}")
    if not _is_int(max_iterations) or max_iterations < 0:
        raise ValueError(f"max_iterations must be an integer >= 0, got {max_iterations!r}")
    if not (_is_real(tolerance) and np.isfinite(tolerance) and tolerance > 0.0):
        raise ValueError(f"tolerance must be a finite number > 0, got {tolerance!r}")
    if not (_is_real(regularisation) and 0.0 <= regularisation <= 1.0):
        raise ValueError(f"regularisation must be within [0, 1], got {regularisation!r}")


def _broadcast_lengths(name: str, value: ArrayLike, shape: Tuple[int, ...]) -> FloatArray:
    """Chamber lengths ``value`` (m) as floats broadcast to ``shape`` (batch + (n_chambers,));
    not checked for sign or finiteness."""
    array = _as_float(name, value)
    try:
        return np.broadcast_to(array, shape)
    except ValueError as error:
        raise ValueError(
            f"{name} must be broadcastable to shape {shape}, got shape {array.shape}"
        ) from error


def _length_bound(
    name: str, value: Optional[ArrayLike], default: float, shape: Tuple[int, ...]
) -> FloatArray:
    """One bound on the chamber lengths (m) broadcast to ``shape``: ``default`` where ``value``
    is None; ``max_lengths`` may be ``inf`` but not NaN, every bound is > 0."""
    if value is None:
        return np.full(shape, default)
    array = _broadcast_lengths(name, value, shape)
    if name == "max_lengths":
        if np.any(np.isnan(array)):
            raise ValueError(f"{name} must not contain NaN, got {array.tolist()}")
        bad = array <= 0.0
        if np.any(bad):
            val, index = _first_bad(array, bad)
            raise ValueError(f"{name} must be > 0, got {val!r} at index {index}")
    else:
        _check_positive(name, array)
    return array


def _length_bounds(
    min_lengths: Optional[ArrayLike], max_lengths: Optional[ArrayLike], shape: Tuple[int, ...]
) -> Tuple[FloatArray, FloatArray]:
    """Lower and upper chamber-length bounds (m), each flattened to (n_items, n_chambers);
    the lower defaults to 1e-6 m, the upper to ``inf``, and lower <= upper everywhere."""
    n_chambers = shape[-1]
    lower = _length_bound("min_lengths", min_lengths, _DEFAULT_MIN_LENGTH, shape)
    upper = _length_bound("max_lengths", max_lengths, np.inf, shape)
    lower, upper = lower.reshape(-1, n_chambers), upper.reshape(-1, n_chambers)
    if np.any(lower > upper):
        raise ValueError(
            "min_lengths must be <= max_lengths element-wise, got min_lengths "
            f"{lower.max()!r} > max_lengths {upper.min()!r} somewhere"
        )
    return lower, upper


def _inverse_problem(
    target_position: ArrayLike,
    d: DistanceLike,
    n_segments: Any,
    rest_length: Union[float, Sequence[float]],
    min_lengths: Optional[ArrayLike],
    max_lengths: Optional[ArrayLike],
    damping: Any,
    max_iterations: Any,
    tolerance: Any,
    regularisation: Any,
) -> _InverseProblem:
    """Check the arguments of :func:`cc_inverse` (in the order of its signature, so that the
    first bad one is reported) and flatten them to one batch axis."""
    target = _validate_target(target_position)
    n_segments = _validate_n_segments(n_segments)
    n_chambers = 3 * n_segments
    batch = target.shape[:-1]
    d_full = _broadcast_d(d, n_segments, batch)
    rest = _validate_per_segment("rest_length", rest_length, n_segments)
    _check_iteration_settings(damping, max_iterations, tolerance, regularisation)
    lower, upper = _length_bounds(min_lengths, max_lengths, batch + (n_chambers,))
    return _InverseProblem(target.reshape(-1, 3), batch, n_chambers, d_full, rest, lower, upper)


def _split_single_arc(problem: _InverseProblem) -> FloatArray:
    """The single CC arc through each target (:func:`cc_inverse_single`) split over the segments
    in proportion to their rest lengths, which keeps its curvature in every segment (exact for
    the CC model, Wang et al. 2023 (wang2023), eqs. (19)-(24)); the straight rest pose where no
    such arc exists or a chamber length would not be positive. Chamber lengths (m), shape
    (n_items, n_chambers)."""
    rest_lengths = np.repeat(problem.rest, 3)
    arc_s, arc_kx, arc_ky, valid = _single_arc(problem.target)
    share = problem.rest / problem.rest.sum()
    seg_s = arc_s[:, None] * share
    guess = _lengths(seg_s, arc_kx[:, None], arc_ky[:, None], problem.d)
    valid = valid & np.all(guess > 0.0, axis=-1)
    return np.where(valid[:, None], guess, rest_lengths)


def _initial_guess(problem: _InverseProblem, initial_lengths: Optional[ArrayLike]) -> FloatArray:
    """Starting chamber lengths (m) of the iteration, shape (n_items, n_chambers), clipped to the
    bounds: ``initial_lengths`` (checked > 0) if given, else :func:`_split_single_arc`."""
    if initial_lengths is not None:
        init = _broadcast_lengths(
            "initial_lengths", initial_lengths, problem.batch + (problem.n_chambers,)
        )
        _check_positive("initial_lengths", init)
        lengths = init.reshape(-1, problem.n_chambers).copy()
    else:
        lengths = _split_single_arc(problem)
    return np.clip(lengths, problem.lower, problem.upper)


def _damped_step(
    lengths: FloatArray,
    d: FloatArray,
    error: FloatArray,
    lam: FloatArray,
    nu: FloatArray,
    reference: FloatArray,
) -> FloatArray:
    """One damped least-squares step (m) of the chamber lengths, trust-region limited
    (:func:`_limit_step`)::

        dl = J^T (J J^T + lambda^2 I)^-1 e + (I - J^+ J) * nu * (l_ref - l)

    with the analytic Jacobian ``J`` of the CC model (Wang et al. 2023 (wang2023),
    eqs. (19)-(24)), tip error ``e`` (m), damping ``lam`` and null-space gain ``nu`` per item.
    Shapes: ``lengths``, ``reference`` (n, n_chambers); ``d`` (n, n_segments); ``error`` (n, 3);
    ``lam``, ``nu`` (n,).
    """
    _, jac = _jacobian(lengths, d)
    jac_t = np.swapaxes(jac, -1, -2)
    system = jac @ jac_t + (lam**2 + 1e-18)[:, None, None] * _EYE3
    primary = (jac_t @ np.linalg.solve(system, error[..., None]))[..., 0]
    null = np.eye(lengths.shape[-1]) - np.linalg.pinv(jac, rcond=1e-10) @ jac
    secondary = (null @ (nu[:, None] * (reference - lengths))[..., None])[..., 0]
    return _limit_step(primary + secondary, lengths, d)


def _refine(
    problem: _InverseProblem,
    lengths: FloatArray,
    damping: float,
    max_iterations: int,
    tolerance: float,
    regularisation: float,
) -> Tuple[FloatArray, FloatArray, NDArray[np.int_]]:
    """Levenberg-Marquardt iteration of :func:`_damped_step` from ``lengths`` (also the
    null-space reference ``l_ref``), each step clipped to the bounds and accepted only if it
    reduces the tip error; ``lambda`` x10 after a rejected step, /10 (not below ``damping``)
    after an accepted one; ``nu`` x0.8 per iteration and x0.5 more after a rejection.

    Returns ``(lengths, residual, iterations)``: chamber lengths (m), shape
    (n_items, n_chambers), the final tip error (m) and the iterations taken, shape (n_items,).
    """
    target, d_full, lower, upper = problem.target, problem.d, problem.lower, problem.upper
    n_items = target.shape[0]
    reference = lengths.copy()
    error = target - _forward(lengths, d_full)
    residual = np.linalg.norm(error, axis=-1)
    lam = np.full(n_items, float(damping))
    nu = np.full(n_items, float(regularisation))
    iterations = np.zeros(n_items, dtype=int)
    for _ in range(max_iterations):
        active = np.flatnonzero((residual >= tolerance) & (lam < _MAX_DAMPING))
        if active.size == 0:
            break
        l_act = lengths[active]
        d_act = d_full[active]
        step = _damped_step(
            l_act, d_act, error[active], lam[active], nu[active], reference[active]
        )
        candidate = np.clip(l_act + step, lower[active], upper[active])
        cand_error = target[active] - _forward(candidate, d_act)
        cand_residual = np.linalg.norm(cand_error, axis=-1)
        accept = cand_residual < residual[active]
        iterations[active] += 1
        acc, rej = active[accept], active[~accept]
        lengths[acc] = candidate[accept]
        error[acc] = cand_error[accept]
        residual[acc] = cand_residual[accept]
        lam[acc] = np.maximum(lam[acc] / 10.0, damping)
        lam[rej] = np.maximum(lam[rej], 1e-6) * 10.0
        nu[active] *= _REGULARISATION_DECAY
        nu[rej] *= 0.5
    return lengths, residual, iterations


def _inverse_info(
    residual: FloatArray,
    iterations: NDArray[np.int_],
    batch: Tuple[int, ...],
    tolerance: float,
) -> Dict[str, Any]:
    """The ``info`` of :func:`cc_inverse`: ``'converged'``, ``'residual_m'`` (m) and
    ``'iterations'`` per target, in the caller's batch shape (Python scalars without a batch)."""
    converged = (residual < tolerance).reshape(batch)
    residual_out = residual.reshape(batch)
    iterations_out = iterations.reshape(batch)
    if batch == ():
        return {
            "converged": bool(converged),
            "residual_m": float(residual_out),
            "iterations": int(iterations_out),
        }
    return {"converged": converged, "residual_m": residual_out, "iterations": iterations_out}


@overload
def cc_inverse(
    target_position: ArrayLike,
    d: DistanceLike,
    n_segments: int = ...,
    rest_length: Union[float, Sequence[float]] = ...,
    initial_lengths: Optional[ArrayLike] = ...,
    min_lengths: Optional[ArrayLike] = ...,
    max_lengths: Optional[ArrayLike] = ...,
    damping: float = ...,
    max_iterations: int = ...,
    tolerance: float = ...,
    regularisation: float = ...,
    return_info: Literal[False] = ...,
) -> FloatArray: ...


@overload
def cc_inverse(
    target_position: ArrayLike,
    d: DistanceLike,
    n_segments: int = ...,
    rest_length: Union[float, Sequence[float]] = ...,
    initial_lengths: Optional[ArrayLike] = ...,
    min_lengths: Optional[ArrayLike] = ...,
    max_lengths: Optional[ArrayLike] = ...,
    damping: float = ...,
    max_iterations: int = ...,
    tolerance: float = ...,
    regularisation: float = ...,
    *,
    return_info: Literal[True],
) -> Tuple[FloatArray, Dict[str, Any]]: ...


def cc_inverse(
    target_position: ArrayLike,
    d: DistanceLike,
    n_segments: int = 1,
    rest_length: Union[float, Sequence[float]] = 0.1,
    initial_lengths: Optional[ArrayLike] = None,
    min_lengths: Optional[ArrayLike] = None,
    max_lengths: Optional[ArrayLike] = None,
    damping: float = 1e-3,
    max_iterations: int = 100,
    tolerance: float = 1e-7,
    regularisation: float = 0.1,
    return_info: bool = False,
) -> Union[FloatArray, Tuple[FloatArray, Dict[str, Any]]]:
    """Chamber lengths that place the arm tip at ``target_position``.

    Initial guess: ``initial_lengths`` if given; otherwise the single CC arc through the target
    (closed form, see :func:`cc_inverse_single`) split over the segments in proportion to
    ``rest_length`` -- an exact solution with equal curvature in every segment -- or the
    straight rest pose where no such arc exists.  The guess is clipped to the bounds and
    refined by damped least squares (Levenberg-Marquardt) on the analytic Jacobian
    (:func:`cc_jacobian`) of the CC model of Wang et al. 2023 (wang2023), eqs. (19)-(24), and
    Zou et al. 2022 (zou2022), eqs. (2)-(10)::

        dl = J^T (J J^T + lambda^2 I)^-1 e + (I - J^+ J) * nu * (l_ref - l)

    where ``e`` is the tip error and ``J^+`` the pseudo-inverse.  ``lambda`` starts at
    ``damping`` and adapts (x10 after a rejected step, /10 after an accepted one, never below
    ``damping``).  The null-space term pulls the redundant (multi-segment) solution toward the
    initial guess ``l_ref`` without moving the tip to first order, so the redundant case has a
    well-defined, deterministic answer close to ``l_ref``; its gain ``nu`` starts at
    ``regularisation`` and decays geometrically (x0.8 per iteration) so that the final
    iterations are plain Gauss-Newton steps and converge quickly.  Each step is scaled so that
    no segment changes its bending angle by more than 0.5 rad or its arc length by more than
    20 %, clipped to ``[min_lengths, max_lengths]``, and accepted only if it reduces the tip
    error.  For one segment (no redundancy) the closed-form guess is already exact and no
    iteration is needed unless the bounds are active.

    Args:
        target_position: Desired tip position (m), shape (..., 3), finite.
        d: Chamber distance from the segment axis (m), float or one value per segment.
        n_segments: Number of segments, integer >= 1.
        rest_length: Rest (straight) segment length (m), float or one value per segment; used
            for the fallback initial guess and for splitting the single-arc solution.
        initial_lengths: Optional initial chamber lengths (m), broadcastable to
            (..., 3*n_segments).
        min_lengths: Optional lower bound on chamber lengths (m), broadcastable to
            (..., 3*n_segments); defaults to 1e-6 m (lengths must stay positive).
        max_lengths: Optional upper bound on chamber lengths (m); defaults to no bound.
        damping: Initial and minimum damping ``lambda`` (dimensionless, m/m), >= 0.
        max_iterations: Maximum number of damped least-squares iterations, >= 0.
        tolerance: Tip position error (m) below which a solution counts as converged, > 0.
        regularisation: Initial null-space gain ``nu`` in [0, 1] toward the initial guess
            (0 disables the pull).
        return_info: Also return a dict with per-target ``'converged'`` (bool),
            ``'residual_m'`` (final tip error, m) and ``'iterations'`` (int).

    Returns:
        Chamber lengths (m), shape (..., 3*n_segments); with ``return_info=True`` the tuple
        ``(lengths, info)``.  Unreachable targets give the closest solution found and
        ``converged = False``.
    """
    problem = _inverse_problem(
        target_position, d, n_segments, rest_length, min_lengths, max_lengths,
        damping, max_iterations, tolerance, regularisation,
    )
    lengths = _initial_guess(problem, initial_lengths)
    lengths, residual, iterations = _refine(
        problem, lengths, damping, max_iterations, tolerance, regularisation
    )
    result = lengths.reshape(problem.batch + (problem.n_chambers,))
    if not return_info:
        return result
    return result, _inverse_info(residual, iterations, problem.batch, tolerance)
