"""Every default track path of every preset lies on the arm's reachable workspace.

The reference is independent of the placement rule (``TrackTask``: the median-height plane, or
the quadratic surface fitted to the reachable tips): for each target of a path the pressure
search (``soft_gym.procedures.workspace.reach_distances``, the search of
``soft_gym.procedures.positioning``) drives the unloaded arm's tip there on the reference engine
(PyBullet), and the closest tip it finds must be within 2 mm. The presets and shapes come from
their registries (``PRESETS``, ``PATH_SHAPES``), so a new arm or shape is checked too.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401  (registers the env ids)
from soft_gym.procedures.workspace import reach_distances, reachable_tips
from soft_gym.robots.presets import PRESETS, get_preset
from soft_gym.tasks.paths import PATH_SHAPES, PathSpec, make_reference_trajectory
from soft_gym.tasks.tasks import TrackTask

REACHED_MM = 2.0


@pytest.mark.slow
@pytest.mark.parametrize("path", PATH_SHAPES)
@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_target_of_every_default_path_is_reachable(preset: str, path: str) -> None:
    """Each target of one cycle of the default task (default scale and speed) is within 2 mm of
    a tip the pressure search finds on the unloaded arm."""
    spec = get_preset(preset)
    task = TrackTask(spec, reachable_tips(spec), path=path)
    distances_mm = reach_distances(spec, task.trajectory_m) * 1e3
    assert distances_mm.max() < REACHED_MM, (task.placement, float(distances_mm.max()),
                                             int(np.argmax(distances_mm)))


def test_the_ho2018_track_env_default_path_is_reachable() -> None:
    """``gym.make("SoftArmTrackHo2018-v0")``'s circle, lifted onto the upright arm's workspace:
    every fourth target (about 4 mm apart) within 2 mm of a tip the pressure search finds."""
    env = gym.make("SoftArmTrackHo2018-v0", feedback="ground_truth")
    try:
        task = env.unwrapped.task
        spec = env.unwrapped.arm
    finally:
        env.close()
    assert task.path_spec.shape == "circle" and task.placement == "surface"
    distances_mm = reach_distances(spec, task.trajectory_m[::4]) * 1e3
    assert distances_mm.max() < REACHED_MM, float(distances_mm.max())


def test_the_search_reports_the_old_median_plane_as_off_the_upright_workspace() -> None:
    """The measure tells off-workspace points apart: half-way round the circle laid in the plane
    at the reachable tips' median height (the placement before the surface), the target lies
    tens of mm from anything the upright ho2018 arm reaches, though within its reach from the
    base."""
    spec = get_preset("ho2018")
    tips = reachable_tips(spec)
    radius = 0.5 * float(np.percentile(np.linalg.norm(tips[:, :2], axis=1), 75))
    plane = PathSpec(shape="circle", center_m=(0.0, 0.0, float(np.median(tips[:, 2]))),
                     radius_m=radius, speed_m_s=2 * np.pi * radius / 20.0)
    targets = make_reference_trajectory(plane, spec.control_period_s)
    half_way = targets[len(targets) // 2][None]
    assert np.linalg.norm(half_way) < spec.max_reach_m
    assert reach_distances(spec, half_way)[0] * 1e3 > 20.0


@pytest.mark.parametrize("points, message", [
    (np.zeros((0, 3)), r"^points_m must be points \(m\), shape \(n >= 1, 3\)"),
    (np.zeros((4, 2)), r"^points_m must be points \(m\), shape \(n >= 1, 3\)"),
    (np.array([[0.0, np.nan, 0.1]]), r"^points_m must be finite"),
])
def test_reach_distances_refuses_bad_points(points: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        reach_distances(get_preset("wang2023"), points)


def test_reach_distances_refuses_bad_settings() -> None:
    spec = get_preset("wang2023")
    with pytest.raises(ValueError, match=r"^hold_s"):
        reach_distances(spec, np.array([[0.0, 0.0, 0.1]]), hold_s=0.0)
    with pytest.raises(ValueError, match=r"^tolerance_m"):
        reach_distances(spec, np.array([[0.0, 0.0, 0.1]]), tolerance_m=-1e-3)
