"""Tasks (reach, track), reference paths and reachable workspaces."""

from soft_gym.tasks.tasks import ReachTask, TrackTask

__all__ = ["ReachTask", "TrackTask"]
