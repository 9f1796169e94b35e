"""Reference paths for trajectory-tracking tasks.

Trajectory-tracking tasks (e.g. Wang et al. 2023, which track pentagram and
circle paths) move a target along a closed planar path at constant speed.
This module provides:

* unit shapes: densely sampled closed 2D curves inside the unit disk
  (:func:`unit_shape`);
* equal arc-length resampling of polylines (:func:`resample_constant_speed`);
* a frozen path description placing a shape in 3D (:class:`PathSpec`): the
  unit shape is scaled by ``radius_m`` and laid in the plane through
  ``center_m`` with normal ``plane_normal``, so a path can be sized to each
  arm's workspace;
* the per-control-step target sequence (:func:`make_reference_trajectory`,
  :func:`cycle_index`);
* the dense closed path in 3D and point-to-path distances for path-deviation
  metrics (:func:`path_polyline`, :func:`path_deviation`);
* the quadratic surface fitted to an arm's reachable tips (:func:`workspace_surface`,
  :func:`surface_height`), onto which a path can be lifted (:attr:`PathSpec.lift_m`), as
  Ho et al. 2018 project their rectangle onto the workspace (ho2018 Section 3.4).

Units are SI throughout: positions and lengths in metres (m), speeds in
metres per second (m/s), times in seconds (s). Unit shapes are dimensionless.

Closed paths are represented without repeating the first point at the end:
the segment from the last point back to the first closes the loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Optional

import numpy as np

__all__ = [
    "PATH_SHAPES",
    "RECTANGLE_HALF_EXTENTS",
    "SPIRAL_INNER_RADIUS",
    "SPIRAL_TURNS",
    "STAR_INNER_RADIUS",
    "PathSpec",
    "cycle_index",
    "make_reference_trajectory",
    "path_deviation",
    "path_length",
    "path_polyline",
    "plane_basis",
    "resample_constant_speed",
    "surface_height",
    "unit_shape",
    "workspace_surface",
]

#: Names of the built-in unit shapes accepted by :func:`unit_shape`.
PATH_SHAPES: tuple[str, ...] = ("circle", "pentagram", "rectangle", "spiral", "star")

#: Shape name for a user-supplied closed polyline (:attr:`PathSpec.waypoints_m`).
WAYPOINTS_SHAPE = "waypoints"

#: Half width and half height of the unit rectangle (dimensionless).  The
#: rectangle has aspect ratio 5:3 and its corners lie on the unit circle, so
#: it stays inside the unit disk like every other unit shape (a 2 x 1.2
#: rectangle would reach radius sqrt(1.36) ~= 1.166 at its corners).
RECTANGLE_HALF_EXTENTS: tuple[float, float] = (5.0 / math.sqrt(34.0), 3.0 / math.sqrt(34.0))

#: Inner radius of the unit star's concave vertices (outer radius is 1).
STAR_INNER_RADIUS: float = 0.4

#: Starting radius of the unit Archimedean spiral (it ends at radius 1).
SPIRAL_INNER_RADIUS: float = 0.2

#: Number of turns of the unit spiral's outbound leg.
SPIRAL_TURNS: int = 2

_MIN_SHAPE_POINTS = 16
_MIN_POINTS_PER_CYCLE = 3
_DEFAULT_DENSE_POINTS = 2000
_MAX_DENSE_POINTS = 200_000
_DENSE_POINTS_PER_STEP = 8
# Relative tolerance used when deciding whether an arc-length sample falls
# exactly on the end of a path.
_ARC_TOL = 1e-9


# ---------------------------------------------------------------------------
# Small validation helpers
# ---------------------------------------------------------------------------


def _check_positive_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, raising ValueError unless finite and > 0."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    out = float(value)
    if not math.isfinite(out) or out <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return out


def _check_positive_int(name: str, value: object, minimum: int = 1) -> int:
    """Return ``value`` as an int, raising ValueError unless an int >= minimum."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    out = int(value)
    if out < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return out


