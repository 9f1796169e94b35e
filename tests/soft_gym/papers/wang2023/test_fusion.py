"""Eq. (18) fusion: limits, continuity, convexity, slerp."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from soft_gym.papers.wang2023.fusion import PoseFusion, slerp
from soft_gym.papers.wang2023.pipeline import SensingPipeline
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.fbg import FBGFiber

CAMERA = (np.array([0.01, 0.0, 0.09]), Rotation.from_euler("x", 10, degrees=True).as_quat())
FEMP = (np.array([0.012, 0.002, 0.088]), Rotation.from_euler("y", 20, degrees=True).as_quat())


@pytest.mark.smoke
def test_camera_below_lower_bound_femp_above_upper_bound_or_lost():
    fusion = PoseFusion(1.0, 2.0)
    position, quaternion = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=0.5)
    np.testing.assert_array_equal(position, CAMERA[0])
    np.testing.assert_allclose(quaternion, CAMERA[1], atol=1e-12)
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=3.0)
    np.testing.assert_array_equal(position, FEMP[0])
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=0.1, lost=True)
    np.testing.assert_array_equal(position, FEMP[0])
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=float("inf"))
    np.testing.assert_array_equal(position, FEMP[0])


def test_blend_is_convex_and_continuous_at_both_bounds():
    fusion = PoseFusion(1.0, 2.0)
    errors = np.linspace(0.9, 2.1, 241)
    positions = np.array([fusion.fuse(*CAMERA, *FEMP, e)[0] for e in errors])
    assert np.abs(np.diff(positions, axis=0)).max() < 1e-4  # no jumps
    mid, _ = fusion.fuse(*CAMERA, *FEMP, 1.5)
    np.testing.assert_allclose(mid, 0.5 * (CAMERA[0] + FEMP[0]))


@pytest.mark.smoke
def test_slerp_matches_scipy():
    rotations = Rotation.from_quat([CAMERA[1], FEMP[1]])
    reference = Slerp([0, 1], rotations)
    for fraction in (0.0, 0.25, 0.5, 0.9, 1.0):
        ours = Rotation.from_quat(slerp(CAMERA[1], FEMP[1], fraction))
        assert (ours.inv() * reference([fraction])[0]).magnitude() < 1e-9


@pytest.mark.parametrize("lower, upper, name", [(-1.0, 2.0, "lower_px"), (2.0, 1.0, "upper_px")])
def test_bad_bounds_raise(lower, upper, name):
    with pytest.raises(ValueError, match=name):
        PoseFusion(lower, upper)


@pytest.mark.parametrize("options, name", [
    ({"n_init": 5}, "n_init"),
    ({"map_steps": -1}, "map_steps"),
    ({"map_steps": 2.5}, "map_steps"),
    ({"femp_prior": 1}, "femp_prior"),
])
def test_bad_sensing_pipeline_options_raise(options, name):
    with pytest.raises(ValueError, match=name):
        SensingPipeline(EyeInHandCamera(), FBGFiber(), **options)


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour of eq. (18) of wang2023 (corrected form) or of ``slerp``
# that a surviving mutant changed unnoticed: the shortest arc whatever the signs of the inputs,
# nearly parallel and identical quaternions, inputs that are not exactly unit, the gain
# ``K_S = 1 / (E_U - E_L)`` with bounds whose difference is not 1, ``lost=False`` by default, and
# equal bounds refused. References: scipy's ``Slerp`` and the piecewise formula of the module
# docstring written out here.
# ==========================================================================================


Q0 = Rotation.from_euler("xyz", [10, -5, 30], degrees=True).as_quat()
Q1 = Rotation.from_euler("xyz", [-20, 15, 80], degrees=True).as_quat()


def _reference(q0: np.ndarray, q1: np.ndarray, fraction: float) -> Rotation:
    return Slerp([0.0, 1.0], Rotation.from_quat([q0, q1]))([fraction])[0]


def _angle(q: np.ndarray, rotation: Rotation) -> float:
    return float((Rotation.from_quat(q).inv() * rotation).magnitude())


@pytest.mark.parametrize("fraction", [0.0, 0.3, 0.5, 1.0])
def test_slerp_takes_the_shortest_arc_whatever_the_signs(fraction: float) -> None:
    """``-q1`` is the same rotation as ``q1``: the interpolation is the same rotation, along
    the shorter arc (scipy's reference), and the returned quaternion is the same one."""
    assert Q0 @ Q1 > 0
    expected = slerp(Q0, Q1, fraction)
    flipped = slerp(Q0, -Q1, fraction)
    np.testing.assert_allclose(flipped, expected, rtol=0, atol=1e-12)
    assert _angle(flipped, _reference(Q0, Q1, fraction)) < 1e-9
    np.testing.assert_allclose(np.linalg.norm(flipped), 1.0, rtol=0, atol=1e-12)


def test_slerp_of_nearly_parallel_quaternions() -> None:
    """Quaternions 0.02 rad apart (dot product above 0.9995) interpolate along the arc to
    within 1e-6 rad, and the result is a unit quaternion."""
    q1 = (Rotation.from_quat(Q0) * Rotation.from_rotvec([0.012, -0.01, 0.01])).as_quat()
    assert abs(Q0 @ q1) > 0.9995
    for fraction in (0.0, 0.25, 0.6, 1.0):
        for a, b in ((Q0, q1), (Q0, -q1)):
            out = slerp(a, b, fraction)
            np.testing.assert_allclose(np.linalg.norm(out), 1.0, rtol=0, atol=1e-12)
            angle = _angle(out, _reference(Q0, q1, fraction))
            assert angle < 1e-6, f"fraction {fraction}: {angle:.3g} rad from the arc"


def test_slerp_of_a_quaternion_with_itself_is_that_quaternion() -> None:
    """Also for quaternions whose dot product with themselves is exactly 1 (no arc at all)."""
    for q in (Q1, np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.5, 0.5, -0.5, 0.5])):
        for fraction in (0.0, 0.4, 1.0):
            np.testing.assert_allclose(slerp(q, q, fraction), q, rtol=0, atol=1e-12)


