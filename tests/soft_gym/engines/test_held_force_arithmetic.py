"""The held forces' cross product against numpy's, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.engines.pybullet.external_loads import cross3

pytestmark = pytest.mark.smoke


def test_cross3_is_numpys_cross_bit_for_bit():
    rng = np.random.default_rng(0)
    for scale in (1e-6, 1.0, 1e3):
        for a, b in zip(rng.normal(size=(2000, 3)) * scale, rng.normal(size=(2000, 3))):
            assert np.array_equal(cross3(a, b), np.cross(a, b))
    assert np.array_equal(cross3(np.zeros(3), np.ones(3)), np.cross(np.zeros(3), np.ones(3)))
