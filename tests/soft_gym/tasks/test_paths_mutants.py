"""Checks of ``soft_gym.tasks.paths`` that mutation testing found missing
(docs/mutation_testing.md).

Each test pins a documented behaviour that a surviving mutant changed unnoticed: errors name
the offending field first; repeated and closing points are dropped; the polygon sampler keeps
every vertex and rounds by largest remainder; the resampler's sample counts at exact multiples
of the spacing; the placement ``center + radius (x u + y v)``; field normalisation of
:class:`PathSpec`; and point-to-path distances on polylines with repeated vertices. References
are the docstrings' rules, worked out by hand here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.tasks.paths import (
    PathSpec,
    cycle_index,
    make_reference_trajectory,
    path_deviation,
    path_polyline,
    plane_basis,
    resample_constant_speed,
    unit_shape,
)

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def _polygon(m: int, radius: float = 0.05) -> np.ndarray:
    """A regular m-gon in the plane z = 0.1 (m), counter-clockwise."""
    angles = 2.0 * np.pi * np.arange(m) / m
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                            np.full(m, 0.1)])


def _spec(**changes) -> PathSpec:
    fields = {"shape": "circle", "center_m": (0.0, 0.0, 0.1), "radius_m": 0.02,
              "speed_m_s": 0.01}
    fields.update(changes)
    return PathSpec(**fields)


# ------------------------------------------------------------------------------------------
# Errors name the field first
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("call, message", [
    (lambda: resample_constant_speed(SQUARE, "x"), r"^spacing_m must be a positive finite number"),
    (lambda: resample_constant_speed([["a", "b"], ["c", "d"]], 0.1),
     r"^points must be a numeric array of shape \(n, d\)"),
    (lambda: resample_constant_speed([0.0, 1.0, 2.0], 0.1),
     r"^points must have shape \(n, d\) with d in \(2, 3\), got shape \(3,\)"),
    (lambda: resample_constant_speed(np.zeros((5, 4)), 0.1),
     r"^points must have shape \(n, d\) with d in \(2, 3\), got shape \(5, 4\)"),
    (lambda: resample_constant_speed([[0.0, 0.0, 0.0]], 0.1),
     r"^points must contain at least 2 points, got 1$"),
    (lambda: resample_constant_speed([[1.0, 2.0], [1.0, 2.0]], 0.1),
     r"^points must span a non-zero length \(all points coincide\)$"),
    (lambda: unit_shape("hexagon"),
     r"^unknown path 'hexagon' \(parameter 'name'\); path must be one of circle, pentagram, "
     r"rectangle, spiral, star$"),
    (lambda: unit_shape("circle", 8), r"^n_points must be an integer >= 16"),
    (lambda: plane_basis(("a", "b", "c")), r"^plane_normal must be 3 finite numbers"),
    (lambda: plane_basis((0.0, 0.0, 0.0)), r"^plane_normal must be non-zero"),
    (lambda: _spec(shape="hexagon"),
     r"^shape must be one of circle, pentagram, rectangle, spiral, star, waypoints, got "
     r"'hexagon'$"),
    (lambda: _spec(center_m=["a", "b", "c"]), r"^center_m must be 3 finite numbers"),
    (lambda: _spec(radius_m=-1.0), r"^radius_m must be a positive finite number"),
    (lambda: _spec(speed_m_s=0.0), r"^speed_m_s must be a positive finite number"),
    (lambda: _spec(plane_normal=(1.0, np.nan, 0.0)), r"^plane_normal must be 3 finite numbers"),
    (lambda: _spec(cycles=0), r"^cycles must be an integer >= 1"),
    (lambda: _spec(shape="waypoints"),
     r"^waypoints_m is required when shape='waypoints', got None$"),
    (lambda: _spec(shape="waypoints", waypoints_m=[["a", "b", "c"], ["d", "e", "f"]]),
     r"^waypoints_m must be a sequence of 3D points"),
    (lambda: _spec(shape="waypoints", waypoints_m=[[0.0, 0.0, 0.1]]),
     r"^waypoints_m must contain at least 2 points, got 1$"),
    (lambda: _spec(shape="waypoints", waypoints_m=[[0.0, 0.0, 0.1], [0.0, 0.0, 0.1]]),
     r"^waypoints_m must contain at least 2 distinct points"),
    (lambda: path_polyline("circle"), r"^spec must be a PathSpec"),
    (lambda: path_polyline(_spec(), 5), r"^n_points must be an integer >= 16, got 5"),
    (lambda: path_polyline(_spec(shape="waypoints", waypoints_m=_polygon(4)), 5),
     r"^n_points must be an integer >= 16, got 5"),
    (lambda: make_reference_trajectory("circle", 0.05), r"^spec must be a PathSpec"),
    (lambda: make_reference_trajectory(_spec(), -0.05),
     r"^control_period_s must be a positive finite number"),
    (lambda: cycle_index(0, 1), r"^trajectory_len must be an integer >= 1"),
    (lambda: cycle_index(6, 0), r"^cycles must be an integer >= 1"),
    (lambda: path_deviation(np.zeros((1, 3)), [[0.0, 0.0]]),
     r"^polyline_m must contain at least 2 points"),
    (lambda: path_deviation([["a", "b", "c"]], np.eye(3)), r"^points_m must be a numeric array"),
    (lambda: path_deviation(np.zeros((4, 2)), np.eye(3)),
     r"^points_m must have shape \(k, 3\) to match polyline_m, got shape \(4, 2\)$"),
    (lambda: path_deviation([[0.0, np.inf, 0.0]], np.eye(3)),
     r"^points_m must contain only finite values$"),
])
def test_errors_name_the_field_first(call, message: str) -> None:
    """Every rejected input raises ``ValueError`` starting with the field's name (the module's
    ``Raises`` sections: "naming the offending field and value")."""
    with pytest.raises(ValueError, match=message):
        call()


# ------------------------------------------------------------------------------------------
# PathSpec normalisation and placement
# ------------------------------------------------------------------------------------------


def test_pathspec_fields_are_normalised_to_plain_floats_and_tuples() -> None:
    """"Vector fields are normalised to tuples of floats on construction": arrays and numpy
    scalars come back as tuples, floats and ints."""
    spec = PathSpec("circle", np.array([0.0, 0.01, 0.1]), np.int64(1), np.float32(0.5),
                    plane_normal=[0, 0, 2], cycles=np.int64(2))
    assert spec.center_m == (0.0, 0.01, 0.1) and type(spec.center_m) is tuple
    assert spec.plane_normal == (0.0, 0.0, 2.0) and type(spec.plane_normal) is tuple
    assert type(spec.radius_m) is float and type(spec.speed_m_s) is float
    assert spec.cycles == 2 and type(spec.cycles) is int


def test_built_in_shapes_are_placed_at_center_plus_radius_times_u_and_v() -> None:
    """``center_m + radius_m * (x u + y v)``: the circle starts at ``center + r u`` and passes
    ``center + r v`` a quarter of the way round (``u, v`` from :func:`plane_basis`)."""
    spec = _spec(center_m=(0.01, -0.02, 0.1), radius_m=0.03, plane_normal=(0.0, 1.0, 1.0))
    u, v, _ = plane_basis(spec.plane_normal)
    points = path_polyline(spec, 400)
    center = np.array(spec.center_m)
    np.testing.assert_allclose(points[0], center + 0.03 * u, atol=1e-15)
    np.testing.assert_allclose(points[100], center + 0.03 * v, atol=1e-15)


def test_star_starts_with_its_top_tip() -> None:
    """"first tip at the top": the star outline starts at (0, 1) and its first inner vertex is
    at radius 0.4, 36 degrees further counter-clockwise (20 points on 10 equal edges: two per
    edge, the vertex and the midpoint)."""
    star = unit_shape("star", 20)
    np.testing.assert_allclose(star[0], [0.0, 1.0], atol=1e-15)
    angle = math.radians(90.0 + 36.0)
    np.testing.assert_allclose(star[2], [0.4 * math.cos(angle), 0.4 * math.sin(angle)],
                               atol=1e-15)


# ------------------------------------------------------------------------------------------
# Waypoints: repeated points and vertex-preserving sampling
# ------------------------------------------------------------------------------------------


def test_repeated_and_closing_waypoints_are_dropped() -> None:
    """Consecutive repeats and a last point equal to the first describe the same closed path:
    :func:`path_polyline` gives the same samples with or without them."""
    square = [[0.0, 0.0, 0.1], [0.02, 0.0, 0.1], [0.02, 0.02, 0.1], [0.0, 0.02, 0.1]]
    plain = path_polyline(_spec(shape="waypoints", waypoints_m=square), 40)
    noisy = square[:2] + [square[1]] + square[2:] + [square[3], square[0]]
    np.testing.assert_array_equal(
        path_polyline(_spec(shape="waypoints", waypoints_m=noisy), 40), plain)
    assert len(plain) == 40
    for vertex in square:
        assert np.any(np.all(plain == vertex, axis=1)), vertex


def test_many_waypoints_are_all_kept_even_above_n_points() -> None:
    """With more distinct waypoints (20) than ``n_points`` (16) the path is sampled with one
    point per waypoint (``max(n_points, number of distinct waypoints)``), i.e. the waypoints
    themselves, also when the list closes on its first point."""
    polygon = _polygon(20)
    for waypoints in (polygon, np.vstack([polygon, polygon[:1]])):
        points = path_polyline(_spec(shape="waypoints", waypoints_m=waypoints), 16)
        np.testing.assert_array_equal(points, polygon)


def test_two_waypoints_are_enough() -> None:
    """"at least 2 finite 3D points": a back-and-forth path between two points is valid."""
    spec = _spec(shape="waypoints", waypoints_m=[[0.0, 0.0, 0.1], [0.02, 0.0, 0.1]])
    points = path_polyline(spec, 16)
    assert points.shape == (16, 3)
    np.testing.assert_array_equal(points[0], [0.0, 0.0, 0.1])


def test_points_are_shared_out_by_largest_remainder() -> None:
    """A right triangle with edges 1, 1 and sqrt(2) (m) sampled with 16 points: the 13 points
    beyond the three vertices have shares 13 (1, 1, 1.414) / 3.414 = 3.81, 3.81 and 5.39;
    the floors 3, 3, 5 leave two, which go to the two largest remainders (0.81, 0.81), so the
    edges carry 5, 5 and 6 points, each starting at its vertex and evenly spaced."""
    a, b, c = np.array([0.0, 0.0, 0.1]), np.array([0.0, 1.0, 0.1]), np.array([0.0, 1.0, 1.1])
    points = path_polyline(_spec(shape="waypoints", waypoints_m=[a, b, c]), 16)
    assert points.shape == (16, 3)
    start = 0
    for count, (p, q) in zip((5, 5, 6), ((a, b), (b, c), (c, a))):
        expected = p + (np.arange(count) / count)[:, None] * (q - p)
        np.testing.assert_allclose(points[start:start + count], expected, atol=1e-15)
        start += count


# ------------------------------------------------------------------------------------------
# Resampling rules
# ------------------------------------------------------------------------------------------


def test_resampling_is_closed_by_default() -> None:
    """``closed=True`` is the default."""
    np.testing.assert_array_equal(resample_constant_speed(SQUARE, 0.3),
                                  resample_constant_speed(SQUARE, 0.3, closed=True))


def test_closed_count_at_an_exact_multiple_of_the_spacing() -> None:
    """Closed: samples strictly below the total length, so a 4 mm square at 10 um spacing gives
    exactly 400 samples; a spacing longer than the path gives the start point alone."""
    square = 1e-3 * SQUARE
    assert resample_constant_speed(square, 1e-5).shape == (400, 2)
    single = resample_constant_speed(square, 1.0)
    np.testing.assert_array_equal(single, square[:1])


def test_open_polyline_includes_its_end_at_a_multiple_of_the_spacing() -> None:
    """Open: "the end point is included only if the length is a multiple of s": 1 m at 0.1 m
    gives 11 samples ending on the end point; two points are enough."""
    line = np.array([[0.0, 0.0], [1.0, 0.0]])
    samples = resample_constant_speed(line, 0.1, closed=False)
    assert samples.shape == (11, 2)
    np.testing.assert_allclose(samples[-1], [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(np.diff(samples[:, 0]), 0.1, atol=1e-12)


def test_spiral_small_and_its_closing_step() -> None:
    """The spiral works at the smallest size (16 points), and its closing step (last sample
    back to the start) is as long as its first step: equal arc spacing all round."""
    assert unit_shape("spiral", 16).shape == (16, 2)
    spiral = unit_shape("spiral", 2000)
    first = np.linalg.norm(spiral[1] - spiral[0])
    closing = np.linalg.norm(spiral[0] - spiral[-1])
    assert closing == pytest.approx(first, rel=1e-3), (first, closing)


def test_three_targets_per_cycle_are_enough() -> None:
    """At least 3 targets per cycle: a circle of circumference 2 pi r walked in three control
    periods gives exactly three targets."""
    spec = _spec(radius_m=0.03, speed_m_s=2.0 * math.pi * 0.03 / 3.0 / 0.05)
    assert make_reference_trajectory(spec, 0.05).shape == (3, 3)


# ------------------------------------------------------------------------------------------
# Point-to-path distance
# ------------------------------------------------------------------------------------------


def test_deviation_from_a_polyline_with_a_repeated_vertex() -> None:
    """A repeated vertex is a zero-length segment; distances stay exact (no NaN from 0 / 0)."""
    line = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    points = np.array([[0.5, -0.2, 0.0], [1.3, 0.5, 0.0], [1.0, 0.0, 0.4]])
    with np.errstate(all="ignore"):
        distances = path_deviation(points, line)
    np.testing.assert_allclose(distances, [0.2, 0.3, 0.4], atol=1e-15)


def test_deviation_of_one_point_is_a_scalar() -> None:
    """A single ``(d,)`` point gives a 0-d result."""
    distance = path_deviation(np.array([0.5, -0.2, 0.0]), np.eye(3))
    assert np.shape(distance) == ()
