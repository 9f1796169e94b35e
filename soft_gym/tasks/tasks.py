"""Tasks: where the target is at each control step, the reward, and when an episode ends.

Every task has the face of :class:`Task` (dm_control's split: the task owns its reward and its
end, the env only composes and steps):

* :class:`ReachTask` draws a random target from the preset's reachable set each episode, or
  keeps a fixed goal (point to point, zhao2021 Section V-B), optionally ending the episode when
  the tip is within a tolerance of it.
* :class:`TrackTask` moves the target along a path at constant speed (Wang et al. 2023 track
  pentagram and circle paths; docs/architecture.md, "Tasks and metrics"), for a number of cycles.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from soft_gym._validation import as_finite_array, as_points, require_integer, require_positive
from soft_gym.robots.spec import ArmSpec
from soft_gym.tasks.paths import (PATH_SHAPES, PathSpec, make_reference_trajectory, path_length,
                                  path_polyline, surface_height, workspace_surface)

MAX_TRACK_STEPS = 72_000
"""Longest track episode (control steps): an hour of simulated time at 20 Hz."""

MIN_SURFACE_TIPS = 12
"""Fewest reachable tips a workspace surface is fitted to (two per coefficient of the quadratic
:func:`~soft_gym.tasks.paths.workspace_surface`); with fewer, paths stay in the plane."""


@runtime_checkable
class Task(Protocol):
    """What the env asks of a task.

    Attributes:
        name: ``"reach"`` or ``"track"``.
        episode_steps: control steps of a full episode.
        path_m: the path's polyline (m, (n, 3)) for drawing, or ``None`` (no path).
    """

    name: str
    episode_steps: int
    path_m: np.ndarray | None

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode (a reach task draws its target from ``rng``)."""

    def target(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        """Current and next target (m) at control step ``step``."""

    def reward(self, tip_m: np.ndarray, target_m: np.ndarray, action: np.ndarray,
               last_action: np.ndarray) -> tuple[float, float]:
        """``(reward, error_m)`` of a step that took the tip to ``tip_m``."""

    def is_reached(self, error_m: float) -> bool:
        """Whether the episode ends with success (termination)."""

    def is_over(self, step: int) -> bool:
        """Whether the episode runs out after ``step`` control steps (truncation)."""


class _TrackingReward:
    """``-||tip - target|| (m) - action_rate_weight * ||a_t - a_{t-1}||^2``."""

    action_rate_weight: float = 0.0

    def reward(self, tip_m: np.ndarray, target_m: np.ndarray, action: np.ndarray,
               last_action: np.ndarray) -> tuple[float, float]:
        """``(reward, error_m)``: the tip's distance from the target (m) less the weighted
        squared change of the action."""
        error_m = float(np.linalg.norm(tip_m - target_m))
        rate = float(((action - last_action) ** 2).sum())
        return -error_m - self.action_rate_weight * rate, error_m


def _checked_tips(reachable_tips_m: Any) -> np.ndarray:
    """The arm's reachable tip positions (m, (n >= 1, 3)), checked."""
    return as_points("reachable_tips_m", reachable_tips_m)


class ReachTask(_TrackingReward):
    """Reach a target within ``episode_steps`` control steps: a random reachable one each
    episode, or the fixed ``target_m``; with ``tolerance_mm`` the episode ends (terminates) as
    soon as the tip is that close to it.

    Args:
        spec: the arm.
        episode_steps: most control steps of an episode.
        target_m: a fixed goal (m, base frame) within the arm's reach, or ``None`` for random
            reachable targets.
        tolerance_mm: distance (mm) at which the goal counts as reached, or ``None`` (the
            episode runs ``episode_steps``).
        reachable_tips_m: tip positions the arm reaches (m, (n, 3)), the random targets'
            pool (:func:`soft_gym.procedures.workspace.reachable_tips`); needed without
            ``target_m``.
        action_rate_weight: weight of the action-rate penalty in the reward.
    """

    name = "reach"
    path_m = None

    def __init__(self, spec: ArmSpec, episode_steps: int = 100, target_m: Any = None,
                 tolerance_mm: float | None = None, reachable_tips_m: Any = None,
                 action_rate_weight: float = 0.0) -> None:
        self.spec = spec
        self.episode_steps = require_integer("episode_steps", episode_steps, 1)
        self.fixed_target = None if target_m is None else within_reach(spec, "target_m", target_m)
        self.tolerance_mm = None if tolerance_mm is None else require_positive("tolerance_mm",
                                                                                 tolerance_mm)
        if self.fixed_target is None and reachable_tips_m is None:
            raise ValueError("reachable_tips_m must be given for random targets (target_m=None)")
        self.targets = _checked_tips(reachable_tips_m) if self.fixed_target is None else \
            self.fixed_target[None].copy()
        self.target_m = self.targets[0]
        self.action_rate_weight = float(action_rate_weight)

    def reset(self, rng: np.random.Generator) -> None:
        if self.fixed_target is None:
            self.target_m = self.targets[rng.integers(len(self.targets))]

    def target(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        """Current and next target (m)."""
        return self.target_m, self.target_m

    def is_over(self, step: int) -> bool:
        return step >= self.episode_steps

    def is_reached(self, error_m: float) -> bool:
        """Whether the tip at ``error_m`` from the target has reached it (``tolerance_mm``)."""
        return self.tolerance_mm is not None and error_m * 1000.0 <= self.tolerance_mm


def within_reach(spec: ArmSpec, name: str, point_m: Any) -> np.ndarray:
    """``point_m`` as a float (3,) array, refused with a ``ValueError`` naming ``name`` unless it
    is three finite numbers (not booleans or text) within the arm's reach of its base
    (:attr:`ArmSpec.max_reach_m`)."""
    try:
        kind = np.asarray(point_m).dtype.kind
    except (TypeError, ValueError):  # ragged nesting: as_finite_array says what is wrong
        kind = "f"
    if kind not in "iuf":
        raise ValueError(f"{name} must be three numbers (m), got {point_m!r}")
    point = as_finite_array(name, point_m, shape=(3,))
    if np.linalg.norm(point) > spec.max_reach_m:
        raise ValueError(f"{name} must lie within the {spec.name} arm's reach of "
                         f"{spec.max_reach_m * 1e3:.0f} mm from its base, got a point "
                         f"{np.linalg.norm(point) * 1e3:.0f} mm away")
    return point


class TrackTask(_TrackingReward):
    """Follow a path whose target advances one point per control step.

    Placement on the arm's workspace, from its reachable tips alone (deterministic): a built-in
    shape of radius ``scale`` x the 75th percentile of the tips' lateral distance from the arm
    axis is centred on the axis, in the plane normal to it at the tips' median height
    (``placement == "plane"``) when that plane stays within the tips' RMS scatter about the
    quadratic surface fitted to them (:func:`~soft_gym.tasks.paths.workspace_surface`) over the
    whole disk the path occupies. Otherwise the plane misses the workspace (an upright arm's
    workspace is a dome whose median-height plane lies below it far from the axis) and the
    shape, seen along the axis, is lifted onto that surface (``placement == "surface"``), as
    ho2018 Section 3.4 projects its rectangle "to the 3D workspace of the robot, which was
    approximated from the pre-training data". With fewer than :data:`MIN_SURFACE_TIPS` tips no
    surface is fitted and the plane is used. ``waypoints_m`` are used as given.

    Args:
        spec: the arm.
        reachable_tips_m: tip positions the arm reaches (m, (n, 3)), which place and size the
            path (:func:`soft_gym.procedures.workspace.reachable_tips`).
        path: one of ``PATH_SHAPES`` or ``"waypoints"``.
        cycles: how many times the path is traversed.
        speed_m_s: target speed (m/s); default: ``2 pi radius / 20 s``, one cycle of a planar
            circle in 20 s (a lifted circle, slightly longer, takes a little more).
        scale: path radius as a fraction of the workspace's lateral radius.
        waypoints_m: user points (m, base frame) for ``path="waypoints"``.
        action_rate_weight: weight of the action-rate penalty in the reward.
    """

    name = "track"

    def __init__(self, spec: ArmSpec, reachable_tips_m: Any, path: str = "circle",
                 cycles: int = 1, speed_m_s: float | None = None, scale: float = 0.5,
                 waypoints_m: np.ndarray | None = None,
                 action_rate_weight: float = 0.0) -> None:
        if path not in PATH_SHAPES + ("waypoints",):
            raise ValueError(f"path must be one of {list(PATH_SHAPES) + ['waypoints']}, got {path!r}")
        require_positive("scale", scale)
        self.action_rate_weight = float(action_rate_weight)
        tips = _checked_tips(reachable_tips_m)
        lateral = np.linalg.norm(tips[:, :2], axis=1)
        radius = float(scale * np.percentile(lateral, 75))
        # a plane across the workspace, normal to the arm axis, at the reachable set's mid height
        center = (0.0, 0.0, float(np.median(tips[:, 2])))
        self.surface = workspace_lift(tips, radius)
        self.placement = "plane" if self.surface is None or path == "waypoints" else "surface"
        lift = None
        if self.placement == "surface":
            # the surface about the path's centre on the axis: (s, t) = (x, y), height along z
            center = (0.0, 0.0, float(self.surface[0]))
            lift = (0.0,) + tuple(float(c) for c in self.surface[1:])
        if speed_m_s is None:
            speed_m_s = 2 * np.pi * radius / 20.0
        if waypoints_m is not None:
            waypoints_m = as_finite_array("waypoints_m", waypoints_m)
            if waypoints_m.ndim != 2 or waypoints_m.shape[1] != 3 or len(waypoints_m) < 2:
                raise ValueError("waypoints_m must be at least 2 points (x, y, z) in metres, "
                                 f"shape (n, 3), got shape {waypoints_m.shape}")
            farthest = float(np.linalg.norm(waypoints_m, axis=1).max())
            if farthest > spec.max_reach_m:
                raise ValueError(
                    f"waypoints_m must lie within the {spec.name} arm's reach of "
                    f"{spec.max_reach_m * 1e3:.0f} mm from its base, got a point "
                    f"{farthest * 1e3:.0f} mm away")
        self.spec = spec
        self.path_spec = PathSpec(
            shape=path, center_m=center, radius_m=radius, speed_m_s=speed_m_s, cycles=cycles,
            waypoints_m=None if waypoints_m is None else tuple(map(tuple, waypoints_m)),
            lift_m=lift)
        self.path_m = path_polyline(self.path_spec)
        length_m = path_length(self.path_spec)  # closed: the last point back to the first
        steps = self.path_spec.cycles * length_m / (self.path_spec.speed_m_s
                                                    * spec.control_period_s)
        trajectory = None
        if steps <= MAX_TRACK_STEPS * 1.01:  # cheap to build: count its steps exactly
            trajectory = make_reference_trajectory(self.path_spec, spec.control_period_s)
            steps = len(trajectory)
        if steps > MAX_TRACK_STEPS:
            slowest = self.path_spec.cycles * length_m / (MAX_TRACK_STEPS * spec.control_period_s)
            most_cycles = int(MAX_TRACK_STEPS * self.path_spec.speed_m_s * spec.control_period_s
                              // length_m)
            raise ValueError(
                f"cycles={self.path_spec.cycles} at speed_m_s={self.path_spec.speed_m_s:.3g} "
                f"make a {steps:.3g}-step episode; at most {MAX_TRACK_STEPS} steps are allowed "
                f"(MAX_TRACK_STEPS: an hour at {1 / spec.control_period_s:g} Hz), so speed_m_s "
                f"must be >= {slowest:.3g} for this path ({length_m * 1e3:.0f} mm x "
                f"{self.path_spec.cycles} cycles)"
                + (f", or cycles <= {most_cycles} at this speed" if most_cycles >= 1 else ""))
        self.trajectory_m = trajectory
        self.episode_steps = len(self.trajectory_m)

    def reset(self, rng: np.random.Generator) -> None:
        pass

    def target(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        last = len(self.trajectory_m) - 1
        return self.trajectory_m[min(step, last)], self.trajectory_m[min(step + 1, last)]

    def is_over(self, step: int) -> bool:
        return step >= self.episode_steps

    def is_reached(self, error_m: float) -> bool:
        """A tracked path is never "reached": track episodes end by truncation only."""
        return False


def workspace_lift(reachable_tips_m: Any, radius_m: float) -> np.ndarray | None:
    """The workspace surface a path of radius ``radius_m`` about the arm axis is lifted onto, or
    ``None`` when the plane normal to the axis at the tips' median height will do.

    The quadratic ``z = q(x, y)`` (m) fitted to the reachable tips
    (:func:`~soft_gym.tasks.paths.workspace_surface`, ho2018 Section 3.4) is compared with the
    median-height plane over the disk of radius ``radius_m`` about the axis (a polar grid of
    points): where the largest gap between them exceeds the RMS distance of the tips from the
    surface, the plane leaves the band the reachable tips occupy and the surface is returned.

    Args:
        reachable_tips_m: reachable tip positions (m, base frame), shape (n, 3).
        radius_m: the path's radius (m, >= 0).

    Returns:
        The surface's 6 coefficients (:func:`~soft_gym.tasks.paths.surface_height`, in m), or
        ``None`` (the plane; also with fewer than :data:`MIN_SURFACE_TIPS` tips).

    Raises:
        ValueError: tips not of shape (n >= 1, 3) or not finite, or a negative radius.
    """
    tips = _checked_tips(reachable_tips_m)
    radius = float(radius_m)
    if not np.isfinite(radius) or radius < 0.0:
        raise ValueError(f"radius_m must be a finite distance >= 0 (m), got {radius_m!r}")
    if len(tips) < MIN_SURFACE_TIPS:
        return None
    surface = workspace_surface(tips)
    scatter = float(np.sqrt(np.mean((tips[:, 2] - surface_height(surface, tips[:, 0],
                                                                  tips[:, 1])) ** 2)))
    rho, angle = np.meshgrid(np.linspace(0.0, radius, 9),
                             np.linspace(0.0, 2.0 * np.pi, 36, endpoint=False))
    gap = np.abs(surface_height(surface, rho * np.cos(angle), rho * np.sin(angle))
                 - float(np.median(tips[:, 2])))
    return surface if float(gap.max()) > scatter else None
