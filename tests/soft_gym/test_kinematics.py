"""Tests for the constant-curvature kinematics in ``soft_gym.kinematics``.

References are computed independently with plain trigonometry: the classical arc
``((1 - cos th)/k cos phi, (1 - cos th)/k sin phi, sin th / k)`` and the homogeneous transform
``Rz(phi) Ry(theta) Rz(-phi)`` of a constant-curvature segment.
"""

from __future__ import annotations

import inspect
import math
import warnings
from fractions import Fraction

import numpy as np
import pytest

from soft_gym import kinematics
from soft_gym.kinematics import (
    CHAMBER_ANGLES,
    cc_backbone,
    cc_forward,
    cc_inverse,
    cc_inverse_single,
    cc_jacobian,
    cc_segment_transform,
    cc_tip_pose,
    curvature_from_lengths,
    lengths_from_curvature,
)
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD, CHAMBER_COS, CHAMBER_SIN

D = 5.1e-3  # chamber distance from the segment axis (m)
S_RANGE = (0.07, 0.16)  # segment arc lengths (m)
THETA_MAX = np.deg2rad(120.0)  # largest bending angle per segment (rad)


# ------------------------------------------------------------------------------------------
# Independent references
# ------------------------------------------------------------------------------------------


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def arc_tip(s: float, kappa: float, phi: float) -> np.ndarray:
    """Tip of a CC arc by plain trigonometry (straight segment when kappa == 0)."""
    if kappa == 0.0:
        return np.array([0.0, 0.0, s])
    theta = kappa * s
    r = (1.0 - np.cos(theta)) / kappa
    return np.array([r * np.cos(phi), r * np.sin(phi), np.sin(theta) / kappa])


def arc_transform(s: float, kappa: float, phi: float) -> np.ndarray:
    """4x4 homogeneous transform of a CC segment: Rz(phi) Ry(theta) Rz(-phi)."""
    transform = np.eye(4)
    transform[:3, :3] = rot_z(phi) @ rot_y(kappa * s) @ rot_z(-phi)
    transform[:3, 3] = arc_tip(s, kappa, phi)
    return transform


def chamber_lengths(s: float, kappa: float, phi: float, d: float = D) -> np.ndarray:
    """l_i = s (1 - d kappa cos(sigma_i - phi)) with sigma_i = 2 pi i / 3."""
    sigma = CHAMBER_ANGLES
    return s * (1.0 - d * kappa * np.cos(sigma - phi))


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def random_configs(rng: np.random.Generator, n: int, n_segments: int):
    """Random (s, kappa, phi) per segment, each of shape (n, n_segments)."""
    s = rng.uniform(*S_RANGE, size=(n, n_segments))
    theta = rng.uniform(0.0, THETA_MAX, size=(n, n_segments))
    phi = rng.uniform(-np.pi, np.pi, size=(n, n_segments))
    return s, theta / s, phi


def random_lengths(rng: np.random.Generator, n: int, n_segments: int) -> np.ndarray:
    s, kappa, phi = random_configs(rng, n, n_segments)
    out = np.empty((n, 3 * n_segments))
    for j in range(n):
        for k in range(n_segments):
            out[j, 3 * k : 3 * k + 3] = chamber_lengths(s[j, k], kappa[j, k], phi[j, k])
    return out


def central_difference_jacobian(lengths: np.ndarray, h: float = 1e-7) -> np.ndarray:
    n = lengths.shape[-1]
    jac = np.empty((3, n))
    for i in range(n):
        step = np.zeros(n)
        step[i] = h
        jac[:, i] = (cc_forward(lengths + step, D) - cc_forward(lengths - step, D)) / (2.0 * h)
    return jac


def straight_jacobian(segment_lengths: np.ndarray, d: float = D) -> np.ndarray:
    """Jacobian at the straight pose from small-angle geometry.

    A bend d_theta of segment k (d_theta_x = -2/(3d) sum_i dl_i cos sigma_i) moves its own tip
    by s_k d_theta / 2 and swings the distal length L_d by L_d d_theta.
    """
    sigma = CHAMBER_ANGLES
    n = len(segment_lengths)
    jac = np.zeros((3, 3 * n))
    for k in range(n):
        lever = 0.5 * segment_lengths[k] + np.sum(segment_lengths[k + 1 :])
        cols = slice(3 * k, 3 * k + 3)
        jac[0, cols] = -2.0 * np.cos(sigma) / (3.0 * d) * lever
        jac[1, cols] = -2.0 * np.sin(sigma) / (3.0 * d) * lever
        jac[2, cols] = 1.0 / 3.0
    return jac


# ------------------------------------------------------------------------------------------
# Straight pose and single-segment geometry
# ------------------------------------------------------------------------------------------


