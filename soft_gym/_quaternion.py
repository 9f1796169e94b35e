"""Small quaternion helpers (x, y, z, w order, as scipy and PyBullet) for the simulator's hot path.

scipy's ``Rotation`` costs tens of microseconds per call on single rotations; these plain numpy
versions are used where a pose is read every control step.
"""

from __future__ import annotations

import math

import numpy as np


def quaternion_to_matrix(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4) in (x, y, z, w) order."""
    x, y, z, w = np.moveaxis(np.asarray(quaternions, dtype=float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def quaternion_multiply(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
    """Hamilton product ``a * b`` (rotation ``b`` applied first, in ``a``'s frame)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def axis_rotation(axis: int, angle_rad: float) -> tuple[float, float, float, float]:
    """Quaternion of a rotation by ``angle_rad`` about the x (0), y (1) or z (2) axis."""
    half = 0.5 * angle_rad
    vector = [0.0, 0.0, 0.0]
    vector[axis] = math.sin(half)
    return (vector[0], vector[1], vector[2], math.cos(half))
