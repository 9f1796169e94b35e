"""The package's one quaternion module, (x, y, z, w) order, against scipy's Rotation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from soft_gym._quaternion import (axis_rotation, matrix_to_quaternion, quaternion_multiply,
                                  quaternion_to_matrix, rotation_vector_to_quaternion)

pytestmark = pytest.mark.smoke

ROTATIONS = Rotation.random(12, random_state=0)


def _same_rotation(a: np.ndarray, b: np.ndarray) -> None:
    """Equal up to the sign (q and -q are one rotation)."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    np.testing.assert_allclose(np.abs(np.sum(a * b, axis=-1)), 1.0, atol=1e-12)


@pytest.mark.parametrize("shape", [(), (12,), (3, 4)])
def test_matrix_conversions_keep_batch_shapes(shape):
    quaternions = ROTATIONS.as_quat().reshape(shape + (4,)) if shape else ROTATIONS[0].as_quat()
    matrices = quaternion_to_matrix(quaternions)
    assert matrices.shape == shape + (3, 3)
    expected = Rotation.from_quat(quaternions.reshape(-1, 4)).as_matrix().reshape(shape + (3, 3))
    np.testing.assert_allclose(matrices, expected, atol=1e-14)
    back = matrix_to_quaternion(matrices)
    assert back.shape == shape + (4,)
    _same_rotation(back.reshape(-1, 4), quaternions.reshape(-1, 4))


def test_product_is_rotation_composition_for_pairs_and_batches():
    q = ROTATIONS.as_quat()
    expected = (ROTATIONS[:6] * ROTATIONS[6:]).as_quat()
    batched = quaternion_multiply(q[:6], q[6:])
    _same_rotation(batched, expected)
    for i in range(6):
        pair = quaternion_multiply(tuple(q[i]), tuple(q[6 + i]))
        np.testing.assert_allclose(pair, batched[i], atol=1e-15)
    # broadcasting one quaternion against a batch
    np.testing.assert_allclose(quaternion_multiply(q[0][None], q[6:]),
                               np.array([quaternion_multiply(q[0], b) for b in q[6:]]),
                               atol=1e-15)


def test_rotation_vectors_and_axis_rotations():
    vectors = np.array([[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0], [0.01, -0.02, 0.005], [0.0, 2.0, 0.0]])
    quaternions = rotation_vector_to_quaternion(vectors)
    np.testing.assert_allclose(quaternions, Rotation.from_rotvec(vectors).as_quat(), atol=1e-15)
    assert np.all(quaternions[:, 3] >= 0.0)
    for axis in range(3):
        vector = np.zeros(3)
        vector[axis] = 0.7
        np.testing.assert_allclose(axis_rotation(axis, 0.7), rotation_vector_to_quaternion(vector),
                                   atol=1e-15)


def test_one_quaternion_is_scipys_matrix_bit_for_bit():
    """The single-quaternion path (plain floats) gives scipy's matrix exactly, for unit and
    slightly off-unit quaternions as PyBullet returns them."""
    rng = np.random.default_rng(1)
    quaternions = rng.normal(size=(5000, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1)[:, None]
    quaternions[::2] *= 1.0 + rng.normal(scale=1e-9, size=(2500, 1))
    quaternions[-1] = [0.0, 0.0, 0.0, 3.0]
    for quaternion in quaternions:
        expected = Rotation.from_quat(quaternion).as_matrix()
        assert np.array_equal(quaternion_to_matrix(quaternion), expected)
        assert np.array_equal(quaternion_to_matrix(tuple(quaternion)), expected)


@pytest.mark.parametrize("bad", [(0.0, 0.0, 0.0, 0.0), (np.nan, 0.0, 0.0, 1.0),
                                 (np.inf, 0.0, 0.0, 1.0)])
def test_one_degenerate_quaternion_is_refused(bad):
    with pytest.raises(ValueError, match="quaternion"):
        quaternion_to_matrix(bad)