def test_chamber_angles() -> None:
    np.testing.assert_allclose(CHAMBER_ANGLES, [0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
    # one copy in the library: the actuation module's, read-only
    assert CHAMBER_ANGLES is CHAMBER_ANGLES_RAD and not CHAMBER_ANGLES.flags.writeable
    np.testing.assert_allclose(CHAMBER_COS, np.cos(CHAMBER_ANGLES), atol=1e-15)
    np.testing.assert_allclose(CHAMBER_SIN, np.sin(CHAMBER_ANGLES), atol=1e-15)


@pytest.mark.parametrize("n_segments", [1, 2, 3])
@pytest.mark.parametrize("length", [0.07, 0.115, 0.16])
def test_straight_pose(n_segments: int, length: float) -> None:
    lengths = np.full(3 * n_segments, length)
    tip, rotation, segment_tips = cc_forward(lengths, D, return_frames=True)
    np.testing.assert_allclose(tip, [0.0, 0.0, n_segments * length], atol=1e-15)
    np.testing.assert_allclose(rotation, np.eye(3), atol=1e-15)
    expected = np.array([[0.0, 0.0, (k + 1) * length] for k in range(n_segments)])
    np.testing.assert_allclose(segment_tips, expected, atol=1e-15)
    s, kx, ky = curvature_from_lengths(lengths, D)
    np.testing.assert_allclose(s, length)
    assert np.all(kx == 0.0) and np.all(ky == 0.0)
    position, quat = cc_tip_pose(lengths, D)
    np.testing.assert_allclose(position, tip)
    np.testing.assert_allclose(quat, [0.0, 0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(
        cc_jacobian(lengths, D), straight_jacobian(np.full(n_segments, length)), rtol=1e-12, atol=1e-12
    )


@pytest.mark.smoke
@pytest.mark.parametrize(
    "s, theta_deg, phi",
    [(0.1, 30.0, 0.0), (0.07, 120.0, 1.0), (0.16, 90.0, -2.5), (0.12, 5.0, np.pi), (0.09, 60.0, 2.0)],
)
def test_single_segment_matches_analytic_arc(s: float, theta_deg: float, phi: float) -> None:
    kappa = np.deg2rad(theta_deg) / s
    kx, ky = kappa * np.cos(phi), kappa * np.sin(phi)
    lengths = lengths_from_curvature(s, kx, ky, D)
    np.testing.assert_allclose(lengths, chamber_lengths(s, kappa, phi), rtol=1e-14)

    s_out, kx_out, ky_out = curvature_from_lengths(lengths, D)
    np.testing.assert_allclose(s_out, [s], rtol=1e-13)
    np.testing.assert_allclose(kx_out, [kx], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ky_out, [ky], rtol=1e-9, atol=1e-9)

    reference = arc_transform(s, kappa, phi)
    tip, rotation, _ = cc_forward(lengths, D, return_frames=True)
    np.testing.assert_allclose(tip, arc_tip(s, kappa, phi), atol=1e-14)
    np.testing.assert_allclose(rotation, reference[:3, :3], atol=1e-13)
    # The tip tangent follows the arc.
    theta = kappa * s
    tangent = [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]
    np.testing.assert_allclose(rotation[:, 2], tangent, atol=1e-13)

    position, matrix = cc_segment_transform(s, kx, ky)
    np.testing.assert_allclose(position, reference[:3, 3], atol=1e-14)
    np.testing.assert_allclose(matrix, reference[:3, :3], atol=1e-13)


@pytest.mark.smoke
def test_multi_segment_matches_transform_chain() -> None:
    rng = np.random.default_rng(1)
    for n_segments in (2, 3):
        s, kappa, phi = random_configs(rng, 10, n_segments)
        for j in range(10):
            lengths = np.concatenate(
                [chamber_lengths(s[j, k], kappa[j, k], phi[j, k]) for k in range(n_segments)]
            )
            transform = np.eye(4)
            expected_tips = []
            for k in range(n_segments):
                transform = transform @ arc_transform(s[j, k], kappa[j, k], phi[j, k])
                expected_tips.append(transform[:3, 3].copy())
            tip, rotation, segment_tips = cc_forward(lengths, D, return_frames=True)
            np.testing.assert_allclose(tip, transform[:3, 3], atol=1e-13)
            np.testing.assert_allclose(rotation, transform[:3, :3], atol=1e-12)
            np.testing.assert_allclose(segment_tips, np.array(expected_tips), atol=1e-13)
            position, quat = cc_tip_pose(lengths, D)
            np.testing.assert_allclose(position, tip)
            assert abs(np.linalg.norm(quat) - 1.0) < 1e-12 and quat[3] >= 0.0
            np.testing.assert_allclose(quat_to_matrix(quat), transform[:3, :3], atol=1e-12)


def test_lengths_curvature_roundtrip() -> None:
    rng = np.random.default_rng(2)
    lengths = random_lengths(rng, 50, 2)
    s, kx, ky = curvature_from_lengths(lengths, D)
    np.testing.assert_allclose(lengths_from_curvature(s, kx, ky, D), lengths, rtol=1e-13)
    d_per_segment = [D, 4.0e-3]
    s, kx, ky = curvature_from_lengths(lengths, d_per_segment)
    np.testing.assert_allclose(lengths_from_curvature(s, kx, ky, d_per_segment), lengths, rtol=1e-13)


def test_rotating_chamber_pattern_rotates_tip_by_plus_120_degrees() -> None:
    rng = np.random.default_rng(3)
    for lengths in random_lengths(rng, 20, 1):
        rotated = lengths[[2, 0, 1]]  # (l0, l1, l2) -> (l2, l0, l1)
        tip = cc_forward(lengths, D)
        np.testing.assert_allclose(cc_forward(rotated, D), rot_z(2.0 * np.pi / 3.0) @ tip, atol=1e-14)
        # ... and not by -120 degrees (the tips are well away from the z axis).
        assert np.linalg.norm(cc_forward(rotated, D) - rot_z(-2.0 * np.pi / 3.0) @ tip) > 1e-4


def test_lengthening_a_chamber_bends_away_from_it() -> None:
    base = np.full(3, 0.1)
    for i, sigma in enumerate(CHAMBER_ANGLES):
        lengths = base.copy()
        lengths[i] += 2e-3
        tip = cc_forward(lengths, D)
        direction = tip[:2] / np.linalg.norm(tip[:2])
        np.testing.assert_allclose(direction, [-np.cos(sigma), -np.sin(sigma)], atol=1e-12)
    lengths = base.copy()
    lengths[0] += 2e-3
    tip = cc_forward(lengths, D)
    assert tip[0] < -1e-3 and abs(tip[1]) < 1e-15


# ------------------------------------------------------------------------------------------
# Inverse kinematics
# ------------------------------------------------------------------------------------------


@pytest.mark.smoke
@pytest.mark.parametrize("n_segments", [1, 2])
def test_inverse_reaches_forward_mapped_targets(n_segments: int) -> None:
    rng = np.random.default_rng(4 + n_segments)
    targets = cc_forward(random_lengths(rng, 100, n_segments), D)
    lengths, info = cc_inverse(targets, D, n_segments=n_segments, return_info=True)
    assert lengths.shape == (100, 3 * n_segments)
    assert np.all(info["converged"])
    assert np.all(np.isfinite(lengths)) and np.all(lengths > 0.0)
    np.testing.assert_allclose(cc_forward(lengths, D), targets, atol=1e-6, rtol=0.0)
    assert np.all(info["residual_m"] < 1e-6)


@pytest.mark.parametrize("n_segments", [2, 3])
def test_inverse_damped_least_squares_from_straight_start(n_segments: int) -> None:
    rng = np.random.default_rng(10 + n_segments)
    targets = cc_forward(random_lengths(rng, 40, n_segments), D)
    initial = np.full(3 * n_segments, 0.11)
    lengths, info = cc_inverse(
        targets, D, n_segments=n_segments, initial_lengths=initial, return_info=True
    )
    assert np.all(info["converged"])
    assert np.all(info["iterations"] > 0)
    np.testing.assert_allclose(cc_forward(lengths, D), targets, atol=1e-6, rtol=0.0)


def test_inverse_recovers_single_segment_lengths() -> None:
    rng = np.random.default_rng(6)
    lengths = random_lengths(rng, 100, 1)
    targets = cc_forward(lengths, D)
    np.testing.assert_allclose(cc_inverse(targets, D), lengths, atol=1e-10)
    np.testing.assert_allclose(cc_inverse_single(targets, D), lengths, atol=1e-10)
    # The DLS refinement from a perturbed start also lands on the unique solution.
    start = lengths + rng.normal(0.0, 1e-3, size=lengths.shape)
    np.testing.assert_allclose(cc_inverse(targets, D, initial_lengths=start), lengths, atol=1e-6)


def test_inverse_single_straight_and_known_arc() -> None:
    np.testing.assert_allclose(cc_inverse_single([0.0, 0.0, 0.12], D), np.full(3, 0.12))
    s, kappa, phi = 0.1, np.deg2rad(100.0) / 0.1, 0.7
    lengths = cc_inverse_single(arc_tip(s, kappa, phi), D)
    np.testing.assert_allclose(lengths, chamber_lengths(s, kappa, phi), rtol=1e-12)


def test_inverse_respects_bounds_and_reports_unreachable() -> None:
    target = np.array([0.3, 0.0, 0.05])  # far beyond a 0.15 m segment
    lengths, info = cc_inverse(target, D, max_lengths=0.15, min_lengths=0.06, return_info=True)
    assert lengths.shape == (3,)
    assert np.all(lengths <= 0.15) and np.all(lengths >= 0.06)
    assert info["converged"] is False
    assert info["residual_m"] > 0.1
    reachable = cc_forward(np.array([0.1, 0.12, 0.11]), D)
    lengths, info = cc_inverse(reachable, D, max_lengths=0.15, min_lengths=0.06, return_info=True)
    assert info["converged"] is True
    np.testing.assert_allclose(cc_forward(lengths, D), reachable, atol=1e-6)


def test_inverse_batch_shape() -> None:
    rng = np.random.default_rng(7)
    targets = cc_forward(random_lengths(rng, 8, 2), D).reshape(2, 4, 3)
    lengths, info = cc_inverse(targets, D, n_segments=2, return_info=True)
    assert lengths.shape == (2, 4, 6)
    assert info["converged"].shape == (2, 4) and info["iterations"].shape == (2, 4)
    np.testing.assert_allclose(cc_forward(lengths, D), targets, atol=1e-6)


# ------------------------------------------------------------------------------------------
# Jacobian and continuity through the straight pose
# ------------------------------------------------------------------------------------------


@pytest.mark.smoke
@pytest.mark.parametrize("n_segments", [1, 2])
def test_jacobian_matches_central_differences(n_segments: int) -> None:
    rng = np.random.default_rng(8 + n_segments)
    poses = list(random_lengths(rng, 15, n_segments))
    straight = np.full(3 * n_segments, 0.1)
    poses += [straight, straight + rng.normal(0.0, 1e-6, size=straight.shape)]
    for lengths in poses:
        jac = cc_jacobian(lengths, D)
        reference = central_difference_jacobian(lengths)
        assert jac.shape == (3, 3 * n_segments)
        assert np.linalg.norm(jac - reference) <= 1e-6 * np.linalg.norm(reference)


def test_continuity_through_straight_pose() -> None:
    rng = np.random.default_rng(12)
    for n_segments in (1, 2):
        segment_lengths = rng.uniform(*S_RANGE, size=n_segments)
        straight = np.repeat(segment_lengths, 3)
        tip0 = np.array([0.0, 0.0, segment_lengths.sum()])
        jac0 = straight_jacobian(segment_lengths)
        direction = rng.normal(size=straight.shape)
        direction /= np.linalg.norm(direction)
        tip_errors, jac_errors = [], []
        for eps in 10.0 ** np.arange(-12, -2):
            lengths = straight + eps * direction
            tip, rotation, _ = cc_forward(lengths, D, return_frames=True)
            jac = cc_jacobian(lengths, D)
            assert np.all(np.isfinite(tip)) and np.all(np.isfinite(rotation))
            assert np.all(np.isfinite(jac))
            tip_errors.append(np.linalg.norm(tip - tip0))
            jac_errors.append(np.linalg.norm(jac - jac0) / np.linalg.norm(jac0))
            # Lipschitz-type bounds: both maps are smooth at the straight pose.
            assert tip_errors[-1] <= 50.0 * eps
            assert jac_errors[-1] <= 1e-10 + 5e3 * eps
        assert tip_errors[0] < 1e-10 and jac_errors[0] < 1e-8


# ------------------------------------------------------------------------------------------
# Batching
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(5, 3), (2, 4, 6)])
def test_batch_shapes_agree_with_per_item_calls(shape: tuple) -> None:
    rng = np.random.default_rng(13)
    n_segments = shape[-1] // 3
    batch = shape[:-1]
    lengths = random_lengths(rng, int(np.prod(batch)), n_segments).reshape(shape)

    tip, rotation, segment_tips = cc_forward(lengths, D, return_frames=True)
    position, quat = cc_tip_pose(lengths, D)
    jac = cc_jacobian(lengths, D)
    backbone = cc_backbone(lengths, D, points_per_segment=4)
    s, kx, ky = curvature_from_lengths(lengths, D)
    assert tip.shape == batch + (3,)
    assert rotation.shape == batch + (3, 3)
    assert segment_tips.shape == batch + (n_segments, 3)
    assert position.shape == batch + (3,) and quat.shape == batch + (4,)
    assert jac.shape == batch + (3, 3 * n_segments)
    assert backbone.shape == batch + (4 * n_segments + 1, 3)
    assert s.shape == kx.shape == ky.shape == batch + (n_segments,)
    assert lengths_from_curvature(s, kx, ky, D).shape == shape
    seg_p, seg_r = cc_segment_transform(s, kx, ky)
    assert seg_p.shape == batch + (n_segments, 3) and seg_r.shape == batch + (n_segments, 3, 3)

    for index in np.ndindex(*batch):
        item = lengths[index]
        item_tip, item_rot, item_tips = cc_forward(item, D, return_frames=True)
        np.testing.assert_allclose(tip[index], item_tip, rtol=1e-14, atol=1e-16)
        np.testing.assert_allclose(rotation[index], item_rot, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(segment_tips[index], item_tips, rtol=1e-14, atol=1e-16)
        np.testing.assert_allclose(quat[index], cc_tip_pose(item, D)[1], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(jac[index], cc_jacobian(item, D), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(backbone[index], cc_backbone(item, D, 4), rtol=1e-14, atol=1e-16)


# ------------------------------------------------------------------------------------------
# Backbone
# ------------------------------------------------------------------------------------------


def test_backbone_lies_on_arcs_with_equal_spacing() -> None:
    rng = np.random.default_rng(14)
    n_points = 8
    for n_segments in (1, 2):
        s, kappa, phi = random_configs(rng, 5, n_segments)
        for j in range(5):
            lengths = np.concatenate(
                [chamber_lengths(s[j, k], kappa[j, k], phi[j, k]) for k in range(n_segments)]
            )
            points = cc_backbone(lengths, D, points_per_segment=n_points)
            assert points.shape == (n_segments * n_points + 1, 3)
            np.testing.assert_array_equal(points[0], np.zeros(3))
            np.testing.assert_allclose(points[-1], cc_forward(lengths, D), atol=1e-15)
            base = np.eye(4)
            for k in range(n_segments):
                seg = points[k * n_points : (k + 1) * n_points + 1]
                for m in range(n_points + 1):
                    local = arc_tip(s[j, k] * m / n_points, kappa[j, k], phi[j, k])
                    expected = base[:3, :3] @ local + base[:3, 3]
                    np.testing.assert_allclose(seg[m], expected, atol=1e-14)
                # Equal chords <=> equal arc-length spacing on a circular arc.
                chords = np.linalg.norm(np.diff(seg, axis=0), axis=1)
                np.testing.assert_allclose(chords, chords[0], rtol=1e-10)
                step = s[j, k] / n_points
                expected_chord = 2.0 * np.sin(0.5 * kappa[j, k] * step) / kappa[j, k]
                np.testing.assert_allclose(chords, expected_chord, rtol=1e-10)
                base = base @ arc_transform(s[j, k], kappa[j, k], phi[j, k])


def test_backbone_straight() -> None:
    points = cc_backbone(np.full(6, 0.1), D, points_per_segment=5)
    expected = np.stack([np.zeros(11), np.zeros(11), np.linspace(0.0, 0.2, 11)], axis=-1)
    np.testing.assert_allclose(points, expected, atol=1e-15)


# ------------------------------------------------------------------------------------------
# Input validation
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: cc_forward([0.1, np.nan, 0.1], D), "lengths"),
        (lambda: cc_forward([0.1, np.inf, 0.1], D), "lengths"),
        (lambda: cc_forward([0.1, -0.1, 0.1], D), "lengths"),
        (lambda: cc_forward([0.1, 0.0, 0.1], D), "lengths"),
        (lambda: cc_forward([0.1, 0.1, 0.1, 0.1], D), "lengths"),
        (lambda: cc_forward(0.1, D), "lengths"),
        (lambda: cc_forward([0.1, 0.1, 0.1], 0.0), "d"),
        (lambda: cc_forward([0.1, 0.1, 0.1], -D), "d"),
        (lambda: cc_forward([0.1, 0.1, 0.1], np.nan), "d"),
        (lambda: cc_forward(np.full(6, 0.1), [D, D, D]), "d"),
        (lambda: curvature_from_lengths(np.full(5, 0.1), D), "lengths"),
        (lambda: curvature_from_lengths(np.full(3, 0.1), -1.0), "d"),
        (lambda: cc_jacobian([0.1, 0.1, np.nan], D), "lengths"),
        (lambda: cc_jacobian(np.full(3, 0.1), 0.0), "d"),
        (lambda: cc_tip_pose([0.1, -0.1, 0.1], D), "lengths"),
        (lambda: cc_backbone(np.full(4, 0.1), D), "lengths"),
        (lambda: cc_backbone(np.full(3, 0.1), D, points_per_segment=0), "points_per_segment"),
        (lambda: lengths_from_curvature(0.1, 0.0, 0.0, 0.0), "d"),
        (lambda: lengths_from_curvature(-0.1, 0.0, 0.0, D), "s"),
        (lambda: lengths_from_curvature(0.1, np.nan, 0.0, D), "kx"),
        (lambda: lengths_from_curvature(0.1, 1.2 / D, 0.0, D), "kx"),
        (lambda: cc_segment_transform(0.1, np.inf, 0.0), "kx"),
        (lambda: cc_inverse([0.0, np.nan, 0.1], D), "target_position"),
        (lambda: cc_inverse([0.0, 0.0, np.inf], D), "target_position"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], 0.0), "d"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, n_segments=0), "n_segments"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, initial_lengths=[0.1, -0.1, 0.1]), "initial_lengths"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths=0.2, max_lengths=0.1), "min_lengths"),
        (lambda: cc_inverse_single([0.0, np.nan, 0.1], D), "target_position"),
        (lambda: cc_inverse_single([0.0, 0.0, 0.1], -D), "d"),
        (lambda: cc_inverse_single([0.0, 0.0, -0.1], D), "target_position"),
    ],
)
def test_bad_inputs_raise_value_error_naming_parameter(call, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()


def test_error_message_contains_bad_value() -> None:
    with pytest.raises(ValueError, match=r"lengths.*-0\.25"):
        cc_forward([0.1, -0.25, 0.1], D)
    with pytest.raises(ValueError, match=r"d must be > 0, got -0\.003"):
        cc_forward([0.1, 0.1, 0.1], -0.003)
    with pytest.raises(ValueError, match=r"lengths.*last dimension 4"):
        cc_forward([0.1, 0.1, 0.1, 0.1], D)


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour that a surviving mutant of the module changed without any
# test noticing: the exact wording of the errors (each names its parameter first, so that a caller
# can tell which argument was wrong), the boundaries the docstrings promise (``>= 0`` against
# ``> 0``, ``w >= 0``, bounds that may be equal), per-segment ``d``, the iteration and trust-region
# rules of :func:`cc_inverse`, and the Taylor series of the sinc derivatives near the straight pose.
# References are independent: closed-form arcs, exact rational Taylor coefficients, and the rules as
# stated in the docstrings.
# ==========================================================================================


STRAIGHT = np.full(3, 0.1)


# ------------------------------------------------------------------------------------------
# Error messages name the parameter first
# ------------------------------------------------------------------------------------------


@pytest.mark.smoke
@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: cc_forward(["a", "b", "c"], D), r"^lengths must be numeric array-like"),
        (lambda: cc_forward(0.1, D), r"^lengths must have shape \(\.\.\., 3\*n_segments\) .*got a "
                                     r"scalar"),
        (lambda: cc_forward(np.zeros((2, 0)), D), r"^lengths must have shape \(\.\.\., "
                                                  r"3\*n_segments\) with n_segments >= 1"),
        (lambda: cc_forward([0.1, -0.2, 0.1], D), r"^lengths must be > 0, got -0\.2 at index"),
        (lambda: cc_forward(STRAIGHT, "x"), r"^d must be numeric array-like"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, rest_length="x"),
         r"^rest_length must be numeric array-like"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, rest_length=[[0.1]]),
         r"^rest_length must be a float or a sequence of 1 values \(one per segment\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, rest_length=-0.1), r"^rest_length must be > 0"),
        (lambda: cc_inverse("x", D), r"^target_position must be numeric array-like"),
        (lambda: cc_inverse_single(0.1, D), r"^target_position must have shape \(\.\.\., 3\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1, 0.2], D),
         r"^target_position must have shape \(\.\.\., 3\)"),
        (lambda: cc_inverse_single([0.0, np.nan, 0.1], D), r"^target_position must be finite"),
        (lambda: cc_segment_transform("x", 0.0, 0.0), r"^s must be numeric array-like"),
        (lambda: cc_segment_transform(0.1, "x", 0.0), r"^kx must be numeric array-like"),
        (lambda: cc_segment_transform(0.1, 0.0, "x"), r"^ky must be numeric array-like"),
        (lambda: cc_segment_transform(np.nan, 0.0, 0.0), r"^s must be finite"),
        (lambda: cc_segment_transform(0.1, np.nan, 0.0), r"^kx must be finite"),
        (lambda: cc_segment_transform(0.1, 0.0, np.inf), r"^ky must be finite"),
        (lambda: cc_segment_transform(-0.1, 0.0, 0.0),
         r"^s must be >= 0 \(arc length in m\), got -0\.1"),
        (lambda: lengths_from_curvature(0.0, 0.0, 0.0, D),
         r"^s must be > 0 \(arc length in m\), got 0\.0"),
        (lambda: cc_segment_transform([0.1, 0.1], [0.0, 0.0, 0.0], 0.0),
         r"^s, kx and ky must have broadcastable shapes"),
        (lambda: lengths_from_curvature(0.1, 2.0, 0.0, 0.5),
         r"^kx, ky give a curvature too large for d: every chamber length "
         r"s \* \(1 - d \* kappa \* cos\(sigma_i - phi\)\) must be > 0, got a chamber length of "
         r"0\.0 m with d \* kappa up to 1\.0"),
        (lambda: cc_inverse_single([0.0, 0.0, 0.0], D),
         r"^target_position must not lie at the origin or on the negative z half-axis"),
        (lambda: cc_inverse_single([0.5, 0.0, 0.5], 0.5),
         r"^target_position requires a curvature with d \* kappa >= 1 \(a non-positive chamber "
         r"length\)"),
        (lambda: cc_inverse_single([[0.0, 0.0, 0.1], [0.5, 0.0, 0.5]], 0.5),
         r"^target_position requires .* got \[0\.5, 0\.0, 0\.5\] at batch index \(1,\)"),
        (lambda: cc_inverse_single([0.0, 0.0, 0.1], [D, D]),
         r"^d must be a float or have one value per segment"),
        (lambda: cc_inverse(np.zeros((2, 3)) + [0.0, 0.0, 0.1], np.full((5, 1), D)),
         r"^d must be a float, one value per segment, or broadcastable to \(2, 1\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, damping=np.inf),
         r"^damping must be a finite number >= 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, damping=True),
         r"^damping must be a finite number >= 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, max_iterations=-1),
         r"^max_iterations must be an integer >= 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, max_iterations=2.5),
         r"^max_iterations must be an integer >= 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, max_iterations=True),
         r"^max_iterations must be an integer >= 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, n_segments=True),
         r"^n_segments must be an integer >= 1"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, tolerance=np.inf),
         r"^tolerance must be a finite number > 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, tolerance=0.0),
         r"^tolerance must be a finite number > 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, tolerance=True),
         r"^tolerance must be a finite number > 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, regularisation=True),
         r"^regularisation must be within \[0, 1\]"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, regularisation=1.5),
         r"^regularisation must be within \[0, 1\]"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths="x"),
         r"^min_lengths must be numeric array-like"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths=[0.1, 0.1]),
         r"^min_lengths must be broadcastable to shape \(3,\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths=[0.1, np.nan, 0.1]),
         r"^min_lengths must be finite"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths=0.0), r"^min_lengths must be > 0"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, max_lengths=[0.1, np.nan, 0.1]),
         r"^max_lengths must not contain NaN"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, max_lengths=[0.1, 0.0, 0.1]),
         r"^max_lengths must be > 0, got 0\.0 at index \(1,\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, min_lengths=0.2, max_lengths=0.1),
         r"^min_lengths must be <= max_lengths element-wise"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, initial_lengths="x"),
         r"^initial_lengths must be numeric array-like"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, initial_lengths=[0.1, 0.1]),
         r"^initial_lengths must be broadcastable to shape \(3,\)"),
        (lambda: cc_inverse([0.0, 0.0, 0.1], D, initial_lengths=[0.1, -0.1, 0.1]),
         r"^initial_lengths must be > 0"),
        (lambda: cc_backbone(STRAIGHT, D, points_per_segment=True),
         r"^points_per_segment must be an integer >= 1"),
    ],
)
def test_errors_name_the_parameter_first(call, message: str) -> None:
    """Every rejected input raises ``ValueError`` whose message starts with the parameter's
    name and states the rule (reference: the ``Raises``/``Args`` sections of the docstrings)."""
    with pytest.raises(ValueError, match=message):
        call()


