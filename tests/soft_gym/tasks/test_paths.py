"""Tests for soft_gym.tasks.paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.tasks.paths import (
    PATH_SHAPES,
    RECTANGLE_HALF_EXTENTS,
    STAR_INNER_RADIUS,
    PathSpec,
    cycle_index,
    make_reference_trajectory,
    path_deviation,
    path_length,
    path_polyline,
    plane_basis,
    resample_constant_speed,
    unit_shape,
)

# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------


def _closed_steps(points: np.ndarray) -> np.ndarray:
    """Distances between consecutive points including last -> first."""
    return np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)


def _turning_vertices(points: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Indices of points of a closed polyline where the direction changes."""
    d_in = points - np.roll(points, 1, axis=0)
    d_out = np.roll(points, -1, axis=0) - points
    d_in /= np.linalg.norm(d_in, axis=1, keepdims=True)
    d_out /= np.linalg.norm(d_out, axis=1, keepdims=True)
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    dot = np.einsum("ij,ij->i", d_in, d_out)
    return np.flatnonzero((np.abs(cross) > tol) | (dot < 0.0))


def _signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _arc_position(points: np.ndarray, polyline: np.ndarray, closed: bool) -> np.ndarray:
    """Arc length along ``polyline`` of points known to lie on it."""
    ends = np.roll(polyline, -1, axis=0) if closed else polyline[1:]
    starts = polyline if closed else polyline[:-1]
    vec = ends - starts
    seg_len = np.linalg.norm(vec, axis=1)
    cum = np.concatenate(([0.0], np.cumsum(seg_len)))
    out = []
    for p in points:
        rel = p - starts
        t = np.clip(np.einsum("ij,ij->i", rel, vec) / seg_len**2, 0.0, 1.0)
        dist = np.linalg.norm(rel - t[:, None] * vec, axis=1)
        i = int(np.argmin(dist))
        assert dist[i] < 1e-12
        out.append(cum[i] + t[i] * seg_len[i])
    return np.array(out)


# ---------------------------------------------------------------------------
# unit shapes
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", PATH_SHAPES)
def test_unit_shape_closed_within_unit_disk(name: str) -> None:
    pts = unit_shape(name, 2000)
    assert pts.shape == (2000, 2)
    assert np.all(np.isfinite(pts))
    radius = np.linalg.norm(pts, axis=1)
    assert radius.max() <= 1.0 + 1e-12
    steps = _closed_steps(pts)
    # closed: the closing step is as short as the others, no repeated point
    assert steps[-1] <= 1.5 * np.max(steps[:-1])
    assert steps.min() > 0.0


@pytest.mark.parametrize("name", ["circle", "pentagram", "rectangle", "star"])
def test_unit_shape_counter_clockwise(name: str) -> None:
    assert _signed_area(unit_shape(name, 1000)) > 0.0


def test_circle_radius_and_start() -> None:
    pts = unit_shape("circle", 500)
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(pts[0], [1.0, 0.0], atol=1e-12)


