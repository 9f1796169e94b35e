"""The reach and track tasks of ``soft_gym.tasks.tasks`` on a known reachable set: the checks
that mutation testing found missing (docs/mutation_testing.md).

Each test pins a documented behaviour of the reach and track tasks: episode length and
termination, random targets drawn from the whole reachable set, a fixed goal within reach, the
tolerance in millimetres, the track path's radius, centre and default speed taken from the
reachable set, the presented (current, next) targets, waypoint checks and the episode-length
limit. The reachable set is replaced by a small known set of points (instead of a simulation),
so every reference value is computed here by hand or with the public path functions.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.tasks.paths import PathSpec, make_reference_trajectory, path_polyline
from soft_gym.tasks.tasks import MAX_TRACK_STEPS, ReachTask, TrackTask, within_reach

SPEC = get_preset("wang2023")  # max reach 144 mm, 20 Hz control
# the same arm with a 143.4 mm thread: a reach whose rounding to whole millimetres shows
SHORT = dataclasses.replace(SPEC, name="short", segments=(
    dataclasses.replace(SPEC.segments[0], thread_length_m=0.1434),))

# eight reachable tips: lateral radii 0..70 mm, heights 100..121 mm
TIPS = np.array([[0.010 * k * np.cos(k), 0.010 * k * np.sin(k), 0.100 + 0.003 * k]
                 for k in range(8)])
LATERAL_75 = float(np.percentile(np.hypot(TIPS[:, 0], TIPS[:, 1]), 75))  # 52.5 mm
MEDIAN_Z = float(np.median(TIPS[:, 2]))  # 110.5 mm


def test_reach_defaults_one_hundred_steps_and_no_tolerance() -> None:
    task = ReachTask(SPEC, reachable_tips_m=TIPS)
    assert task.spec is SPEC
    assert task.name == "reach" and task.episode_steps == 100 and task.tolerance_mm is None
    assert not task.is_over(99) and task.is_over(100) and task.is_over(150)
    assert not task.is_reached(0.0), "without a tolerance the goal is never reached"


def test_reach_episode_steps_bounds() -> None:
    """One step is the shortest episode; zero is refused with the parameter named first."""
    task = ReachTask(SPEC, reachable_tips_m=TIPS, episode_steps=1)
    assert not task.is_over(0) and task.is_over(1)
    assert ReachTask(SPEC, reachable_tips_m=TIPS, episode_steps=7).episode_steps == 7
    with pytest.raises(ValueError, match=r"^episode_steps must be .*>= 1, got 0"):
        ReachTask(SPEC, reachable_tips_m=TIPS, episode_steps=0)


@pytest.mark.smoke
def test_random_targets_come_from_the_whole_reachable_set() -> None:
    """Before the first reset the target is the set's first point; each reset draws one of
    its points, every one of them over enough episodes, reproducibly for a seed; the current
    and next targets presented are both that point."""
    task = ReachTask(SPEC, reachable_tips_m=TIPS)
    np.testing.assert_array_equal(task.targets, TIPS)
    np.testing.assert_array_equal(task.target_m, TIPS[0])
    rng = np.random.default_rng(0)
    drawn = []
    for _ in range(200):
        task.reset(rng)
        index = int(np.flatnonzero(np.all(TIPS == task.target_m, axis=1))[0])
        drawn.append(index)
        current, upcoming = task.target(5)
        np.testing.assert_array_equal(current, TIPS[index])
        np.testing.assert_array_equal(upcoming, TIPS[index])
    assert sorted(set(drawn)) == list(range(len(TIPS))), sorted(set(drawn))
    again = ReachTask(SPEC, reachable_tips_m=TIPS)
    rng = np.random.default_rng(0)
    for index in drawn[:20]:
        again.reset(rng)
        np.testing.assert_array_equal(again.target_m, TIPS[index])


def test_a_fixed_goal_stays_put_and_is_a_copy() -> None:
    goal = [0.02, -0.01, 0.11]
    task = ReachTask(SPEC, reachable_tips_m=TIPS, target_m=goal)
    goal[0] = 0.5
    for _ in range(3):
        task.reset(np.random.default_rng(1))
        current, upcoming = task.target(0)
        np.testing.assert_array_equal(current, [0.02, -0.01, 0.11])
        np.testing.assert_array_equal(upcoming, [0.02, -0.01, 0.11])
    assert task.targets.shape == (1, 3)
    task.targets[0, 0] = 9.0
    np.testing.assert_array_equal(task.fixed_target, [0.02, -0.01, 0.11])


def test_tolerance_is_in_millimetres_and_inclusive() -> None:
    task = ReachTask(SPEC, reachable_tips_m=TIPS, tolerance_mm=2.5)
    assert task.tolerance_mm == 2.5
    assert task.is_reached(0.0025) and task.is_reached(0.001)
    assert not task.is_reached(0.00251) and not task.is_reached(2.0)
    with pytest.raises(ValueError, match=r"^tolerance_mm must be"):
        ReachTask(SPEC, reachable_tips_m=TIPS, tolerance_mm=0.0)


def test_within_reach_is_inclusive_and_names_the_point() -> None:
    """A point exactly at the arm's reach is accepted; one beyond is refused with a message
    naming the argument, the arm, its reach and the point's distance (mm)."""
    reach = SPEC.max_reach_m
    np.testing.assert_array_equal(within_reach(SPEC, "start_m", [0.0, 0.0, reach]),
                                  [0.0, 0.0, reach])
    far = [0.0, 0.09, 0.12]  # 150 mm from the base
    message = (r"^goal_m must lie within the wang2023 arm's reach of 144 mm from its base, "
               r"got a point 150 mm away$")
    with pytest.raises(ValueError, match=message):
        within_reach(SPEC, "goal_m", far)
    with pytest.raises(ValueError, match=r"^target_m must lie within the wang2023 arm's reach"):
        ReachTask(SPEC, reachable_tips_m=TIPS, target_m=far)
    assert SHORT.max_reach_m == pytest.approx(0.1434)
    with pytest.raises(ValueError, match=r"^goal_m must lie within the short arm's reach of "
                                         r"143 mm from its base, got a point 145 mm away$"):
        within_reach(SHORT, "goal_m", [0.0, 0.08, 0.1215])  # 145.47 mm


