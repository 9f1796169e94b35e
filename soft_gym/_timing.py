"""The time window shared by scenario loads and visual faults.

A window ``[start_s, end_s)`` on the simulator's clock (``sim.time_s``, s); ``end_s=None`` means
until the episode ends. Loads (:mod:`soft_gym.scenarios.loads`) and camera faults
(:mod:`soft_gym.sensors.faults`) inherit it, so both take ``start_s`` / ``end_s`` keywords and
check them the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soft_gym._validation import require_non_negative

_NUMBERS = (int, float, np.integer, np.floating)


@dataclass
class TimeWindow:
    """A time window ``[start_s, end_s)`` (s); ``end_s=None``: open-ended.

    Subclasses that define ``__post_init__`` call :meth:`check_window` themselves (after setting
    any window field they derive).
    """

    start_s: float = 0.0
    end_s: float | None = None

    def __post_init__(self) -> None:
        self.check_window()

    def check_window(self) -> None:
        """Raise ``ValueError`` unless ``start_s`` is finite and >= 0 and ``end_s`` is ``None`` or
        finite and > ``start_s``."""
        for name in ("start_s", "end_s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, _NUMBERS + (type(None),)) \
                    or (value is None and name == "start_s"):
                allowed = "a number >= 0" if name == "start_s" else "None or a number > start_s"
                raise ValueError(f"{name} must be {allowed} (s), got {value!r}")
        require_non_negative("start_s", self.start_s)
        if self.end_s is not None and (not np.isfinite(self.end_s) or self.end_s <= self.start_s):
            raise ValueError(f"end_s must be None or > start_s={self.start_s}, got {self.end_s!r}")

    def active(self, time_s: float) -> bool:
        """Whether ``time_s`` (s) lies in the window ``[start_s, end_s)``."""
        return time_s >= self.start_s and (self.end_s is None or time_s < self.end_s)
