"""Tasks (reach, track) and their reference paths: targets, reward and episode end.

Tasks are pure: they never drive a simulator. The reachable tips that place their targets and
paths come from :func:`soft_gym.procedures.workspace.reachable_tips`.
"""

from soft_gym.tasks.tasks import ReachTask, Task, TrackTask

__all__ = ["ReachTask", "Task", "TrackTask"]
