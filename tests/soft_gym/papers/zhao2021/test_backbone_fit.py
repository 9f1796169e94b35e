"""zhao2021 backbone fit (eqs. (7)-(10)) against exact constant-curvature backbones.

The reference backbones are written here from the arc formula (independent of the module): a
segment of bending angle ``theta``, bending-plane angle ``phi`` and length ``L`` has, at arc ``s``
with ``kappa = theta / L``, ``x = (1 - cos(kappa s)) / kappa cos(phi)``, ``y = ... sin(phi)``,
``z = sin(kappa s) / kappa``; segment 2 is chained with segment 1's end rotation (axis
``(-sin phi, cos phi, 0)``, angle ``theta``). Key points at ``s = 0, 50, ..., 300 mm`` (two
150 mm segments, as in the paper); errors are eq. (21) on 60 arc-length-spaced points.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from soft_gym.kinematics import cc_backbone, lengths_from_curvature
from soft_gym.papers.zhao2021.backbone_fit import (BACKBONE_CURVES, fit_backbone,
                                                    mean_backbone_error_m, resample_by_arc_length)

CASCADE = "cubic_fallback"
"""The paper's curve with the cubic wherever it misses a key point (exact on these shapes)."""
SEGMENT_M = 0.15
KEY_S_M = np.linspace(0.0, 2 * SEGMENT_M, 7)


def _arc(theta: float, phi: float, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) of one CC segment at arcs ``s`` and its end rotation."""
    axis = np.array([-np.sin(phi), np.cos(phi), 0.0])
    rotation = Rotation.from_rotvec(theta * axis).as_matrix()
    if abs(theta) < 1e-12:
        return np.stack([0 * s, 0 * s, s], axis=-1), rotation
    kappa = theta / SEGMENT_M
    radial = (1.0 - np.cos(kappa * s)) / kappa
    return np.stack([radial * np.cos(phi), radial * np.sin(phi), np.sin(kappa * s) / kappa],
                    axis=-1), rotation


def cc_points(segments: list[tuple[float, float]], s: np.ndarray) -> np.ndarray:
    """Backbone points at arcs ``s`` (m) of a two-segment arm, segments ``(theta, phi)`` rad."""
    s = np.asarray(s, dtype=float)
    out = np.zeros((len(s), 3))
    base, frame = np.zeros(3), np.eye(3)
    for k, (theta, phi) in enumerate(segments):
        last = k == len(segments) - 1
        mask = (s >= k * SEGMENT_M) & ((s <= (k + 1) * SEGMENT_M) if last
                                       else (s < (k + 1) * SEGMENT_M))
        local, _ = _arc(theta, phi, s[mask] - k * SEGMENT_M)
        out[mask] = base + local @ frame.T
        end, rotation = _arc(theta, phi, np.array([SEGMENT_M]))
        base, frame = base + frame @ end[0], frame @ rotation
    return out


def cc_tangent(segments: list[tuple[float, float]], s: float) -> np.ndarray:
    ahead, behind = cc_points(segments, np.array([s, s - 1e-6]))
    return (ahead - behind) / np.linalg.norm(ahead - behind)


def sample(segments: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Key points (7, 3) and a dense true backbone (601, 3)."""
    return cc_points(segments, KEY_S_M), cc_points(segments, np.linspace(0, 2 * SEGMENT_M, 601))


def deg(value: float) -> float:
    return float(np.radians(value))


def turning_angles_deg(points: np.ndarray) -> np.ndarray:
    steps = np.diff(points, axis=0)
    steps /= np.linalg.norm(steps, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(steps[1:] * steps[:-1], axis=1), -1.0, 1.0)))


TWO_SEGMENT_SHAPES = {
    "S 60/60 in one plane": [(deg(60), 0.0), (deg(60), np.pi)],
    "S 30/90 crossing back": [(deg(30), 0.0), (deg(90), np.pi)],
    "90 deg apart planes": [(deg(45), 0.0), (deg(60), np.pi / 2)],
    "small then large": [(deg(10), 0.0), (deg(60), np.pi / 2)],
    "120/120 curl": [(deg(120), 0.5), (deg(120), 0.5)],
    "120/120 S": [(deg(120), 0.5), (deg(120), 0.5 + np.pi)],
    "segment 2 only": [(0.0, 0.0), (deg(60), 1.0)],
}