def test_within_reach_wants_one_finite_point() -> None:
    with pytest.raises(ValueError, match=r"^goal_m must be finite"):
        within_reach(SPEC, "goal_m", [0.01, np.nan, 0.1])
    for bad in ([0.01, 0.1], [[0.01, 0.0, 0.1]], [0.0, 0.0, 0.1, 0.0]):
        with pytest.raises(ValueError, match=r"^goal_m must have shape \(3,\)"):
            within_reach(SPEC, "goal_m", bad)


def test_track_path_geometry_comes_from_the_reachable_set() -> None:
    """Radius ``scale`` x the 75th percentile of the set's lateral radii, centre on the arm axis
    at the set's median height, default speed one circle in 20 s: the circle is 400 targets at
    20 Hz, the reference trajectory of that ``PathSpec``."""
    task = TrackTask(SPEC, TIPS)
    assert task.name == "track" and task.spec is SPEC
    radius = 0.5 * LATERAL_75
    spec = task.path_spec
    assert spec.shape == "circle" and spec.cycles == 1 and spec.waypoints_m is None
    assert spec.radius_m == pytest.approx(radius, rel=1e-12)
    assert spec.center_m == pytest.approx((0.0, 0.0, MEDIAN_Z), abs=1e-15)
    assert spec.speed_m_s == pytest.approx(2 * np.pi * radius / 20.0, rel=1e-12)
    reference = make_reference_trajectory(
        PathSpec(shape="circle", center_m=(0.0, 0.0, MEDIAN_Z), radius_m=radius,
                 speed_m_s=2 * np.pi * radius / 20.0), SPEC.control_period_s)
    assert task.episode_steps == len(reference) == 400
    np.testing.assert_allclose(task.trajectory_m, reference, rtol=0, atol=1e-12)


def test_track_options_reach_the_path() -> None:
    task = TrackTask(SPEC, TIPS, path="pentagram", cycles=3, speed_m_s=0.01, scale=0.8)
    radius = 0.8 * LATERAL_75
    path_spec = PathSpec(shape="pentagram", center_m=(0.0, 0.0, MEDIAN_Z), radius_m=radius,
                         speed_m_s=0.01, cycles=3)
    np.testing.assert_allclose(task.path_m, path_polyline(path_spec), rtol=0, atol=1e-12)
    reference = make_reference_trajectory(path_spec, SPEC.control_period_s)
    assert task.episode_steps == len(reference)
    np.testing.assert_allclose(task.trajectory_m, reference, rtol=0, atol=1e-12)


