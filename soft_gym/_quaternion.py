"""The package's quaternion helpers: (x, y, z, w) order (scalar last, as scipy and PyBullet).

Every quaternion product and conversion of the package lives here. Conversions use scipy's
:class:`~scipy.spatial.transform.Rotation`; measured with scipy 1.17 (``constraints.txt``) it turns
1-24 quaternions into matrices in ~7 us against ~23 us for the plain numpy formula. One
quaternion (every physics substep that holds a force reads a link's) is turned by scipy's own
arithmetic in plain Python floats, bit for bit the same matrix, in ~2 us against ~18 us
(``tests/soft_gym/test_quaternion.py`` compares them). The product stays plain arithmetic:
``Rotation`` composition costs ~24 us per pair against ~2 us here, and the simulator composes tip
rotations at every pose read.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation


def quaternion_to_matrix(quaternions: Any) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from quaternions (..., 4) in (x, y, z, w) order.

    The quaternions are normalised first (scipy's ``Rotation.from_quat``).
    """
    array = np.asarray(quaternions, dtype=float)
    if array.shape == (4,):
        return _one_quaternion_to_matrix(*array.tolist())
    matrices = Rotation.from_quat(array.reshape(-1, 4)).as_matrix()
    return matrices.reshape(array.shape[:-1] + (3, 3))


def _one_quaternion_to_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """scipy's ``Rotation.from_quat(q).as_matrix()`` for one quaternion, operation for
    operation: normalised by its norm, then the same products, sums and differences."""
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 0.0 or not math.isfinite(norm):
        raise ValueError(f"a quaternion must be finite and non-zero, got {[x, y, z, w]}")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    return np.array([[x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
                     [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
                     [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2]])


def matrix_to_quaternion(matrices: Any) -> np.ndarray:
    """Unit quaternions (..., 4) in (x, y, z, w) order of rotation matrices (..., 3, 3).

    The sign is scipy's (either sign is the same rotation); near-orthogonal input is projected
    onto the nearest rotation.
    """
    array = np.asarray(matrices, dtype=float)
    if array.ndim == 2:
        return Rotation.from_matrix(array).as_quat()
    quaternions = Rotation.from_matrix(array.reshape(-1, 3, 3)).as_quat()
    return quaternions.reshape(array.shape[:-2] + (4,))


def rotation_vector_to_quaternion(vectors: Any) -> np.ndarray:
    """Unit quaternions (..., 4), (x, y, z, w), of rotation vectors (..., 3) (axis times angle,
    rad); ``w = cos(|v| / 2) >= 0`` for angles up to pi."""
    array = np.asarray(vectors, dtype=float)
    if array.ndim == 1:
        return Rotation.from_rotvec(array).as_quat()
    quaternions = Rotation.from_rotvec(array.reshape(-1, 3)).as_quat()
    return quaternions.reshape(array.shape[:-1] + (4,))


def quaternion_multiply(a: Any, b: Any) -> np.ndarray:
    """Hamilton product ``a * b`` (rotation ``b`` applied first, in ``a``'s frame).

    ``a`` and ``b`` are quaternions (..., 4) in (x, y, z, w) order that broadcast against each
    other; the result is an array (..., 4) (not normalised).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == 1 and b.ndim == 1:  # one pair (every pose read): Python floats are fastest
        ax, ay, az, aw = a.tolist()
        bx, by, bz, bw = b.tolist()
        return np.array([aw * bx + ax * bw + ay * bz - az * by,
                         aw * by - ax * bz + ay * bw + az * bx,
                         aw * bz + ax * by - ay * bx + az * bw,
                         aw * bw - ax * bx - ay * by - az * bz])
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def axis_rotation(axis: int, angle_rad: float) -> tuple[float, float, float, float]:
    """Quaternion of a rotation by ``angle_rad`` about the x (0), y (1) or z (2) axis."""
    half = 0.5 * angle_rad
    vector = [0.0, 0.0, 0.0]
    vector[axis] = math.sin(half)
    return (vector[0], vector[1], vector[2], math.cos(half))
