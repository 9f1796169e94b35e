"""Checks of ``soft_gym.kinematics`` that mutation testing found missing (docs/mutation_testing.md).

Each test pins a documented behaviour that a surviving mutant of the module changed without any
test noticing: the exact wording of the errors (each names its parameter first, so that a caller
can tell which argument was wrong), the boundaries the docstrings promise (``>= 0`` against
``> 0``, ``w >= 0``, bounds that may be equal), per-segment ``d``, the iteration and trust-region
rules of :func:`cc_inverse`, and the Taylor series of the sinc derivatives near the straight
pose. References are independent: closed-form arcs, exact rational Taylor coefficients, and the
rules as stated in the docstrings.
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

D = 5.1e-3  # chamber distance from the segment axis (m)
STRAIGHT = np.full(3, 0.1)


def arc_tip(s: float, kappa: float, phi: float) -> np.ndarray:
    """Tip of a constant-curvature arc by plain trigonometry."""
    theta = kappa * s
    r = (1.0 - math.cos(theta)) / kappa
    return np.array([r * math.cos(phi), r * math.sin(phi), math.sin(theta) / kappa])


# ------------------------------------------------------------------------------------------
# Error messages name the parameter first
# ------------------------------------------------------------------------------------------


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