def test_pentagram_vertices() -> None:
    pts = unit_shape("pentagram", 2000)
    idx = _turning_vertices(pts)
    assert idx.size == 5
    verts = pts[idx]
    np.testing.assert_allclose(np.linalg.norm(verts, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(pts[0], [0.0, 1.0], atol=1e-12)
    angles = np.degrees(np.arctan2(verts[:, 1], verts[:, 0]))
    # traversal order 0, 2, 4, 1, 3: each edge advances by 144 degrees
    step = np.mod(np.diff(np.concatenate((angles, angles[:1]))), 360.0)
    np.testing.assert_allclose(step, 144.0, atol=1e-9)
    spread = np.sort(np.mod(angles - 90.0, 360.0))
    np.testing.assert_allclose(spread, [0.0, 72.0, 144.0, 216.0, 288.0], atol=1e-9)
    # self-intersecting: the central pentagon is enclosed twice
    assert _signed_area(pts) > 1.1


def test_rectangle_extents() -> None:
    pts = unit_shape("rectangle", 2000)
    hx, hy = RECTANGLE_HALF_EXTENTS
    assert hx / hy == pytest.approx(5.0 / 3.0)
    assert math.hypot(hx, hy) == pytest.approx(1.0)
    np.testing.assert_allclose(pts.max(axis=0), [hx, hy], atol=1e-12)
    np.testing.assert_allclose(pts.min(axis=0), [-hx, -hy], atol=1e-12)
    idx = _turning_vertices(pts)
    assert idx.size == 4
    np.testing.assert_allclose(np.abs(pts[idx]), np.tile([hx, hy], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(pts[0], [hx, 0.0], atol=1e-12)


def test_star_vertices() -> None:
    pts = unit_shape("star", 2000)
    idx = _turning_vertices(pts)
    assert idx.size == 10
    radii = np.linalg.norm(pts[idx], axis=1)
    np.testing.assert_allclose(radii[0::2], 1.0, atol=1e-12)
    np.testing.assert_allclose(radii[1::2], STAR_INNER_RADIUS, atol=1e-12)
    angles = np.degrees(np.unwrap(np.arctan2(pts[idx, 1], pts[idx, 0])))
    np.testing.assert_allclose(np.diff(angles), 36.0, atol=1e-9)


def test_spiral_out_and_back() -> None:
    pts = unit_shape("spiral", 4000)
    r = np.linalg.norm(pts, axis=1)
    np.testing.assert_allclose(pts[0], [0.2, 0.0], atol=1e-12)
    assert r.min() == pytest.approx(0.2, abs=1e-9)
    assert r.max() == pytest.approx(1.0, abs=1e-3)
    # outbound leg: two counter-clockwise turns with radius growing linearly
    half = pts[: int(np.argmax(r)) + 1]
    theta = np.unwrap(np.arctan2(half[:, 1], half[:, 0]))
    assert np.all(np.diff(theta) > 0.0)
    assert theta[-1] == pytest.approx(4.0 * np.pi, abs=1e-2)
    np.testing.assert_allclose(
        np.linalg.norm(half, axis=1), 0.2 + 0.8 * theta / (4.0 * np.pi), atol=1e-6
    )
    # return leg retraces the outbound leg
    back = pts[int(np.argmax(r)) + 1 :]
    assert np.max(path_deviation(back, half)) < 1e-5


def test_unit_shape_bad_name() -> None:
    with pytest.raises(ValueError) as info:
        unit_shape("hexagon")
    msg = str(info.value)
    assert "path" in msg and "hexagon" in msg
    for name in PATH_SHAPES:
        assert name in msg


def test_unit_shape_bad_n_points() -> None:
    with pytest.raises(ValueError, match="n_points"):
        unit_shape("circle", 2)


# ---------------------------------------------------------------------------
# resampling
# ---------------------------------------------------------------------------


def test_resample_straight_polyline_constant_spacing() -> None:
    line = np.array([[0.0, 0.0], [0.3, 0.0], [0.35, 0.0], [1.0, 0.0]])
    out = resample_constant_speed(line, 0.07, closed=False)
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    np.testing.assert_allclose(steps, 0.07, rtol=1e-9)
    assert out.shape[0] == 15  # 0, 0.07, ..., 0.98


@pytest.mark.parametrize("closed", [True, False])
def test_resample_bent_polyline(closed: bool) -> None:
    rng = np.random.default_rng(0)
    poly = rng.uniform(-1.0, 1.0, size=(7, 3))
    spacing = 0.013
    out = resample_constant_speed(poly, spacing, closed=closed)
    s = _arc_position(out, poly, closed)  # asserts every point lies on the polyline
    np.testing.assert_allclose(np.diff(s), spacing, rtol=1e-9)
    assert s[0] == pytest.approx(0.0, abs=1e-12)
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert np.all(steps <= spacing * (1.0 + 1e-9))
    if closed:
        total = _arc_position(poly[:1], poly, closed)  # sanity: start is at 0
        assert total[0] == pytest.approx(0.0, abs=1e-12)
        # last sample is strictly before the end (start point not duplicated)
        assert np.linalg.norm(out[-1] - out[0]) > 0.0


def test_resample_closed_square_exact_count() -> None:
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    out = resample_constant_speed(square, 0.1, closed=True)
    assert out.shape == (40, 2)
    np.testing.assert_allclose(_closed_steps(out), 0.1, rtol=1e-9)
    assert np.all(path_deviation(out, square) < 1e-12)


def test_resample_validation() -> None:
    line = np.array([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(ValueError, match="spacing_m"):
        resample_constant_speed(line, 0.0)
    with pytest.raises(ValueError, match="spacing_m"):
        resample_constant_speed(line, float("nan"))
    with pytest.raises(ValueError, match="points"):
        resample_constant_speed(np.array([[0.0, 0.0]]), 0.1)
    with pytest.raises(ValueError, match="points"):
        resample_constant_speed(np.array([[0.0, 0.0], [np.inf, 0.0]]), 0.1)
    with pytest.raises(ValueError, match="points"):
        resample_constant_speed(np.zeros((4, 4)), 0.1)
    with pytest.raises(ValueError, match="points"):
        resample_constant_speed(np.zeros((3, 2)), 0.1)


# ---------------------------------------------------------------------------
# PathSpec and trajectories
# ---------------------------------------------------------------------------

NORMALS = [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.3, -0.5, 0.8), (0.0, 2.0, 0.0)]


def test_plane_basis_orthonormal() -> None:
    for normal in NORMALS:
        u, v, n = plane_basis(normal)
        basis = np.stack((u, v, n))
        np.testing.assert_allclose(basis @ basis.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(np.cross(u, v), n, atol=1e-12)
    u, v, n = plane_basis((0.0, 0.0, 1.0))
    np.testing.assert_allclose(u, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(v, [0.0, 1.0, 0.0])
    u, _, _ = plane_basis((2.0, 0.0, 0.0))  # x parallel to the normal -> use y
    np.testing.assert_allclose(u, [0.0, 1.0, 0.0])


@pytest.mark.parametrize("shape", PATH_SHAPES)
@pytest.mark.parametrize("normal", NORMALS)
def test_trajectory_speed_plane_and_centre(shape: str, normal: tuple) -> None:
    center = np.array([0.05, -0.02, 0.3])
    spec = PathSpec(shape, tuple(center), 0.08, 0.02, plane_normal=normal)
    period = 0.05
    traj = make_reference_trajectory(spec, period)
    assert traj.ndim == 2 and traj.shape[1] == 3
    spacing = spec.speed_m_s * period
    steps = _closed_steps(traj)
    assert np.all(steps <= spacing * 1.01)
    # chord equals the step except where a step cuts a corner of the path
    n_corners = {"circle": 0, "pentagram": 5, "rectangle": 4, "spiral": 1, "star": 10}[shape]
    short = np.flatnonzero(steps < spacing * 0.99)
    assert short.size <= n_corners
    # in the requested plane
    n = np.asarray(normal) / np.linalg.norm(normal)
    np.testing.assert_allclose(traj @ n, center @ n, atol=1e-12)
    # within radius of the centre and centre inside the bounding box
    assert np.max(np.linalg.norm(traj - center, axis=1)) <= spec.radius_m * (1 + 1e-9)
    assert np.all(traj.min(axis=0) <= center + 1e-12)
    assert np.all(traj.max(axis=0) >= center - 1e-12)
    # lies on the path (curved shapes: compare with a finer chord polyline)
    curved = shape in ("circle", "spiral")
    fine = path_polyline(spec, 20000 if curved else 2000)
    assert np.max(path_deviation(traj, fine)) < (1e-7 if curved else 1e-12)


@pytest.mark.parametrize("shape", ["circle", "rectangle"])
def test_symmetric_trajectory_centred(shape: str) -> None:
    center = np.array([0.1, 0.2, -0.3])
    spec = PathSpec(shape, tuple(center), 0.05, 0.01, plane_normal=(0.0, 0.0, 1.0))
    traj = make_reference_trajectory(spec, 0.01)
    mid = 0.5 * (traj.min(axis=0) + traj.max(axis=0))
    np.testing.assert_allclose(mid, center, atol=spacing_tol(spec, 0.01))


def spacing_tol(spec: PathSpec, period: float) -> float:
    return spec.speed_m_s * period


def test_trajectory_cycles_and_index() -> None:
    base = PathSpec("pentagram", (0.0, 0.0, 0.2), 0.1, 0.03)
    one = make_reference_trajectory(base, 0.02)
    three = make_reference_trajectory(
        PathSpec("pentagram", (0.0, 0.0, 0.2), 0.1, 0.03, cycles=3), 0.02
    )
    assert three.shape[0] == 3 * one.shape[0]
    np.testing.assert_array_equal(three[: one.shape[0]], one)
    np.testing.assert_array_equal(three[2 * one.shape[0] :], one)
    idx = cycle_index(three.shape[0], 3)
    assert idx.shape == (three.shape[0],)
    np.testing.assert_array_equal(np.bincount(idx), [one.shape[0]] * 3)
    assert np.all(np.diff(idx) >= 0)
    # the number of steps per cycle matches path length / (speed * period)
    expected = path_length(base) / (base.speed_m_s * 0.02)
    assert abs(one.shape[0] - expected) <= 0.5 + 1e-9
    # the trajectory starts at the path's start point
    np.testing.assert_allclose(one[0], path_polyline(base)[0], atol=1e-12)


def test_circle_trajectory_speed_exact() -> None:
    spec = PathSpec("circle", (0.0, 0.0, 0.0), 0.1, 0.02, cycles=2)
    traj = make_reference_trajectory(spec, 0.01)
    steps = _closed_steps(traj)
    np.testing.assert_allclose(steps, 0.02 * 0.01, rtol=1e-3)
    np.testing.assert_allclose(np.linalg.norm(traj, axis=1), 0.1, rtol=1e-6)


def test_trajectory_too_fast_raises() -> None:
    spec = PathSpec("circle", (0.0, 0.0, 0.0), 0.01, 10.0)
    with pytest.raises(ValueError, match="targets per cycle"):
        make_reference_trajectory(spec, 0.1)


@pytest.mark.parametrize("period", [0.0, -0.1, float("inf")])
def test_trajectory_bad_period(period: float) -> None:
    spec = PathSpec("circle", (0.0, 0.0, 0.0), 0.1, 0.02)
    with pytest.raises(ValueError, match="control_period_s"):
        make_reference_trajectory(spec, period)


def test_cycle_index_validation() -> None:
    np.testing.assert_array_equal(cycle_index(6, 2), [0, 0, 0, 1, 1, 1])
    with pytest.raises(ValueError, match="trajectory_len"):
        cycle_index(7, 2)
    with pytest.raises(ValueError, match="cycles"):
        cycle_index(6, 0)
    with pytest.raises(ValueError, match="trajectory_len"):
        cycle_index(0, 1)


def test_waypoints_spec() -> None:
    wp = [(0.0, 0.0, 0.1), (0.1, 0.0, 0.1), (0.1, 0.1, 0.2), (0.0, 0.1, 0.2)]
    spec = PathSpec("waypoints", (0.0, 0.0, 0.0), 1.0, 0.01, waypoints_m=[list(p) for p in wp])
    assert spec.waypoints_m == tuple(wp)
    hash(spec)
    poly = path_polyline(spec)
    assert poly.shape[1] == 3
    for p in wp:  # waypoints are kept unscaled
        assert np.min(np.linalg.norm(poly - np.asarray(p), axis=1)) < 1e-12
    traj = make_reference_trajectory(spec, 0.1)
    np.testing.assert_allclose(traj[0], wp[0], atol=1e-12)
    assert np.max(path_deviation(traj, np.asarray(wp))) < 1e-12
    steps = _closed_steps(traj)
    assert np.all(steps <= 0.001 * 1.01)
    assert np.sum(steps < 0.001 * 0.99) <= len(wp)
    perimeter = 0.1 + math.hypot(0.1, 0.1) + 0.1 + math.hypot(0.1, 0.1)
    assert traj.shape[0] == round(perimeter / 0.001)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(shape="hexagon"), "shape"),
        (dict(radius_m=0.0), "radius_m"),
        (dict(radius_m=-1.0), "radius_m"),
        (dict(radius_m=float("nan")), "radius_m"),
        (dict(speed_m_s=0.0), "speed_m_s"),
        (dict(speed_m_s=-0.1), "speed_m_s"),
        (dict(cycles=0), "cycles"),
        (dict(cycles=1.5), "cycles"),
        (dict(plane_normal=(0.0, 0.0, 0.0)), "plane_normal"),
        (dict(plane_normal=(0.0, 1.0)), "plane_normal"),
        (dict(center_m=(0.0, float("nan"), 0.0)), "center_m"),
        (dict(shape="waypoints"), "waypoints_m"),
        (dict(shape="waypoints", waypoints_m=((0.0, 0.0, 0.0),)), "waypoints_m"),
        (dict(shape="waypoints", waypoints_m=((0.0, 0.0, 0.0), (1.0, np.nan, 0.0))), "waypoints_m"),
        (dict(shape="waypoints", waypoints_m=((0.0, 0.0), (1.0, 0.0))), "waypoints_m"),
        (dict(shape="waypoints", waypoints_m=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))), "waypoints_m"),
        (dict(waypoints_m=((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))), "waypoints_m"),
    ],
)
def test_pathspec_validation(kwargs: dict, field: str) -> None:
    base = dict(shape="circle", center_m=(0.0, 0.0, 0.0), radius_m=0.1, speed_m_s=0.02)
    base.update(kwargs)
    with pytest.raises(ValueError, match=field):
        PathSpec(**base)


# ---------------------------------------------------------------------------
# path deviation
# ---------------------------------------------------------------------------


@pytest.mark.smoke
@pytest.mark.parametrize("shape", PATH_SHAPES)
def test_path_deviation_zero_on_path(shape: str) -> None:
    spec = PathSpec(shape, (0.1, 0.0, 0.2), 0.07, 0.01, plane_normal=(0.2, 0.4, 1.0))
    poly = path_polyline(spec)
    assert np.max(path_deviation(poly, poly)) < 1e-15
    mids = 0.5 * (poly + np.roll(poly, -1, axis=0))
    assert np.max(path_deviation(mids, poly)) < 1e-12


def test_path_deviation_normal_offset() -> None:
    normal = np.array([0.3, -0.5, 0.8])
    spec = PathSpec("star", (0.0, 0.1, 0.3), 0.05, 0.01, plane_normal=tuple(normal))
    poly = path_polyline(spec)
    n = normal / np.linalg.norm(normal)
    offsets = np.linspace(-0.02, 0.02, 9)
    pts = poly[::97][: offsets.size] + offsets[:, None] * n
    np.testing.assert_allclose(path_deviation(pts, poly), np.abs(offsets), atol=1e-12)


def test_path_deviation_circle_analytic() -> None:
    R = 0.12
    spec = PathSpec("circle", (0.0, 0.0, 0.0), R, 0.01)
    poly = path_polyline(spec, 2000)
    rng = np.random.default_rng(1)
    r = rng.uniform(0.2 * R, 2.0 * R, size=200)
    phi = rng.uniform(0.0, 2.0 * np.pi, size=200)
    pts = np.column_stack((r * np.cos(phi), r * np.sin(phi), np.zeros_like(r)))
    dev = path_deviation(pts, poly)
    np.testing.assert_allclose(dev, np.abs(r - R), atol=2e-6 * R)
    # and an out-of-plane offset: sqrt((r - R)^2 + h^2)
    h = 0.03
    pts[:, 2] = h
    np.testing.assert_allclose(
        path_deviation(pts, poly), np.hypot(r - R, h), atol=2e-6 * R
    )


def test_path_deviation_segment_and_closing_segment() -> None:
    square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    # (-0.5, 0.5) is nearest to the closing segment (0,1)->(0,0)
    pts = np.array([[-0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [2.0, 2.0, 0.0], [0.5, -0.25, 0.0]])
    np.testing.assert_allclose(
        path_deviation(pts, square), [0.5, 0.5, math.sqrt(2.0), 0.25], atol=1e-15
    )
    assert path_deviation(np.array([0.5, 0.5, 0.0]), square) == pytest.approx(0.5)


def test_path_deviation_chunked_matches() -> None:
    poly = path_polyline(PathSpec("spiral", (0.0, 0.0, 0.0), 0.1, 0.01), 3000)
    rng = np.random.default_rng(2)
    pts = rng.uniform(-0.12, 0.12, size=(1500, 3))
    full = path_deviation(pts, poly)
    parts = np.concatenate([path_deviation(pts[i : i + 7], poly) for i in range(0, 1500, 7)])
    np.testing.assert_allclose(full, parts, rtol=0, atol=0)


def test_path_deviation_validation() -> None:
    poly = np.zeros((4, 3))
    poly[:, 0] = np.arange(4)
    with pytest.raises(ValueError, match="points_m"):
        path_deviation(np.zeros((2, 2)), poly)
    with pytest.raises(ValueError, match="points_m"):
        path_deviation(np.array([[np.nan, 0.0, 0.0]]), poly)
    with pytest.raises(ValueError, match="polyline_m"):
        path_deviation(np.zeros((2, 3)), poly[:1])


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour that a surviving mutant changed unnoticed: errors name the
# offending field first; repeated and closing points are dropped; the polygon sampler keeps every
# vertex and rounds by largest remainder; the resampler's sample counts at exact multiples of the
# spacing; the placement ``center + radius (x u + y v)``; field normalisation of :class:`PathSpec`;
# and point-to-path distances on polylines with repeated vertices. References are the docstrings'
# rules, worked out by hand here.
# ==========================================================================================


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