@pytest.mark.smoke
def test_track_presents_current_and_next_target_and_holds_the_last() -> None:
    task = TrackTask(SPEC, TIPS, speed_m_s=0.02)
    trajectory, last = task.trajectory_m, task.episode_steps - 1
    for step in (0, 1, last // 2, last - 1):
        current, upcoming = task.target(step)
        np.testing.assert_array_equal(current, trajectory[step])
        np.testing.assert_array_equal(upcoming, trajectory[step + 1])
    for step in (last, last + 1, last + 10):
        current, upcoming = task.target(step)
        np.testing.assert_array_equal(current, trajectory[last])
        np.testing.assert_array_equal(upcoming, trajectory[last])
    assert not task.is_over(last) and task.is_over(last + 1)
    task.reset(np.random.default_rng(0))
    np.testing.assert_array_equal(task.trajectory_m, trajectory)
    assert not task.is_reached(0.0)


def test_track_waypoints_within_reach() -> None:
    """User waypoints are kept as given; a point exactly at the reach is allowed."""
    reach = SPEC.max_reach_m
    points = np.array([[0.03, 0.0, 0.10], [0.0, 0.03, 0.11], [0.0, 0.0, reach]])
    task = TrackTask(SPEC, TIPS, path="waypoints", waypoints_m=points, speed_m_s=0.01)
    assert task.path_spec.shape == "waypoints"
    assert task.path_spec.waypoints_m == tuple(map(tuple, points))
    two = TrackTask(SPEC, TIPS, path="waypoints", waypoints_m=points[:2], speed_m_s=0.01)
    assert two.path_spec.waypoints_m == tuple(map(tuple, points[:2]))


@pytest.mark.parametrize("points", [np.zeros((1, 3)), np.zeros((4, 2)), np.zeros((2, 4)),
                                    np.zeros(3)])
def test_track_waypoints_need_two_points_in_3d(points: np.ndarray) -> None:
    with pytest.raises(ValueError, match=r"^waypoints_m must be at least 2 points \(x, y, z\)"):
        TrackTask(SPEC, TIPS, path="waypoints", waypoints_m=points)


def test_track_waypoints_beyond_reach_are_refused() -> None:
    points = [[0.03, 0.0, 0.10], [0.0, 0.09, 0.12]]  # the second 150 mm away
    message = (r"^waypoints_m must lie within the wang2023 arm's reach of 144 mm from its base, "
               r"got a point 150 mm away$")
    with pytest.raises(ValueError, match=message):
        TrackTask(SPEC, TIPS, path="waypoints", waypoints_m=points)
    with pytest.raises(ValueError, match=r"^waypoints_m must lie within the short arm's reach of "
                                         r"143 mm from its base, got a point 145 mm away$"):
        TrackTask(SHORT, TIPS, path="waypoints", waypoints_m=[[0.03, 0.0, 0.1], [0.0, 0.08, 0.1215]])
    with pytest.raises(ValueError, match=r"^waypoints_m must be finite"):
        TrackTask(SPEC, TIPS, path="waypoints", waypoints_m=[[0.03, 0.0, np.nan], [0.0, 0.0, 0.1]])


def test_track_bad_path_and_scale_are_named_first() -> None:
    with pytest.raises(ValueError, match=r"^path must be one of \['circle', .*'waypoints'\], "
                                         r"got 'square'"):
        TrackTask(SPEC, TIPS, path="square")
    with pytest.raises(ValueError, match=r"^scale must be"):
        TrackTask(SPEC, TIPS, scale=0.0)


def test_track_episode_length_limit() -> None:
    """At most ``MAX_TRACK_STEPS`` steps: the slowest allowed speed is one path length x cycles
    per ``MAX_TRACK_STEPS`` control periods. Just above it the task is built; below it the task
    is refused with a message giving the cycles, the step count, the limit, that slowest speed,
    the path length and the most cycles allowed at the requested speed."""
    radius = 0.45 * LATERAL_75  # a 148.4 mm circle
    polyline = path_polyline(PathSpec(shape="circle", center_m=(0.0, 0.0, MEDIAN_Z),
                                      radius_m=radius, speed_m_s=1.0))
    closed = np.vstack([polyline, polyline[:1]])  # the last point back to the first
    length = float(np.linalg.norm(np.diff(closed, axis=0), axis=1).sum())
    slowest = 3 * length / (MAX_TRACK_STEPS * SPEC.control_period_s)
    task = TrackTask(SPEC, TIPS, cycles=3, speed_m_s=slowest * 1.01, scale=0.45)
    assert MAX_TRACK_STEPS * 0.98 < task.episode_steps <= MAX_TRACK_STEPS
    # at the limit itself the episode never runs over it (counted on the closed path)
    for factor in (1.0, 1.0001):
        task = TrackTask(SPEC, TIPS, cycles=3, speed_m_s=slowest * factor, scale=0.45)
        assert MAX_TRACK_STEPS * 0.999 < task.episode_steps <= MAX_TRACK_STEPS, factor
    with pytest.raises(ValueError, match="at most 72000 steps"):
        TrackTask(SPEC, TIPS, cycles=3, speed_m_s=slowest * 0.999, scale=0.45)
    speed = slowest * 0.7  # 72000 / 0.7 = 102857 steps; 2.1 cycles would fit
    with pytest.raises(ValueError) as error:
        TrackTask(SPEC, TIPS, cycles=3, speed_m_s=speed, scale=0.45)
    message = str(error.value)
    assert message.startswith("cycles=3 at speed_m_s="), message
    for part in (f" {MAX_TRACK_STEPS / 0.7:.3g}-step episode", f"at most {MAX_TRACK_STEPS} steps",
                 "(MAX_TRACK_STEPS: an hour at 20 Hz)", "(148 mm x 3 cycles)",
                 f"speed_m_s must be >= {slowest:.3g} for this path",
                 f"({length * 1e3:.0f} mm x 3 cycles)", "cycles <= 2 at this speed"):
        assert part in message, (part, message)
    # fewer cycles are suggested only when at least one fits at that speed
    for factor, suggestion in ((0.5, ", or cycles <= 1 at this speed"), (0.2, "")):
        with pytest.raises(ValueError) as error:  # 1.5 and 0.6 cycles would fit
            TrackTask(SPEC, TIPS, cycles=3, speed_m_s=slowest * factor, scale=0.45)
        assert str(error.value).endswith(f"x 3 cycles){suggestion}"), (factor, str(error.value))