def test_reference_matches_the_package_constant_curvature_backbone():
    segments = [(deg(50), 0.7), (deg(80), 2.9)]
    d = 0.01
    s = np.full(2, SEGMENT_M)
    kappa = np.array([t for t, _ in segments]) / SEGMENT_M
    phi = np.array([p for _, p in segments])
    lengths = lengths_from_curvature(s, kappa * np.cos(phi), kappa * np.sin(phi), d)
    package = cc_backbone(lengths, d, points_per_segment=3)
    np.testing.assert_allclose(cc_points(segments, KEY_S_M), package, atol=1e-9)


def test_straight_arm_is_exact():
    key_points, true = sample([(0.0, 0.0), (0.0, 0.0)])
    fit = fit_backbone(key_points)
    np.testing.assert_allclose(fit.points_m, resample_by_arc_length(true, 60), atol=1e-12)
    np.testing.assert_allclose(fit.tip_position_m, [0, 0, 0.3], atol=1e-12)
    np.testing.assert_allclose(fit.tip_tangent, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(fit.tip_quaternion, [0, 0, 0, 1], atol=1e-12)
    assert fit.methods == ("cubic",) * 3 and fit.fallback_subsegments == (1, 2, 3)
    assert all("nearly vertical" in sub.reason for sub in fit.subsegments)
    assert fit.length_m == pytest.approx(0.3, abs=1e-12)


@pytest.mark.parametrize("bend_deg, bound_mm", [(30, 0.2), (60, 0.3), (90, 0.6)])
@pytest.mark.parametrize("phi", [0.0, 1.0, 2.5, -2.2])
def test_single_plane_bends_are_well_within_the_paper_error(bend_deg, bound_mm, phi):
    # Measured 0.04 / 0.09 / 0.24 mm for 30 / 60 / 90 deg per segment (paper's FEM shapes at
    # xi = 0: 2.4-3.2 mm, Table II).
    segments = [(deg(bend_deg), phi), (deg(bend_deg), phi)]
    key_points, true = sample(segments)
    fit = fit_backbone(key_points, curve=CASCADE)
    assert mean_backbone_error_m(true, fit.points_m) < bound_mm * 1e-3
    assert np.max(fit.key_point_residuals_m) <= 1e-3
    angle = np.degrees(np.arccos(np.clip(fit.tip_tangent @ cc_tangent(segments, 0.3), -1, 1)))
    assert angle < 3.5  # measured up to 2.9 deg (90 + 90 deg)
    assert fit.length_m == pytest.approx(0.3, rel=2e-3)


@pytest.mark.parametrize("name", list(TWO_SEGMENT_SHAPES))
def test_two_segment_shapes_including_s_bends(name):
    # Measured <= 0.6 mm for every shape here.
    segments = TWO_SEGMENT_SHAPES[name]
    key_points, true = sample(segments)
    fit = fit_backbone(key_points, curve=CASCADE)
    assert mean_backbone_error_m(true, fit.points_m) < 1.2e-3
    assert np.max(fit.key_point_residuals_m) <= 1e-3
    angle = np.degrees(np.arccos(np.clip(fit.tip_tangent @ cc_tangent(segments, 0.3), -1, 1)))
    assert angle < 8.0
    dense = fit_backbone(key_points, n_points=300, curve=CASCADE)
    assert np.max(turning_angles_deg(dense.points_m)) < 3.0


def test_the_paper_isf_is_used_where_it_fits_and_the_fallback_is_reported():
    fit = fit_backbone(sample([(deg(30), 0.3), (deg(30), 0.3)])[0], curve=CASCADE)
    assert fit.methods == ("cubic", "isf", "isf")
    assert "constraints of eq. (10) bind" in fit.subsegments[0].reason
    for sub in fit.subsegments[1:]:
        d, e, f, g = sub.isf_defg
        assert d > 0 and f > 0 and sub.reason == ""
        assert sub.parabola_abc is not None and sub.cubic_coefficients_m is None
    curl = fit_backbone(sample(TWO_SEGMENT_SHAPES["120/120 curl"])[0], curve=CASCADE)
    assert "does not rise" in curl.subsegments[2].reason


@pytest.mark.parametrize("segments", [[(deg(30), 0.3), (deg(30), 0.3)],
                                      [(deg(20), 2.0), (deg(25), 2.6)]])
def test_isf_parameters_satisfy_eqs_8_to_10(segments):
    fit = fit_backbone(sample(segments)[0], curve=CASCADE)
    assert "isf" in fit.methods
    assert fit.subsegments[0].t_start_m == 0.0
    for previous, sub in zip(fit.subsegments[:-1], fit.subsegments[1:]):
        assert sub.t_start_m == previous.t_end_m > previous.t_start_m
    for sub in fit.subsegments:
        if sub.method != "isf":
            continue
        d, e, f, g = sub.isf_defg
        t0, t2 = sub.t_start_m, sub.t_end_m
        assert d > 0 and e < t0 and 2 * (t2 - e) < f  # constraints 1-3 of eq. (10)
        z = lambda t: d * np.log((t - e) / (f - (t - e))) + g  # noqa: E731  eq. (9)
        assert z(t0) == pytest.approx(sub.start_m[2], abs=1e-12)  # constraint 4
        assert z(t2) == pytest.approx(sub.end_m[2], abs=1e-9)
        a, b, c = sub.parabola_abc  # eq. (8) in the frame turned by frame_angle_rad
        turn = Rotation.from_euler("z", -sub.frame_angle_rad).as_matrix()
        x0, y0, _ = turn @ sub.start_m
        assert a * x0 ** 2 + b * x0 + c == pytest.approx(y0, abs=1e-12)
        # Choice (b): in a vertical plane through the axis t is sqrt(x^2 + y^2).
        if sub.start_m[0] != 0.0:
            assert t0 == pytest.approx(np.hypot(*sub.start_m[:2]), abs=1e-9)


def test_subsegments_join_with_continuous_position_and_tangent():
    for segments in [[(deg(60), 1.0), (deg(60), 1.0)], *TWO_SEGMENT_SHAPES.values()]:
        key_points = sample(segments)[0]
        fit = fit_backbone(key_points, curve=CASCADE)
        np.testing.assert_array_equal(fit.points_m[0], key_points[0])
        for previous, current in zip(fit.subsegments[:-1], fit.subsegments[1:]):
            np.testing.assert_array_equal(current.start_m, previous.end_m)
        # No kink anywhere, joints included (a 300-point resampling turns < 3 deg per step).
        dense = fit_backbone(key_points, n_points=300, curve=CASCADE)
    assert np.max(turning_angles_deg(dense.points_m)) < 3.0


def test_rotating_the_key_points_about_z_rotates_the_fit():
    for segments in [[(deg(70), 0.4), (deg(40), 2.0)], TWO_SEGMENT_SHAPES["S 30/90 crossing back"]]:
        key_points = sample(segments)[0]
        fit = fit_backbone(key_points)
        for angle in (0.3, 2.0, -1.2):
            rotation = Rotation.from_euler("z", angle).as_matrix()
            turned = fit_backbone(key_points @ rotation.T)
            np.testing.assert_allclose(turned.points_m, fit.points_m @ rotation.T, atol=1e-9)
            np.testing.assert_allclose(turned.tip_tangent, rotation @ fit.tip_tangent, atol=1e-9)
            assert turned.methods == fit.methods


def test_six_key_points_imply_the_origin():
    key_points = sample([(deg(50), 1.0), (deg(20), 3.0)])[0]
    np.testing.assert_array_equal(fit_backbone(key_points[1:]).points_m,
                                  fit_backbone(key_points).points_m)


def test_tip_quaternion_takes_z_to_the_tip_tangent():
    for segments in [[(deg(60), 1.0), (deg(60), 1.0)], *TWO_SEGMENT_SHAPES.values()]:
        fit = fit_backbone(sample(segments)[0])
        assert np.linalg.norm(fit.tip_tangent) == pytest.approx(1.0)
        assert np.linalg.norm(fit.tip_quaternion) == pytest.approx(1.0)
        np.testing.assert_allclose(Rotation.from_quat(fit.tip_quaternion).apply([0, 0, 1]),
                                   fit.tip_tangent, atol=1e-12)
        assert fit.tip_quaternion[2] == pytest.approx(0.0, abs=1e-15)  # no twist: smallest turn


def test_paper_table_iii_key_points_give_a_smooth_curve_through_them():
    key_points_mm = np.array([[0, 0, 0], [-0.1, 0.5, 49.6], [4.2, 4.9, 90.1], [3.8, 9.6, 133.2],
                              [-22.6, 19.9, 172.9], [-35.9, 35.2, 210.8],
                              [-58.7, 64.7, 248.5]])
    fit = fit_backbone(key_points_mm * 1e-3, n_points=300, curve=CASCADE)
    assert np.all(np.isfinite(fit.points_m))
    assert np.max(fit.key_point_residuals_m) <= 1e-3
    for k, point in enumerate(key_points_mm * 1e-3):
        assert np.min(np.linalg.norm(fit.points_m - point, axis=1)) < 1.1e-3, k
    polyline = np.sum(np.linalg.norm(np.diff(key_points_mm, axis=0), axis=1)) * 1e-3
    assert polyline <= fit.length_m < 1.03 * polyline
    assert np.max(turning_angles_deg(fit.points_m)) < 3.0


def test_key_point_noise_raises_the_error_only_modestly():
    # Table II: uniform noise U(-xi, xi) on every coordinate of P1..P6. Measured (150 random
    # two-segment shapes up to 120 deg per segment): mean 0.25 / 1.83 / 3.75 mm, worst 1.1 / 3.4
    # / 6.9 mm at xi = 0 / 2 / 4 mm -- the fitted backbone moves about as much as the key points
    # (mean key-point displacement ~0.96 xi), it does not amplify their error.
    rng = np.random.default_rng(1)
    shapes = [[(deg(60), 1.0), (deg(60), 1.0)], TWO_SEGMENT_SHAPES["S 60/60 in one plane"],
              TWO_SEGMENT_SHAPES["90 deg apart planes"], [(0.0, 0.0), (0.0, 0.0)]]
    means = {}
    for xi_mm in (0.0, 2.0, 3.0, 4.0):
        errors, displacements = [], []
        for segments in shapes:
            key_points, true = sample(segments)
            for _ in range(12 if xi_mm else 1):
                noise = rng.uniform(-xi_mm, xi_mm, (6, 3)) * 1e-3
                noisy = key_points.copy()
                noisy[1:] += noise
                fit = fit_backbone(noisy, curve=CASCADE)
                assert np.all(np.isfinite(fit.points_m))
                errors.append(mean_backbone_error_m(true, fit.points_m))
                displacements.append(np.mean(np.linalg.norm(noise, axis=1)))
        means[xi_mm] = float(np.mean(errors))
        assert np.max(errors) < 0.5e-3 + 2.5 * xi_mm * 1e-3
        assert means[xi_mm] < 0.5e-3 + 1.15 * float(np.mean(displacements))
    assert means[0.0] < means[2.0] < means[4.0]


@pytest.mark.smoke
def test_random_constant_curvature_shapes_property():
    # Seeded stand-in for a hypothesis property test (hypothesis is not installed): random
    # bends up to 120 deg per segment in any planes; measured worst 1.1 mm over 1500 shapes.
    rng = np.random.default_rng(7)
    for _ in range(150):
        segments = [(deg(rng.uniform(0, 120)), rng.uniform(-np.pi, np.pi)),
                    (deg(rng.uniform(0, 120)), rng.uniform(-np.pi, np.pi))]
        key_points, true = sample(segments)
        fit = fit_backbone(key_points, curve=CASCADE)
        assert np.all(np.isfinite(fit.points_m)) and np.all(np.isfinite(fit.tip_quaternion))
        assert mean_backbone_error_m(true, fit.points_m) < 1.5e-3, segments
        assert fit.length_m == pytest.approx(0.3, rel=0.01)
        np.testing.assert_allclose(fit.points_m[-1], fit.tip_position_m, atol=1e-15)
        assert np.linalg.norm(fit.tip_position_m - key_points[-1]) <= 1e-3


def test_the_paper_curve_is_the_default_and_fits_each_subsegment_in_its_own_frame():
    segments = [(deg(60), 0.8), (deg(45), 2.5)]
    key_points = sample(segments)[0]
    fit = fit_backbone(key_points)
    assert fit.methods == fit_backbone(key_points, curve="paper").methods
    tangent = np.array([0.0, 0.0, 1.0])
    for j, sub in enumerate(fit.subsegments):
        # eqs. (8) and (10): the subsegment starts on its key point P_{2j-2} with the slope the
        # previous one ended on; its frame's z is that tangent (the identity at the base)
        np.testing.assert_array_equal(sub.start_m, key_points[2 * j])
        np.testing.assert_allclose(sub.frame[:, 2], tangent, atol=1e-12)
        np.testing.assert_allclose(sub.frame.T @ sub.frame, np.eye(3), atol=1e-12)
        assert sub.method == "isf" and sub.t_start_m == 0.0
        d, e, f, g = sub.isf_defg
        t2 = sub.t_end_m
        assert d > 0 and e < 0.0 and 2 * (t2 - e) < f  # constraints 1-3 of eq. (10)
        z = lambda t: d * np.log((t - e) / (f - (t - e))) + g  # noqa: E731  eq. (9)
        assert z(0.0) == pytest.approx(0.0, abs=1e-12)  # constraint 4, in the frame
        # the start slope tan(89 deg), i.e. 1 deg off the frame's z (constraint 5 / Z'_1)
        slope = d * f / ((0.0 - e) * (f - (0.0 - e)))
        assert slope == pytest.approx(np.tan(np.radians(89.0)), rel=1e-9)
        assert z(t2) == pytest.approx((sub.end_m - sub.start_m) @ sub.frame[:, 2], abs=1e-9)
        tangent = sub.end_tangent
    # the bridges are where a subsegment's curve missed the key point the next one starts on
    np.testing.assert_allclose(fit.node_gaps_m, [sub.key_point_residuals_m[1]
                                                 for sub in fit.subsegments[:2]], atol=1e-12)
    np.testing.assert_allclose(fit.tip_position_m, fit.points_m[-1], atol=1e-15)


@pytest.mark.parametrize("bend_deg", [30, 60, 90])
@pytest.mark.parametrize("phi", [0.0, 2.5])
def test_the_paper_curve_is_within_the_papers_fit_error_on_bends(bend_deg, phi):
    # zhao2021 Table II: the paper's curve fits its FEM shapes within 2.42-3.18 mm at xi = 0.
    # Measured here 0.80 / 1.39 / 2.67 mm for 30 / 60 / 90 deg per segment.
    key_points, true = sample([(deg(bend_deg), phi), (deg(bend_deg), phi)])
    assert mean_backbone_error_m(true, fit_backbone(key_points).points_m) < 3.18e-3


def test_the_papers_curve_in_the_base_frame_misses_bends_back_towards_the_axis():
    # The convex ISF branch (constraint 3) can only flatten from the slope it starts with: in
    # the base frame the second half of an S-bend is out of its reach (measured 28.4 mm), in
    # the subsegment's own frame it is not (3.1 mm).
    key_points, true = sample(TWO_SEGMENT_SHAPES["S 60/60 in one plane"])
    base = fit_backbone(key_points, curve="paper_base_frame")
    own = fit_backbone(key_points)
    assert base.methods == ("isf", "isf", "isf")
    assert mean_backbone_error_m(true, base.points_m) > 10e-3
    assert mean_backbone_error_m(true, own.points_m) < 3.18e-3


@pytest.mark.parametrize("key_points", [
    np.zeros((7, 3)),
    np.array([[0, 0, 0]] + [[0.05 * k, 0, 0] for k in range(1, 7)], float),  # lying flat
    np.array([[0, 0, 0]] + [[0, 0, -0.05 * k] for k in range(1, 7)], float),  # pointing down
    np.array([[0, 0, 0], [0, 0, 0.05], [0, 0, 0.05], [0.01, 0, 0.1], [0.01, 0, 0.1],
              [0.01, 0.001, 0.1], [0.02, 0, 0.2]], float),  # repeated key points
    np.array([[0, 0, 0], [0.03, 0, 0.04], [-0.02, 0.01, 0.09], [0.04, -0.03, 0.12],
              [-0.05, 0.02, 0.14], [0.06, 0.05, 0.1], [-0.04, -0.06, 0.2]], float),  # zig-zag
])
def test_degenerate_key_points_never_give_nan(key_points):
    if np.allclose(key_points, 0.0):
        with pytest.raises(ValueError, match="key_points_m"):
            fit_backbone(key_points)
        return
    for curve in BACKBONE_CURVES:
        fit = fit_backbone(key_points, curve=curve)
        for array in (fit.points_m, fit.tip_position_m, fit.tip_tangent, fit.tip_quaternion):
            assert np.all(np.isfinite(array))
        assert np.linalg.norm(fit.tip_tangent) == pytest.approx(1.0)


@pytest.mark.parametrize("bad", [np.zeros((5, 3)), np.zeros((7, 2)), np.zeros(21),
                                 np.full((7, 3), np.nan), np.full((6, 3), np.inf), "points",
                                 np.ones((7, 3)) * 1j])
def test_bad_key_points_raise_naming_the_parameter(bad):
    with pytest.raises(ValueError, match="key_points_m"):
        fit_backbone(bad)


@pytest.mark.parametrize("kwargs, name", [({"n_points": 1}, "n_points"),
                                          ({"n_points": 2.5}, "n_points"),
                                          ({"n_points": True}, "n_points"),
                                          ({"tolerance_m": 0.0}, "tolerance_m"),
                                          ({"min_horizontal_extent_m": -1.0},
                                           "min_horizontal_extent_m"),
                                          ({"curve": "bezier"}, "curve"),
                                          ({"curve": 1}, "curve")])
def test_bad_options_raise_naming_the_parameter(kwargs, name):
    key_points = sample([(deg(30), 0.0), (deg(30), 0.0)])[0]
    with pytest.raises(ValueError, match=name):
        fit_backbone(key_points, **kwargs)


def test_resample_by_arc_length_spaces_points_evenly():
    polyline = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 1], [0, 2, 1]], float)
    points = resample_by_arc_length(polyline, 7)
    np.testing.assert_allclose(np.linalg.norm(np.diff(points, axis=0), axis=1), 0.5)
    np.testing.assert_array_equal(points[[0, -1]], polyline[[0, -1]])
    np.testing.assert_array_equal(resample_by_arc_length(np.zeros((3, 3)), 4), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="points_m"):
        resample_by_arc_length(np.zeros((1, 3)), 5)
    with pytest.raises(ValueError, match="n"):
        resample_by_arc_length(polyline, 1)


def test_mean_backbone_error_is_eq_21():
    true = np.stack([np.zeros(61), np.zeros(61), np.linspace(0, 0.3, 61)], axis=1)
    shifted = true + [0.002, 0.0, 0.0]
    assert mean_backbone_error_m(true, shifted) == pytest.approx(0.002)
    assert mean_backbone_error_m(true, true[::10]) == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(ValueError, match="fitted_points_m"):
        mean_backbone_error_m(true, np.full((5, 3), np.nan))
    with pytest.raises(ValueError, match="true_points_m"):
        mean_backbone_error_m(np.zeros((60, 2)), true)
    with pytest.raises(ValueError, match="n_points"):
        mean_backbone_error_m(true, true, n_points=0)
