"""RSES, ``soft_gym.papers.zou2022.cc_shape`` (zou2022 eqs. 2-10), against analytic arcs: the
checks that mutation testing found missing (docs/mutation_testing.md; RSES beside the other
zou2022 estimators, and its bad input, is in test_zou2022_shape.py).

Each test pins a documented behaviour that a surviving mutant changed unnoticed: the points of a
*two*-segment arm with unequal rest lengths and chamber distances (material points at equal
fractions of the summed rest length, each segment stretched evenly), batches, other point counts,
``cc_shape``'s use of the rest lengths, and the refusals with their messages. Reference: the
chamber lengths are built from chosen arc parameters ``l_i = L (1 - d kappa cos(sigma_i - phi))``
(chamber ``i`` at ``sigma_i = 2 pi i / 3``), and the backbone is the analytic arc of each segment,
``((1 - cos kappa u) / kappa (cos phi, sin phi), sin(kappa u) / kappa)`` at arc ``u``, chained
through the rotation ``Rz(phi) Ry(kappa L) Rz(-phi)`` of each segment's tip frame.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from soft_gym.papers.zou2022.cc_shape import cc_shape, cc_shape_points

SIGMA = 2.0 * np.pi * np.arange(3) / 3.0
D = (0.010, 0.014)
ARCS = [  # (L, kappa, phi) of the two segments, for two readings
    [(0.12, 6.0, 0.4), (0.09, 9.0, -2.2)],
    [(0.15, 3.0, 2.8), (0.07, 12.0, 1.1)],
]


def _lengths(arcs, d) -> np.ndarray:
    return np.concatenate([L * (1.0 - dk * kappa * np.cos(SIGMA - phi))
                           for (L, kappa, phi), dk in zip(arcs, d)])


def _arc_point(L: float, kappa: float, phi: float, u: float) -> np.ndarray:
    radial = (1.0 - math.cos(kappa * u)) / kappa
    return np.array([radial * math.cos(phi), radial * math.sin(phi), math.sin(kappa * u) / kappa])


def _arc_turn(kappa: float, phi: float, u: float) -> np.ndarray:
    z = Rotation.from_rotvec([0.0, 0.0, phi])
    return (z * Rotation.from_rotvec([0.0, kappa * u, 0.0]) * z.inv()).as_matrix()


def _reference(arcs, rest, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Points at fractions ``k / (n - 1)`` of the summed rest length, and the tip rotation."""
    edges = np.r_[0.0, np.cumsum(rest)]
    points = []
    for k in range(n_points):
        target = k / (n_points - 1) * edges[-1]
        position, rotation = np.zeros(3), np.eye(3)
        for j, (L, kappa, phi) in enumerate(arcs):
            if target <= edges[j + 1] or j == len(arcs) - 1:
                u = (target - edges[j]) / rest[j] * L
                points.append(position + rotation @ _arc_point(L, kappa, phi, u))
                break
            position = position + rotation @ _arc_point(L, kappa, phi, L)
            rotation = rotation @ _arc_turn(kappa, phi, L)
    rotation = np.eye(3)
    for L, kappa, phi in arcs:
        rotation = rotation @ _arc_turn(kappa, phi, L)
    return np.array(points), rotation


@pytest.mark.smoke
@pytest.mark.parametrize("n_points", [2, 5, 7, 10])
def test_two_segments_with_unequal_rest_lengths_follow_the_chained_arcs(n_points: int) -> None:
    rest = (0.13, 0.05)    # the second segment is shorter at rest: fewer of the points on it
    lengths = np.stack([_lengths(arcs, D) for arcs in ARCS])
    points = cc_shape_points(lengths, D, rest_lengths_m=rest, n_points=n_points)
    assert points.shape == (2, n_points, 3)
    for b, arcs in enumerate(ARCS):
        expected, _ = _reference(arcs, rest, n_points)
        np.testing.assert_allclose(points[b], expected, rtol=0, atol=1e-12)


def test_equal_segments_by_default() -> None:
    lengths = _lengths(ARCS[0], D)
    expected, _ = _reference(ARCS[0], (1.0, 1.0), 7)
    np.testing.assert_allclose(cc_shape_points(lengths, D), expected, rtol=0, atol=1e-12)


def test_cc_shape_uses_the_rest_lengths_and_the_chained_tip_frame() -> None:
    rest = (0.11, 0.03)
    lengths = _lengths(ARCS[1], D)
    points, tip, quaternion = cc_shape(lengths, D, rest_lengths_m=rest)
    expected, rotation = _reference(ARCS[1], rest, 7)
    np.testing.assert_allclose(points, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tip, expected[-1], rtol=0, atol=1e-12)
    reference = Rotation.from_matrix(rotation).as_quat()
    reference = reference if reference[3] >= 0 else -reference
    np.testing.assert_allclose(quaternion, reference, rtol=0, atol=1e-12)
    # positional: the third argument is the rest lengths
    np.testing.assert_allclose(cc_shape(lengths, D, rest)[0], expected, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------- refusals
LENGTHS = _lengths(ARCS[0], D)


@pytest.mark.parametrize("rest", [(0.1,), (0.1, 0.1, 0.1), (0.1, math.nan), (0.1, math.inf),
                                  (0.1, 0.0), (-0.1, 0.1), ((0.1, 0.1),)])
def test_bad_rest_lengths_are_refused(rest) -> None:
    with pytest.raises(ValueError, match=r"^rest_lengths_m must be 2 finite lengths > 0 \(one per "
                                         r"segment\), got"):
        cc_shape_points(LENGTHS, D, rest_lengths_m=rest)


def test_rest_lengths_below_one_metre_are_accepted() -> None:
    points = cc_shape_points(LENGTHS, D, rest_lengths_m=[0.5, 0.5])
    np.testing.assert_allclose(points, cc_shape_points(LENGTHS, D), rtol=0, atol=1e-15)


def test_point_count_is_checked() -> None:
    with pytest.raises(ValueError, match=r"^n_points must be an integer >= 2, got 1"):
        cc_shape_points(LENGTHS, D, n_points=1)


@pytest.mark.parametrize("lengths, message", [
    (1j * np.ones(3), r"^lengths_m must be real chamber lengths \(m\), got"),
    ("l", r"^lengths_m must be chamber lengths \(m\) \(numbers\), got"),
    ([0.1, -0.1, 0.1], r"^lengths_m must be finite chamber lengths > 0 \(m\), got -0.1 at index"),
    (np.zeros((2, 0)), r"^lengths_m must have shape \(\.\.\., 3 n_segments\)"),
])
def test_bad_lengths_are_refused_with_what_was_expected(lengths, message) -> None:
    with pytest.raises(ValueError, match=message):
        cc_shape_points(lengths, 0.01)


@pytest.mark.parametrize("d, message", [
    (1j, r"^d_m must be real chamber distances from the axis \(m\), got"),
    ("d", r"^d_m must be chamber distances from the axis \(m\) \(numbers\), got"),
    ((0.01, -0.01), r"^d_m must be finite distances > 0 \(m\), got -0.01 at index \(1,\)"),
    ((0.01, 0.01, 0.01), r"^d_m must be one chamber distance \(m\) or one per segment \(2\), "
                         r"got shape \(3,\)"),
])
def test_bad_distances_are_refused_with_what_was_expected(d, message) -> None:
    with pytest.raises(ValueError, match=message):
        cc_shape_points(LENGTHS, d)
