"""Tasks: where the target is at each control step, and when an episode ends.

* :class:`ReachTask` draws a random target from the preset's reachable set each episode.
* :class:`TrackTask` moves the target along a path at constant speed (Wang et al. 2023 track
  pentagram and circle paths; docs/architecture.md, "Tasks and metrics"), for a number of cycles.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import require_positive
from soft_gym.robots.spec import ArmSpec
from soft_gym.tasks.paths import PATH_SHAPES, PathSpec, make_reference_trajectory, path_polyline
from soft_gym.tasks.workspace import reachable_tips


class ReachTask:
    """Reach a random reachable target within ``episode_steps`` control steps."""

    name = "reach"

    def __init__(self, spec: ArmSpec, episode_steps: int = 100) -> None:
        if episode_steps < 1:
            raise ValueError(f"episode_steps must be >= 1, got {episode_steps!r}")
        self.spec = spec
        self.episode_steps = int(episode_steps)
        self.targets = reachable_tips(spec)
        self.target_m = self.targets[0]

    def reset(self, rng: np.random.Generator) -> None:
        self.target_m = self.targets[rng.integers(len(self.targets))]

    def target(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        """Current and next target (m)."""
        return self.target_m, self.target_m

    def is_over(self, step: int) -> bool:
        return step >= self.episode_steps


class TrackTask:
    """Follow a path whose target advances one point per control step.

    Args:
        spec: the arm.
        path: one of ``PATH_SHAPES`` or ``"waypoints"``.
        cycles: how many times the path is traversed.
        speed_m_s: target speed (m/s); default: one cycle of a circle in 20 s.
        scale: path radius as a fraction of the workspace's lateral radius.
        waypoints_m: user points (m, base frame) for ``path="waypoints"``.
    """

    name = "track"

    def __init__(self, spec: ArmSpec, path: str = "circle", cycles: int = 1,
                 speed_m_s: float | None = None, scale: float = 0.5,
                 waypoints_m: np.ndarray | None = None) -> None:
        if path not in PATH_SHAPES + ("waypoints",):
            raise ValueError(f"path must be one of {list(PATH_SHAPES) + ['waypoints']}, got {path!r}")
        require_positive("scale", scale)
        tips = reachable_tips(spec)
        lateral = np.linalg.norm(tips[:, :2], axis=1)
        radius = float(scale * np.percentile(lateral, 75))
        # a plane across the workspace, normal to the arm axis, at the reachable set's mid height
        center = (0.0, 0.0, float(np.median(tips[:, 2])))
        if speed_m_s is None:
            speed_m_s = 2 * np.pi * radius / 20.0
        self.spec = spec
        self.path_spec = PathSpec(
            shape=path, center_m=center, radius_m=radius, speed_m_s=speed_m_s, cycles=cycles,
            waypoints_m=None if waypoints_m is None else tuple(map(tuple, np.asarray(waypoints_m))))
        self.trajectory_m = make_reference_trajectory(self.path_spec, spec.control_period_s)
        self.polyline_m = path_polyline(self.path_spec)
        self.episode_steps = len(self.trajectory_m)

    def reset(self, rng: np.random.Generator) -> None:
        pass

    def target(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        last = len(self.trajectory_m) - 1
        return self.trajectory_m[min(step, last)], self.trajectory_m[min(step + 1, last)]

    def is_over(self, step: int) -> bool:
        return step >= self.episode_steps
