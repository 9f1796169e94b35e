"""Placing track paths on the workspace: the fitted quadratic surface (ho2018 Section 3.4), a
path lifted onto it (``PathSpec.lift_m``) and ``TrackTask``'s choice between the median-height
plane and the surface, on synthetic reachable sets whose shape is known.

References are computed here from the definitions (the quadratic's coefficients chosen by hand,
the lifted height as ``a + b s + c t + d s^2 + e s t + f t^2``), not read back from the code.
"""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.tasks.paths import (PATH_SHAPES, PathSpec, path_polyline, surface_height,
                                  unit_shape, workspace_surface)
from soft_gym.tasks.tasks import MIN_SURFACE_TIPS, TrackTask, workspace_lift

SPEC = get_preset("ho2018")  # max reach 155 mm


def _dome(n: int = 200, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Tips on a tilted dome ``z = 0.175 - 0.05 x + 0.01 y - 5.5 x^2 - 0.4 x y - 6 y^2`` (m)
    over a disk of 150 mm, +-5 mm of scatter: a workspace like the upright ho2018 arm's."""
    coefficients = np.array([0.175, -0.05, 0.01, -5.5, -0.4, -6.0])
    rng = np.random.default_rng(seed)
    rho, angle = 0.15 * np.sqrt(rng.uniform(0, 1, n)), rng.uniform(0, 2 * np.pi, n)
    x, y = rho * np.cos(angle), rho * np.sin(angle)
    z = (coefficients[0] + coefficients[1] * x + coefficients[2] * y + coefficients[3] * x * x
         + coefficients[4] * x * y + coefficients[5] * y * y + rng.uniform(-0.005, 0.005, n))
    return np.column_stack([x, y, z]), coefficients


def _slab(n: int = 200, seed: int = 1) -> np.ndarray:
    """Tips filling a flat slab 30 mm wide and 20 mm thick (z 90-110 mm): a hanging arm's."""
    rng = np.random.default_rng(seed)
    rho, angle = 0.03 * np.sqrt(rng.uniform(0, 1, n)), rng.uniform(0, 2 * np.pi, n)
    return np.column_stack([rho * np.cos(angle), rho * np.sin(angle), rng.uniform(0.09, 0.11, n)])


def test_workspace_surface_recovers_an_exact_quadratic_in_any_unit() -> None:
    rng = np.random.default_rng(2)
    x, y = rng.uniform(-0.1, 0.1, 30), rng.uniform(-0.1, 0.1, 30)
    a, b, c, d, e, f = 0.2, 0.1, -0.3, -4.0, 1.5, 2.0
    z = a + b * x + c * y + d * x * x + e * x * y + f * y * y
    np.testing.assert_allclose(workspace_surface(np.column_stack([x, y, z])),
                               [a, b, c, d, e, f], rtol=1e-9, atol=1e-12)
    # in mm: a scales by 1000, b and c stay, d, e and f scale by 1/1000
    np.testing.assert_allclose(workspace_surface(1000 * np.column_stack([x, y, z])),
                               [1000 * a, b, c, d / 1000, e / 1000, f / 1000], rtol=1e-9)
    np.testing.assert_allclose(surface_height([a, b, c, d, e, f], x, y), z, rtol=0, atol=1e-15)


@pytest.mark.parametrize("tips, message", [
    (np.zeros((5, 3)), r"^tips must have shape \(n, 3\) with n >= 6"),
    (np.zeros((10, 2)), r"^tips must have shape \(n, 3\) with n >= 6"),
    (np.full((10, 3), np.nan), r"^tips must contain only finite values"),
])
def test_workspace_surface_refuses_bad_tips(tips: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        workspace_surface(tips)


def test_surface_height_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match=r"^coefficients must be 6 finite numbers"):
        surface_height([1.0, 2.0], 0.0, 0.0)
    with pytest.raises(ValueError, match=r"^x and y must have one shape"):
        surface_height(np.zeros(6), np.zeros(3), np.zeros(2))


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.0, 1.0, 1.0)])
def test_a_lifted_path_is_its_plane_path_moved_along_the_normal(normal) -> None:
    """Each point moves by ``h(s, t)`` along the unit normal, ``(s, t) = radius * unit shape``."""
    lift = (0.01, 0.2, -0.1, -3.0, 0.5, -2.0)
    flat = PathSpec(shape="star", center_m=(0.01, -0.02, 0.15), radius_m=0.05, speed_m_s=0.01,
                    plane_normal=normal)
    lifted = PathSpec(shape="star", center_m=(0.01, -0.02, 0.15), radius_m=0.05,
                      speed_m_s=0.01, plane_normal=normal, lift_m=lift)
    s, t = (0.05 * unit_shape("star", 500)).T
    height = (lift[0] + lift[1] * s + lift[2] * t + lift[3] * s * s + lift[4] * s * t
              + lift[5] * t * t)
    unit_normal = np.asarray(normal) / np.linalg.norm(normal)
    np.testing.assert_allclose(path_polyline(lifted, 500),
                               path_polyline(flat, 500) + height[:, None] * unit_normal,
                               rtol=0, atol=1e-15)
    assert lifted.lift_m == lift and all(type(c) is float for c in lifted.lift_m)