def _as_vector3(name: str, value: object) -> tuple[float, float, float]:
    """Convert ``value`` to a tuple of three finite floats or raise ValueError."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _as_points(name: str, points: object, dims: tuple[int, ...] = (2, 3)) -> np.ndarray:
    """Convert ``points`` to a float (n, d) array with d in ``dims`` and n >= 2."""
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape (n, d), got {points!r}") from None
    if arr.ndim != 2 or arr.shape[1] not in dims:
        raise ValueError(
            f"{name} must have shape (n, d) with d in {dims}, got shape {arr.shape}"
        )
    if arr.shape[0] < 2:
        raise ValueError(f"{name} must contain at least 2 points, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values")
    return arr


# ---------------------------------------------------------------------------
# Polyline primitives
# ---------------------------------------------------------------------------


def _drop_repeated(points: np.ndarray, closed: bool) -> np.ndarray:
    """Remove consecutive duplicate points (and a duplicated closing point)."""
    keep = np.ones(points.shape[0], dtype=bool)
    keep[1:] = np.any(points[1:] != points[:-1], axis=1)
    out = points[keep]
    if closed and out.shape[0] > 1 and np.all(out[-1] == out[0]):
        out = out[:-1]
    return out


def _segments(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Return segment start points and segment vectors of a polyline."""
    if closed:
        ends = np.roll(points, -1, axis=0)
        return points, ends - points
    return points[:-1], points[1:] - points[:-1]


def _polyline_length(points: np.ndarray, closed: bool) -> float:
    """Total length of a polyline in the units of ``points``."""
    _, vec = _segments(points, closed)
    return float(np.linalg.norm(vec, axis=1).sum())


def _sample_closed_polygon(vertices: np.ndarray, n_points: int) -> np.ndarray:
    """Sample a closed polygon with ``n_points`` points, keeping every vertex.

    Points are distributed over the edges in proportion to edge length
    (largest-remainder rounding, at least one point per edge, namely its
    start vertex) and spaced evenly within each edge.
    """
    verts = _drop_repeated(vertices, closed=True)
    m = verts.shape[0]
    if n_points < m:
        raise ValueError(
            f"n_points must be >= the number of polygon vertices ({m}), got {n_points}"
        )
    starts, vec = _segments(verts, closed=True)
    lengths = np.linalg.norm(vec, axis=1)
    extra = n_points - m
    share = extra * lengths / lengths.sum()
    counts = np.floor(share).astype(int)
    remainder = extra - int(counts.sum())
    if remainder > 0:
        order = np.argsort(-(share - counts), kind="stable")
        counts[order[:remainder]] += 1
    counts += 1
    pieces = []
    for start, v, c in zip(starts, vec, counts):
        t = np.arange(c, dtype=float) / c
        pieces.append(start + t[:, None] * v)
    return np.concatenate(pieces, axis=0)


# ---------------------------------------------------------------------------
# Unit shapes
# ---------------------------------------------------------------------------


def _star_vertices(n_tips: int, inner_radius: float) -> np.ndarray:
    """Vertices of a star outline: alternating outer (1) and inner radii, CCW, tip up."""
    k = np.arange(2 * n_tips)
    angles = np.pi / 2.0 + k * np.pi / n_tips
    radii = np.where(k % 2 == 0, 1.0, inner_radius)
    return np.column_stack((radii * np.cos(angles), radii * np.sin(angles)))


def _pentagram_vertices() -> np.ndarray:
    """Outer vertices of the regular pentagon in pentagram order 0, 2, 4, 1, 3."""
    angles = np.pi / 2.0 + np.arange(5) * 2.0 * np.pi / 5.0
    outer = np.column_stack((np.cos(angles), np.sin(angles)))
    return outer[[0, 2, 4, 1, 3]]