def test_slerp_normalises_its_inputs() -> None:
    """Quaternions off unit length (a scaled or slightly drifted estimate) are normalised
    first: the result is that of the unit quaternions."""
    for fraction in (0.0, 0.35, 1.0):
        np.testing.assert_allclose(slerp(2.5 * Q0, 0.4 * Q1, fraction), slerp(Q0, Q1, fraction),
                                   rtol=0, atol=1e-12)


def test_weight_is_the_corrected_equation_18_for_the_default_bounds() -> None:
    """``K_S (e_S - E_L)`` clipped to [0, 1] with ``K_S = 1 / (E_U - E_L)``; with the
    defaults ``E_L = 0.88``, ``E_U = 1.0`` px it is one half at 0.94 px, a quarter at 0.91 px."""
    fusion = PoseFusion()
    for error, expected in ((0.5, 0.0), (0.88, 0.0), (0.91, 0.25), (0.94, 0.5), (0.97, 0.75),
                            (1.0, 1.0), (3.0, 1.0)):
        assert fusion.weight(error) == pytest.approx(expected, abs=1e-12), error
    assert fusion.trust_threshold_px == pytest.approx(0.94)
    assert fusion.weight(fusion.trust_threshold_px) == pytest.approx(0.5, abs=1e-12)


def test_weight_scales_with_the_width_of_the_band() -> None:
    """Bounds 1 px and 5 px: the weight rises by 1/4 per pixel."""
    fusion = PoseFusion(1.0, 5.0)
    for error in (1.0, 2.0, 3.5, 5.0):
        assert fusion.weight(error) == pytest.approx((error - 1.0) / 4.0, abs=1e-12), error


def test_tracking_is_not_lost_unless_said() -> None:
    """``lost`` defaults to ``False``: a good frame gives the camera alone, in ``weight`` and in
    ``fuse``."""
    fusion = PoseFusion()
    assert fusion.weight(0.5) == 0.0
    position, quaternion = fusion.fuse(np.array([0.01, 0.0, 0.1]), Q0,
                                       np.array([0.02, 0.01, 0.09]), Q1, 0.5)
    np.testing.assert_array_equal(position, [0.01, 0.0, 0.1])
    np.testing.assert_allclose(quaternion, Q0, rtol=0, atol=1e-12)


def test_equal_bounds_are_refused() -> None:
    """``E_L < E_U`` strictly: a zero-width band would make ``K_S`` infinite."""
    with pytest.raises(ValueError, match=r"^upper_px must be finite and > lower_px"):
        PoseFusion(1.0, 1.0)


def test_a_negative_lower_bound_is_named_first() -> None:
    with pytest.raises(ValueError, match=r"^lower_px must be"):
        PoseFusion(-0.5, 1.0)
