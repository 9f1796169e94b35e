"""Tests for the constant-curvature kinematics in ``soft_gym.kinematics``.

References are computed independently with plain trigonometry: the classical arc
``((1 - cos th)/k cos phi, (1 - cos th)/k sin phi, sin th / k)`` and the homogeneous transform
``Rz(phi) Ry(theta) Rz(-phi)`` of a constant-curvature segment.
"""

from __future__ import annotations

import numpy as np
import pytest

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