# ------------------------------------------------------------------------------------------
# Documented boundaries
# ------------------------------------------------------------------------------------------


def test_zero_arc_length_is_the_identity_transform_but_not_a_segment() -> None:
    """``cc_segment_transform`` accepts ``s = 0`` (identity); ``lengths_from_curvature`` needs
    ``s > 0`` (its docstring's ``Raises``)."""
    position, rotation = cc_segment_transform(0.0, 3.0, -2.0)
    np.testing.assert_array_equal(position, np.zeros(3))
    np.testing.assert_array_equal(rotation, np.eye(3))
    with pytest.raises(ValueError, match=r"^s must be > 0"):
        lengths_from_curvature(0.0, 3.0, -2.0, D)


def test_a_chamber_length_of_exactly_zero_is_rejected() -> None:
    """``d * kappa = 1`` towards chamber 0 makes its length exactly 0 (``d = 0.5``,
    ``kappa = 2``: exact in floating point); the docstrings require lengths > 0."""
    with pytest.raises(ValueError, match=r"^kx, ky give a curvature too large"):
        lengths_from_curvature(0.1, 2.0, 0.0, 0.5)
    # the arc of curvature 2 through 90 degrees ends at (0.5, 0, 0.5)
    np.testing.assert_allclose(arc_tip(math.pi / 4.0, 2.0, 0.0), [0.5, 0.0, 0.5], atol=1e-15)
    with pytest.raises(ValueError, match=r"^target_position requires a curvature"):
        cc_inverse_single([0.5, 0.0, 0.5], 0.5)