@pytest.mark.parametrize("kwargs, message", [
    ({"lift_m": (1.0, 2.0)}, r"^lift_m must be 6 finite numbers"),
    ({"lift_m": (0.0, 0.0, 0.0, 0.0, 0.0, np.inf)}, r"^lift_m must be 6 finite numbers"),
    ({"lift_m": "flat"}, r"^lift_m must be 6 finite numbers"),
    ({"lift_m": (0.0,) * 6, "shape": "waypoints", "waypoints_m": ((0, 0, 0.1), (0.01, 0, 0.1))},
     r"^lift_m must be None for shape='waypoints'"),
])
def test_bad_lifts_are_refused_by_name(kwargs: dict, message: str) -> None:
    arguments = {"shape": "circle", "center_m": (0, 0, 0.1), "radius_m": 0.02, "speed_m_s": 0.01,
                 **kwargs}
    with pytest.raises(ValueError, match=message):
        PathSpec(**arguments)


def test_a_dome_gets_the_surface_and_a_slab_keeps_the_plane() -> None:
    dome, _ = _dome()
    lateral_75 = float(np.percentile(np.hypot(dome[:, 0], dome[:, 1]), 75))
    fitted = workspace_lift(dome, 0.5 * lateral_75)
    assert fitted is not None
    np.testing.assert_allclose(fitted, workspace_surface(dome), rtol=0, atol=0)
    assert workspace_lift(_slab(), 0.01) is None
    # a radius so small that the dome's top is within its scatter of the median plane: the
    # median of the dome's heights lies far below its top, so even radius 0 gets the surface
    assert workspace_lift(dome, 0.0) is not None
    assert workspace_lift(dome[:MIN_SURFACE_TIPS - 1], 0.05) is None
    for bad in (-0.01, np.nan):
        with pytest.raises(ValueError, match=r"^radius_m must be a finite distance >= 0"):
            workspace_lift(dome, bad)


@pytest.mark.parametrize("path", PATH_SHAPES)
def test_track_paths_on_a_dome_lie_on_the_fitted_surface(path: str) -> None:
    """Seen along the axis the path is the planar one (same radius, centred on the axis); its
    height is the surface fitted to the tips, within 10 mm of the true dome everywhere."""
    dome, true = _dome()
    task = TrackTask(SPEC, dome, path=path)
    assert task.placement == "surface"
    radius = 0.5 * float(np.percentile(np.hypot(dome[:, 0], dome[:, 1]), 75))
    assert task.path_spec.radius_m == pytest.approx(radius, rel=1e-12)
    planar = path_polyline(PathSpec(shape=path, center_m=(0.0, 0.0, 0.0), radius_m=radius,
                                    speed_m_s=1.0))
    np.testing.assert_allclose(task.path_m[:, :2], planar[:, :2], rtol=0, atol=1e-12)
    x, y, z = task.path_m.T
    np.testing.assert_allclose(z, surface_height(workspace_surface(dome), x, y), rtol=0,
                               atol=1e-12)
    assert np.abs(z - surface_height(true, x, y)).max() < 0.010
    # the targets are on the lifted path too (on chords of its dense polyline: within 1 um)
    x, y, z = task.trajectory_m.T
    np.testing.assert_allclose(z, surface_height(workspace_surface(dome), x, y), rtol=0,
                               atol=1e-6)


def test_waypoints_are_used_as_given_on_a_dome() -> None:
    dome, _ = _dome()
    points = np.array([[0.02, 0.0, 0.14], [0.0, 0.02, 0.15], [-0.02, 0.0, 0.14]])
    task = TrackTask(SPEC, dome, path="waypoints", waypoints_m=points, speed_m_s=0.01)
    assert task.placement == "plane" and task.path_spec.lift_m is None
    np.testing.assert_array_equal(np.asarray(task.path_spec.waypoints_m), points)


def test_a_slab_keeps_the_median_plane() -> None:
    slab = _slab()
    task = TrackTask(SPEC, slab, path="pentagram")
    assert task.placement == "plane" and task.path_spec.lift_m is None
    np.testing.assert_allclose(task.path_m[:, 2], np.median(slab[:, 2]), rtol=0, atol=1e-15)
