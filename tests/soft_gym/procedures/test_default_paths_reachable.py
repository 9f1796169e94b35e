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
from soft_gym.tasks.paths import PATH_SHAPES
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


@pytest.mark.slow  # about 14 s; the ho2018 path's reach is checked by default
def test_the_search_reports_a_point_under_the_dome_as_off_the_upright_workspace() -> None:
    """The measure tells off-workspace points apart: the upright ho2018 arm's tips lie on a dome
    (it bends, it barely shortens), so a point on its axis 100 mm above the base, well within
    its reach from the base and below its straight tip, lies tens of mm from anything it
    reaches."""
    spec = get_preset("ho2018")
    tips = reachable_tips(spec)
    under_dome = np.array([[0.0, 0.0, 0.100]])
    assert np.linalg.norm(under_dome) < spec.max_reach_m
    assert under_dome[0, 2] < tips[:, 2].max() - 0.05
    assert reach_distances(spec, under_dome)[0] * 1e3 > 20.0


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