def test_per_segment_d_is_accepted_everywhere() -> None:
    """``d`` may hold one value per segment (``DistanceLike``); equal values give the same
    result as the scalar."""
    lengths = np.array([0.1, 0.11, 0.105, 0.102, 0.098, 0.1])
    per_segment = [D, D]
    np.testing.assert_array_equal(cc_forward(lengths, per_segment), cc_forward(lengths, D))
    np.testing.assert_array_equal(cc_backbone(lengths, per_segment), cc_backbone(lengths, D))
    for a, b in zip(cc_tip_pose(lengths, per_segment), cc_tip_pose(lengths, D)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(cc_jacobian(lengths, per_segment), cc_jacobian(lengths, D))
    target = cc_forward(lengths, D)
    np.testing.assert_allclose(cc_forward(cc_inverse(target, per_segment, n_segments=2), D),
                               target, atol=1e-7)


def test_backbone_default_resolution_and_one_interval() -> None:
    """Ten intervals per segment by default; ``points_per_segment = 1`` (allowed, >= 1) gives
    the base and the tip."""
    lengths = np.array([0.1, 0.11, 0.105])
    assert cc_backbone(lengths, D).shape == (11, 3)
    points = cc_backbone(lengths, D, points_per_segment=1)
    assert points.shape == (2, 3)
    np.testing.assert_array_equal(points[0], np.zeros(3))
    np.testing.assert_allclose(points[1], cc_forward(lengths, D), atol=1e-15)


def test_inverse_accepts_the_documented_edge_values() -> None:
    """``damping = 0``, ``regularisation`` 0 and 1, ``max_iterations = 0``, equal bounds and an
    infinite ``max_lengths`` are all valid (the ``Args`` section)."""
    lengths = np.array([0.1, 0.11, 0.105, 0.102, 0.098, 0.1])
    target = cc_forward(lengths, D)
    for options in ({"damping": 0.0}, {"regularisation": 0.0}, {"regularisation": 1.0},
                    {"max_lengths": np.inf}):
        solution = cc_inverse(target, D, n_segments=2, initial_lengths=STRAIGHT.repeat(2),
                              **options)
        np.testing.assert_allclose(cc_forward(solution, D), target, atol=1e-7, err_msg=options)
    np.testing.assert_array_equal(
        cc_inverse(target, D, n_segments=2, initial_lengths=STRAIGHT.repeat(2), max_iterations=0),
        STRAIGHT.repeat(2))
    np.testing.assert_array_equal(
        cc_inverse([0.0, 0.0, 0.1], D, min_lengths=0.12, max_lengths=0.12), np.full(3, 0.12))


def test_public_defaults_of_the_inverse() -> None:
    """The keyword defaults of :func:`cc_inverse` are part of its public interface: one segment,
    rest length 0.1 m, damping 1e-3, 100 iterations, tolerance 1e-7 m, regularisation 0.1."""
    parameters = inspect.signature(cc_inverse).parameters
    defaults = {name: parameters[name].default for name in
                ("n_segments", "rest_length", "damping", "max_iterations", "tolerance",
                 "regularisation")}
    assert defaults == {"n_segments": 1, "rest_length": 0.1, "damping": 1e-3,
                        "max_iterations": 100, "tolerance": 1e-7, "regularisation": 0.1}


# ------------------------------------------------------------------------------------------
# Initial guess of the inverse
# ------------------------------------------------------------------------------------------


def test_inverse_falls_back_to_the_rest_pose_where_no_arc_exists() -> None:
    """"the straight rest pose where no such arc exists": a target on the negative z axis, or
    one whose arc needs ``d * kappa >= 1``, starts from ``rest_length`` (0.1 m by default) in
    every chamber; the other targets of the batch keep their exact arcs."""
    reachable = arc_tip(0.1, 1.0, 0.3)
    targets = np.array([reachable, [0.0, 0.0, -0.05], [0.5, 0.0, 0.5]])
    guess = cc_inverse(targets, 0.5, max_iterations=0)
    np.testing.assert_allclose(guess[0], cc_inverse_single(reachable, 0.5), rtol=1e-12)
    np.testing.assert_array_equal(guess[1:], np.full((2, 3), 0.1))
    np.testing.assert_array_equal(
        cc_inverse([0.0, 0.0, -0.05], D, rest_length=0.08, max_iterations=0), np.full(3, 0.08))


def test_inverse_clips_the_initial_guess_to_the_bounds() -> None:
    """The guess is clipped to ``[min_lengths, max_lengths]`` before any iteration."""
    np.testing.assert_array_equal(
        cc_inverse([0.0, 0.0, 0.1], D, min_lengths=0.12, max_iterations=0), np.full(3, 0.12))


def test_inverse_info_for_a_single_target() -> None:
    """A single segment's closed-form guess is exact: ``info`` reports 0 iterations as an int
    (the docstring: "no iteration is needed unless the bounds are active")."""
    target = arc_tip(0.1, 6.0, 1.0)
    _, info = cc_inverse(target, D, return_info=True)
    assert info == {"converged": True, "residual_m": info["residual_m"], "iterations": 0}
    assert isinstance(info["iterations"], int) and info["residual_m"] < 1e-12
    _, batch = cc_inverse(np.array([target, target]), D, return_info=True)
    assert batch["iterations"].dtype.kind == "i", batch["iterations"].dtype


# ------------------------------------------------------------------------------------------
# Iterations of the inverse
# ------------------------------------------------------------------------------------------


def test_inverse_gives_up_once_the_damping_reaches_1e8() -> None:
    """With the lengths pinned by equal bounds every step is rejected, so ``lambda`` grows x10
    per iteration from ``damping`` and the solver stops when it reaches ``1e8``: 11 iterations
    from the default 1e-3 (``1e-3 * 10**11 = 1e8`` exactly), 14 from 0 (floored at 1e-6)."""
    target = np.array([0.01, 0.0, 0.09])
    for damping, expected in ((1e-3, 11), (0.0, 14)):
        lengths, info = cc_inverse(target, D, min_lengths=0.1, max_lengths=0.1, damping=damping,
                                   return_info=True)
        np.testing.assert_array_equal(lengths, STRAIGHT)
        assert info["iterations"] == expected and info["converged"] is False, (damping, info)


def test_one_iteration_is_a_full_gauss_newton_step_near_the_solution() -> None:
    """Close to a solution (1 um off) the trust region is inactive and the damping (1e-3)
    negligible, so one iteration cuts the tip error by more than 1000x (measured ~2e4-3e4),
    and a second one, with the null-space pull at its strongest (``regularisation = 1``),
    reaches rounding level: the pull must not move the tip."""
    rng = np.random.default_rng(0)
    for lengths in (np.array([0.1, 0.11, 0.105]), np.array([0.1, 0.11, 0.105, 0.102, 0.098,
                                                             0.1])):
        n_segments = len(lengths) // 3
        target = cc_forward(lengths, D)
        start = lengths + 1e-6 * rng.standard_normal(lengths.shape)
        before = np.linalg.norm(cc_forward(start, D) - target)
        residuals = [cc_inverse(target, D, n_segments=n_segments, initial_lengths=start,
                                max_iterations=k, tolerance=1e-18, regularisation=1.0,
                                return_info=True)[1]["residual_m"] for k in (1, 2)]
        assert before / residuals[0] > 1e3, (n_segments, before, residuals)
        assert residuals[1] < 1e-13, (n_segments, before, residuals)


def test_trust_region_limits_each_step() -> None:
    """"Each step is scaled so that no segment changes its bending angle by more than 0.5 rad
    or its arc length by more than 20 %": one iteration from the straight pose towards a
    strongly bent target lands exactly on that boundary, a pure extension to twice the length
    stops at +20 %, and each target of a batch is scaled on its own."""
    bent = arc_tip(0.1, math.pi / 2.0 / 0.1, 0.7)
    stretched = np.array([0.0, 0.0, 0.2])
    initial = np.array([STRAIGHT, np.full(3, 0.08)])
    batch = cc_inverse(np.array([bent, stretched]), D, initial_lengths=initial,
                       max_iterations=1, regularisation=0.0)
    for row, target, start in zip(batch, (bent, stretched), initial):
        single = cc_inverse(target, D, initial_lengths=start, max_iterations=1,
                            regularisation=0.0)
        np.testing.assert_allclose(row, single, rtol=1e-13)
    s, kx, ky = curvature_from_lengths(batch[0], D)
    bend_ratio = float(np.hypot(kx, ky)[0] * s[0]) / 0.5
    arc_ratio = abs(float(s[0]) - 0.1) / (0.2 * 0.1)
    assert max(bend_ratio, arc_ratio) == pytest.approx(1.0, abs=1e-9), (bend_ratio, arc_ratio)
    np.testing.assert_allclose(batch[1], np.full(3, 1.2 * 0.08), rtol=1e-12)


def test_lower_bound_holds_during_the_iterations() -> None:
    """A target whose solution needs a chamber shorter than ``min_lengths`` ends on the bound,
    never below it; the solver keeps making small accepted steps along the bound until the
    default cap of 100 iterations."""
    target = cc_forward(np.array([0.07, 0.13, 0.13]), D)
    for initial in (None, STRAIGHT):
        lengths, info = cc_inverse(target, D, initial_lengths=initial, min_lengths=0.09,
                                   return_info=True)
        assert np.all(lengths >= 0.09), lengths
        assert info["converged"] is False and info["iterations"] == 100, info


def test_null_space_pull_keeps_the_redundant_solution_near_the_initial_guess() -> None:
    """"The null-space term pulls the redundant (multi-segment) solution toward the initial
    guess": with it the solution is closer to the guess than without it (measured 8.7 against
    9.5 mm), and both reach the target."""
    target = cc_forward(np.array([0.1, 0.11, 0.105, 0.1, 0.1, 0.1]), D)
    start = STRAIGHT.repeat(2)
    distance = {}
    for regularisation in (0.0, 1.0):
        lengths = cc_inverse(target, D, n_segments=2, initial_lengths=start,
                             regularisation=regularisation)
        np.testing.assert_allclose(cc_forward(lengths, D), target, atol=1e-7)
        distance[regularisation] = np.linalg.norm(lengths - start)
    assert distance[1.0] < 0.97 * distance[0.0], distance


# ------------------------------------------------------------------------------------------
# Taylor series near the straight pose
# ------------------------------------------------------------------------------------------


def _series(u: float, term) -> float:
    """``sum_k term(k) u^k`` to 12 terms in exact rationals (u given as a float)."""
    x = Fraction(u)
    return float(sum(term(k) * x**k for k in range(12)))


def test_sinc_derivative_series_match_exact_taylor_expansions() -> None:
    """Below ``u = theta^2 = 1e-2`` the derivatives use stored Taylor coefficients; compare them
    with the expansions derived here, ``H = sum (-u)^k / (2k+1)!``, ``G = 2 (1 - cos theta) /
    theta^2 = 2 sum (-u)^k / (2k+2)!`` and ``B = (1 - H) / u``, summed exactly."""
    for u in (1e-6, 1e-3, 5e-3, 9.9e-3):
        theta, h, g, _ = kinematics._sinc_terms(np.array([u]))
        dh, dg, b = kinematics._sinc_derivatives(np.array([u]), theta, h, g)
        expected_dh = _series(u, lambda k: Fraction((-1) ** (k + 1) * (k + 1),
                                                    math.factorial(2 * k + 3)))
        expected_dg = _series(u, lambda k: Fraction(2 * (-1) ** (k + 1) * (k + 1),
                                                    math.factorial(2 * k + 4)))
        expected_b = _series(u, lambda k: Fraction((-1) ** k, math.factorial(2 * k + 3)))
        for name, got, expected in (("dH/du", dh, expected_dh), ("dG/du", dg, expected_dg),
                                    ("B", b, expected_b)):
            assert got[0] == pytest.approx(expected, rel=1e-14, abs=0.0), (name, u)


def test_straight_pose_raises_no_floating_point_warning() -> None:
    """The closed forms divide by ``u``; at the straight pose (``u = 0``) they must not be
    evaluated on it (no division-by-zero or invalid-value warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        jac = cc_jacobian(STRAIGHT, D)
    assert np.all(np.isfinite(jac))