def _rectangle_vertices() -> np.ndarray:
    """Rectangle outline starting at the middle of its right edge, CCW."""
    hx, hy = RECTANGLE_HALF_EXTENTS
    return np.array([[hx, 0.0], [hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])


def _spiral(n_points: int) -> np.ndarray:
    """Closed out-and-back Archimedean spiral sampled at equal arc length."""
    n_dense = 8 * n_points + 1000
    theta_end = 2.0 * np.pi * SPIRAL_TURNS
    theta = np.linspace(0.0, theta_end, n_dense)
    r = SPIRAL_INNER_RADIUS + (1.0 - SPIRAL_INNER_RADIUS) * theta / theta_end
    out = np.column_stack((r * np.cos(theta), r * np.sin(theta)))
    # Return leg retraces the spiral inward; the closing segment joins the
    # last return point to the start, so neither end point is repeated.
    loop = np.concatenate((out, out[-2:0:-1]), axis=0)
    length = _polyline_length(loop, closed=True)
    pts = resample_constant_speed(loop, length / n_points, closed=True)
    return pts[:n_points]


def unit_shape(name: str, n_points: int = _DEFAULT_DENSE_POINTS) -> np.ndarray:
    """Densely sampled closed 2D reference curve inside the unit disk.

    All shapes are dimensionless, centred on the origin, fit in the unit disk
    (max radius 1) and are traversed counter-clockwise (positive angle
    direction).  The first point is not repeated at the end; the segment from
    the last point to the first closes the curve.  Polygonal shapes contain
    their vertices exactly.

    Shapes and start points:

    * ``"circle"``: radius 1, starting at (1, 0), equal angular spacing.
    * ``"pentagram"``: the self-intersecting five-pointed star drawn through
      the outer vertices (radius 1, 72 degrees apart, vertex 0 at the top)
      in the order 0, 2, 4, 1, 3; starts at the top vertex (0, 1).
    * ``"rectangle"``: aspect 5:3, centred, half extents
      :data:`RECTANGLE_HALF_EXTENTS` (corners on the unit circle); starts at
      the middle of the right edge.
    * ``"spiral"``: Archimedean spiral from radius
      :data:`SPIRAL_INNER_RADIUS` at angle 0 out to radius 1 over
      :data:`SPIRAL_TURNS` turns (counter-clockwise), then back along the same
      spiral to the start, so the curve is closed.  Starts at (0.2, 0).
    * ``"star"``: non-self-intersecting five-pointed star outline with 10
      vertices alternating between radius 1 (tips, first tip at the top) and
      :data:`STAR_INNER_RADIUS`; starts at the top tip (0, 1).

    Args:
        name: One of :data:`PATH_SHAPES`.
        n_points: Number of samples (>= 16).

    Returns:
        Array of shape (n_points, 2), dimensionless.

    Raises:
        ValueError: For an unknown shape name or an invalid ``n_points``.
    """
    if not isinstance(name, str) or name not in PATH_SHAPES:
        raise ValueError(
            f"unknown path {name!r} (parameter 'name'); path must be one of "
            f"{', '.join(PATH_SHAPES)}"
        )
    n = _check_positive_int("n_points", n_points, minimum=_MIN_SHAPE_POINTS)
    if name == "circle":
        theta = 2.0 * np.pi * np.arange(n) / n
        return np.column_stack((np.cos(theta), np.sin(theta)))
    if name == "pentagram":
        return _sample_closed_polygon(_pentagram_vertices(), n)
    if name == "rectangle":
        return _sample_closed_polygon(_rectangle_vertices(), n)
    if name == "star":
        return _sample_closed_polygon(_star_vertices(5, STAR_INNER_RADIUS), n)
    return _spiral(n)


# ---------------------------------------------------------------------------
# Resampling
# ---------------------------------------------------------------------------


def resample_constant_speed(
    points: np.ndarray, spacing_m: float, closed: bool = True
) -> np.ndarray:
    """Resample a polyline at equal arc-length spacing.

    Samples are placed at arc lengths 0, s, 2s, ... measured along the
    polyline from its first point, where s = ``spacing_m``; each sample lies
    on the original polyline.  For a closed polyline the closing segment
    (last point back to first) is part of the path, samples are taken for
    arc lengths strictly below the total length, and the start point is
    therefore not duplicated at the end.  For an open polyline samples are
    taken up to and including the total length; the end point is included
    only if the length is a multiple of s.  Consecutive samples are exactly
    s apart in arc length (their straight-line distance is shorter where
    they straddle a corner).

    Args:
        points: Polyline vertices, shape (n, 2) or (n, 3), n >= 2, in metres
            (or any consistent length unit).
        spacing_m: Arc-length spacing between samples, > 0, same unit.
        closed: Whether the polyline is a closed loop.

    Returns:
        Array of shape (k, d) with the samples, k >= 1.

    Raises:
        ValueError: If ``points`` is not a finite (n, 2)/(n, 3) array with at
            least 2 points, has zero total length, or ``spacing_m`` is not
            positive and finite.
    """
    pts = _as_points("points", points)
    spacing = _check_positive_finite("spacing_m", spacing_m)
    pts = _drop_repeated(pts, closed=bool(closed))
    if pts.shape[0] < 2:
        raise ValueError("points must span a non-zero length (all points coincide)")
    starts, vec = _segments(pts, closed=bool(closed))
    seg_len = np.linalg.norm(vec, axis=1)
    cum = np.concatenate(([0.0], np.cumsum(seg_len)))
    total = float(cum[-1])
    tol = _ARC_TOL * spacing
    if closed:
        count = max(1, int(math.ceil((total - tol) / spacing)))
    else:
        count = int(math.floor((total + tol) / spacing)) + 1
    s = np.arange(count, dtype=float) * spacing
    s = np.minimum(s, total)
    idx = np.searchsorted(cum, s, side="right") - 1
    idx = np.clip(idx, 0, seg_len.shape[0] - 1)
    t = (s - cum[idx]) / seg_len[idx]
    t = np.clip(t, 0.0, 1.0)
    return starts[idx] + t[:, None] * vec[idx]


# ---------------------------------------------------------------------------
# Workspace surface
# ---------------------------------------------------------------------------


def _quadratic_basis(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Columns ``1, x, y, x^2, x y, y^2`` of the quadratic surface, shape (n, 6)."""
    return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)


def workspace_surface(tips: np.ndarray) -> np.ndarray:
    """Least-squares coefficients ``(a, b, c, d, e, f)`` of the surface
    ``z = a + b x + c y + d x^2 + e x y + f y^2`` through tip positions.

    ho2018 Section 3.4 approximates the robot's 3D workspace by such a surface fitted to the
    pre-training tip positions and projects its rectangle onto it. The fit works in the unit of
    ``tips`` (m or mm): the coefficients are for that unit (``a`` in it, ``b, c``
    dimensionless, ``d, e, f`` in its inverse).

    Args:
        tips: tip positions (x, y, z), shape (n, 3), n >= 6, finite.

    Returns:
        Array of the 6 coefficients.

    Raises:
        ValueError: ``tips`` not finite points of shape (n >= 6, 3).
    """
    try:
        arr = np.asarray(tips, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"tips must be a numeric array of shape (n, 3), got {tips!r}") from None
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 6:
        raise ValueError(f"tips must have shape (n, 3) with n >= 6 (one point per coefficient), "
                         f"got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("tips must contain only finite values")
    x, y, z = arr.T
    return np.linalg.lstsq(_quadratic_basis(x, y), z, rcond=None)[0]


def surface_height(coefficients: object, x: object, y: object) -> np.ndarray:
    """Height ``a + b x + c y + d x^2 + e x y + f y^2`` of a quadratic surface
    (:func:`workspace_surface`) at ``(x, y)`` (arrays of one shape, the coefficients' unit).

    Raises:
        ValueError: ``coefficients`` not 6 finite numbers, or ``x`` and ``y`` of other shapes.
    """
    coeffs = np.asarray(coefficients, dtype=float)
    if coeffs.shape != (6,) or not np.all(np.isfinite(coeffs)):
        raise ValueError(f"coefficients must be 6 finite numbers, got {coefficients!r}")
    xs, ys = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if xs.shape != ys.shape:
        raise ValueError(f"x and y must have one shape, got {xs.shape} and {ys.shape}")
    flat = _quadratic_basis(xs.ravel(), ys.ravel()) @ coeffs
    return flat.reshape(xs.shape)


# ---------------------------------------------------------------------------
# Path specification
# ---------------------------------------------------------------------------


def plane_basis(normal: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Deterministic orthonormal basis (u, v, n) of the plane with ``normal``.

    ``n`` is the normalised normal; ``u`` is the normalised projection of the
    base x axis (1, 0, 0) onto the plane, or of the y axis (0, 1, 0) when x
    is (nearly) parallel to the normal; ``v = n x u``.  A unit shape's
    (x, y) maps to ``x * u + y * v``, so counter-clockwise shapes are
    counter-clockwise when viewed from the side the normal points to.

    Args:
        normal: Plane normal, 3 finite numbers, not all zero (dimensionless).

    Returns:
        Tuple of three unit vectors of shape (3,).

    Raises:
        ValueError: If ``normal`` is not 3 finite numbers or is zero.
    """
    n = np.asarray(_as_vector3("plane_normal", normal), dtype=float)
    norm = float(np.linalg.norm(n))
    if norm == 0.0:
        raise ValueError(f"plane_normal must be non-zero, got {normal!r}")
    n = n / norm
    u = None
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        proj = axis - np.dot(axis, n) * n
        proj_norm = float(np.linalg.norm(proj))
        if proj_norm > 1e-6:
            u = proj / proj_norm
            break
    assert u is not None  # x and y cannot both be parallel to n
    v = np.cross(n, u)
    return u, v, n


@dataclass(frozen=True)
class PathSpec:
    """A closed reference path in 3D traversed at constant speed.

    For a built-in shape the unit shape (:func:`unit_shape`) is scaled by
    ``radius_m`` and placed in the plane through ``center_m`` with normal
    ``plane_normal`` using the basis from :func:`plane_basis`; with ``lift_m`` each point is
    then moved along the normal by the quadratic height ``lift_m`` gives at its in-plane
    coordinates (a path lifted onto a curved workspace surface).  For
    ``shape="waypoints"`` the closed polyline through ``waypoints_m`` is used
    as given (not scaled, centred or projected; ``radius_m``,
    ``center_m`` and ``plane_normal`` are still validated but do not affect
    the path).

    Vector fields are normalised to tuples of floats on construction, so
    lists or numpy arrays are accepted.

    Attributes:
        shape: One of :data:`PATH_SHAPES` or ``"waypoints"``.
        center_m: Path centre in metres, (x, y, z).
        radius_m: Scale of the unit shape in metres (> 0); the path lies
            within this distance of ``center_m``.
        speed_m_s: Target speed along the path in m/s (> 0).
        plane_normal: Normal of the path plane (dimensionless, non-zero).
        cycles: Number of times the path is traversed (>= 1).
        waypoints_m: For ``shape="waypoints"``: at least 2 finite 3D points
            in metres, used as a closed polyline; must be None otherwise.
        lift_m: None (the path lies in its plane), or the 6 coefficients
            ``(a, b, c, d, e, f)`` of the height ``h(s, t) = a + b s + c t + d s^2 + e s t +
            f t^2`` (m) along ``plane_normal`` of the point at in-plane coordinates
            ``(s, t) = radius_m * (x, y)`` (m) about ``center_m`` (``a`` in m, ``b, c``
            dimensionless, ``d, e, f`` in 1/m); built-in shapes only.

    Raises:
        ValueError: On construction, naming the offending field and value.
    """

    shape: str
    center_m: tuple[float, float, float]
    radius_m: float
    speed_m_s: float
    plane_normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    cycles: int = 1
    waypoints_m: Optional[tuple[tuple[float, float, float], ...]] = None
    lift_m: Optional[tuple[float, float, float, float, float, float]] = None

    def __post_init__(self) -> None:
        allowed = PATH_SHAPES + (WAYPOINTS_SHAPE,)
        if not isinstance(self.shape, str) or self.shape not in allowed:
            raise ValueError(
                f"shape must be one of {', '.join(allowed)}, got {self.shape!r}"
            )
        object.__setattr__(self, "center_m", _as_vector3("center_m", self.center_m))
        object.__setattr__(self, "radius_m", _check_positive_finite("radius_m", self.radius_m))
        object.__setattr__(
            self, "speed_m_s", _check_positive_finite("speed_m_s", self.speed_m_s)
        )
        normal = _as_vector3("plane_normal", self.plane_normal)
        if not any(normal):
            raise ValueError(f"plane_normal must be non-zero, got {self.plane_normal!r}")
        object.__setattr__(self, "plane_normal", normal)
        object.__setattr__(self, "cycles", _check_positive_int("cycles", self.cycles))

        if self.shape == WAYPOINTS_SHAPE:
            if self.waypoints_m is None:
                raise ValueError("waypoints_m is required when shape='waypoints', got None")
            try:
                wp = np.asarray(self.waypoints_m, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(
                    f"waypoints_m must be a sequence of 3D points, got {self.waypoints_m!r}"
                ) from None
            if wp.ndim != 2 or wp.shape[1] != 3:
                raise ValueError(
                    f"waypoints_m must have shape (n, 3), got shape {wp.shape}"
                )
            if wp.shape[0] < 2:
                raise ValueError(
                    f"waypoints_m must contain at least 2 points, got {wp.shape[0]}"
                )
            if not np.all(np.isfinite(wp)):
                raise ValueError(f"waypoints_m must be finite, got {self.waypoints_m!r}")
            if _drop_repeated(wp, closed=True).shape[0] < 2:
                raise ValueError(
                    "waypoints_m must contain at least 2 distinct points, got "
                    f"{self.waypoints_m!r}"
                )
            object.__setattr__(
                self, "waypoints_m", tuple(tuple(float(c) for c in p) for p in wp)
            )
        elif self.waypoints_m is not None:
            raise ValueError(
                f"waypoints_m must be None unless shape='waypoints' (shape={self.shape!r}), "
                f"got {self.waypoints_m!r}"
            )
        if self.lift_m is not None:
            if self.shape == WAYPOINTS_SHAPE:
                raise ValueError(
                    f"lift_m must be None for shape='waypoints' (waypoints are used as given), "
                    f"got {self.lift_m!r}"
                )
            try:
                lift = np.asarray(self.lift_m, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"lift_m must be 6 finite numbers, got {self.lift_m!r}") from None
            if lift.shape != (6,) or not np.all(np.isfinite(lift)):
                raise ValueError(f"lift_m must be 6 finite numbers, got {self.lift_m!r}")
            object.__setattr__(self, "lift_m", tuple(float(c) for c in lift))


# ---------------------------------------------------------------------------
# Paths and trajectories in 3D
# ---------------------------------------------------------------------------


def path_polyline(spec: PathSpec, n_points: int = _DEFAULT_DENSE_POINTS) -> np.ndarray:
    """Dense closed path of ``spec`` in 3D, in metres.

    For built-in shapes this is ``center_m + radius_m * (x u + y v)`` for the
    points (x, y) of ``unit_shape(spec.shape, n_points)``, plus ``h(s, t) n`` with
    ``(s, t) = radius_m * (x, y)`` when ``spec.lift_m`` gives the height ``h``.  For waypoints it
    is the closed waypoint polyline sampled with ``max(n_points, number of
    distinct waypoints)`` points, keeping every waypoint.  The first point is
    not repeated at the end.

    Args:
        spec: Path specification.
        n_points: Number of samples (>= 16).

    Returns:
        Array of shape (n, 3) in metres.
    """
    if not isinstance(spec, PathSpec):
        raise ValueError(f"spec must be a PathSpec, got {spec!r}")
    n = _check_positive_int("n_points", n_points, minimum=_MIN_SHAPE_POINTS)
    if spec.shape == WAYPOINTS_SHAPE:
        wp = _drop_repeated(np.asarray(spec.waypoints_m, dtype=float), closed=True)
        return _sample_closed_polygon(wp, max(n, wp.shape[0]))
    uv = unit_shape(spec.shape, n)
    u, v, normal = plane_basis(spec.plane_normal)
    center = np.asarray(spec.center_m, dtype=float)
    points = center + spec.radius_m * (uv[:, :1] * u + uv[:, 1:2] * v)
    if spec.lift_m is not None:
        st = spec.radius_m * uv
        points = points + surface_height(spec.lift_m, st[:, 0], st[:, 1])[:, None] * normal
    return points


def path_length(spec: PathSpec, n_points: int = _DEFAULT_DENSE_POINTS) -> float:
    """Length of one cycle of the closed path in metres (from :func:`path_polyline`)."""
    return _polyline_length(path_polyline(spec, n_points), closed=True)


def make_reference_trajectory(spec: PathSpec, control_period_s: float) -> np.ndarray:
    """Per-control-step target positions moving along the path at constant speed.

    One cycle samples the closed path at equal arc-length spacing starting at
    its start point.  The nominal spacing is ``speed_m_s * control_period_s``
    (m); it is adjusted to ``L / N`` with ``N = round(L / spacing)`` points per
    cycle (L the path length), so the step from the last target of a cycle to
    the first target of the next is as long as every other step and each
    cycle is identical.  The realised speed therefore differs from
    ``speed_m_s`` by at most a factor 1 +- 1 / (2 N).  The cycle is repeated
    ``spec.cycles`` times, so ``T = cycles * N``.  Straight-line distances
    between consecutive targets equal the arc spacing except where they cut
    a corner of the path.

    Args:
        spec: Path specification.
        control_period_s: Control period in seconds (> 0).

    Returns:
        Array of shape (T, 3) of target positions in metres.

    Raises:
        ValueError: If ``control_period_s`` is invalid or the path is too
            short for at least 3 targets per cycle at the requested speed.
    """
    if not isinstance(spec, PathSpec):
        raise ValueError(f"spec must be a PathSpec, got {spec!r}")
    period = _check_positive_finite("control_period_s", control_period_s)
    spacing = spec.speed_m_s * period
    dense = path_polyline(spec, _DEFAULT_DENSE_POINTS)
    length = _polyline_length(dense, closed=True)
    if spec.shape in ("circle", "spiral"):
        # Curved shapes: keep the dense polyline much finer than one step.
        wanted = int(math.ceil(_DENSE_POINTS_PER_STEP * length / spacing))
        n_dense = min(max(_DEFAULT_DENSE_POINTS, wanted), _MAX_DENSE_POINTS)
        if n_dense > _DEFAULT_DENSE_POINTS:
            dense = path_polyline(spec, n_dense)
            length = _polyline_length(dense, closed=True)
    per_cycle = int(round(length / spacing))
    if per_cycle < _MIN_POINTS_PER_CYCLE:
        raise ValueError(
            f"path of length {length:.6g} m gives fewer than {_MIN_POINTS_PER_CYCLE} "
            f"targets per cycle at speed_m_s={spec.speed_m_s!r} and "
            f"control_period_s={control_period_s!r}"
        )
    cycle = resample_constant_speed(dense, length / per_cycle, closed=True)[:per_cycle]
    if cycle.shape[0] != per_cycle:  # pragma: no cover - guarded by the tolerance
        raise RuntimeError("internal error: unexpected number of resampled points")
    return np.tile(cycle, (spec.cycles, 1))


def cycle_index(trajectory_len: int, cycles: int) -> np.ndarray:
    """Cycle number (0 .. cycles-1) of each step of a repeated trajectory.

    Args:
        trajectory_len: Number of steps T (>= 1), a multiple of ``cycles``.
        cycles: Number of cycles (>= 1).

    Returns:
        Integer array of shape (T,), ``[0]*N + [1]*N + ...`` with N = T / cycles.

    Raises:
        ValueError: For non-positive values or if T is not divisible by cycles.
    """
    t = _check_positive_int("trajectory_len", trajectory_len)
    c = _check_positive_int("cycles", cycles)
    if t % c != 0:
        raise ValueError(
            f"trajectory_len must be a multiple of cycles, got trajectory_len={trajectory_len!r} "
            f"and cycles={cycles!r}"
        )
    return np.repeat(np.arange(c), t // c)


def path_deviation(points_m: np.ndarray, polyline_m: np.ndarray) -> np.ndarray:
    """Distance from each point to the closest point of a closed polyline.

    The polyline's segments include the closing segment from its last point
    back to its first.  Distances are exact point-to-segment distances.

    Args:
        points_m: Query points, shape (k, d) or (d,), d in {2, 3}, metres.
        polyline_m: Closed polyline vertices, shape (n, d), n >= 2, metres.

    Returns:
        Distances in metres, shape (k,) (or () for a single (d,) point).

    Raises:
        ValueError: On non-finite input, wrong shapes or mismatched dimensions.
    """
    line = _as_points("polyline_m", polyline_m)
    try:
        pts = np.asarray(points_m, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"points_m must be a numeric array, got {points_m!r}") from None
    single = pts.ndim == 1
    if single:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != line.shape[1]:
        raise ValueError(
            f"points_m must have shape (k, {line.shape[1]}) to match polyline_m, "
            f"got shape {np.shape(points_m)}"
        )
    if not np.all(np.isfinite(pts)):
        raise ValueError("points_m must contain only finite values")
    starts, vec = _segments(line, closed=True)
    seg_sq = np.einsum("ij,ij->i", vec, vec)
    # 1 / |segment|^2, with 0 for zero-length segments (then t = 0).
    inv_sq = np.zeros_like(seg_sq)
    np.divide(1.0, seg_sq, out=inv_sq, where=seg_sq > 0.0)
    dim = line.shape[1]
    out = np.empty(pts.shape[0], dtype=float)
    chunk = max(1, 1_000_000 // starts.shape[0])
    for lo in range(0, pts.shape[0], chunk):
        p = pts[lo : lo + chunk]
        # Per-coordinate (k, m) arrays keep memory and time low.
        rel = [p[:, j : j + 1] - starts[None, :, j] for j in range(dim)]
        t = rel[0] * vec[:, 0]
        for j in range(1, dim):
            t += rel[j] * vec[:, j]
        t *= inv_sq
        np.clip(t, 0.0, 1.0, out=t)
        d2 = np.zeros_like(t)
        for j in range(dim):
            e = rel[j]
            e -= t * vec[:, j]
            e *= e
            d2 += e
        out[lo : lo + chunk] = np.sqrt(d2.min(axis=1))
    return out[0] if single else out
