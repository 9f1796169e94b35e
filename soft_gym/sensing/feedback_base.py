"""The feedback-source protocol: what a source is, what it returns, and the registry by name.

Kept apart from the sources themselves (:mod:`soft_gym.sensing.feedback`,
:mod:`soft_gym.sensing.zou_feedback`) so that every module defining sources imports this one and
none imports another. See docs/architecture.md, "Feedback sources".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from soft_gym.sensing.measurement import Measurement


@dataclass
class FeedbackEstimate:
    """One step's estimate from a feedback source.

    Attributes:
        position_m: tip position (m, base frame).
        quaternion: tip orientation (x, y, z, w).
        shape_m: backbone points (m, base frame, (n, 3)) where the source estimates a shape.
        shape_points_m: seven backbone points ``P_0..P_6`` from the base to the tip (m, (7, 3)),
            at sixths of the rest length (zhao2021 Section III's key points with the base; the
            seven points of zou2022's shape), where the source estimates them (the ``shape``
            obs part).
        details: what ``info["estimates"]`` reports (e.g. camera, F-emp and fused positions).
    """

    position_m: np.ndarray
    quaternion: np.ndarray
    shape_m: np.ndarray | None = None
    shape_points_m: np.ndarray | None = None
    details: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class CalibrationContext:
    """What a source may use to calibrate: the simulator (the arm at rest, loads attached), its
    sensors, and the cache key of everything else that changes a calibration."""

    sim: Any
    sensors: dict[str, Any]
    settle_s: float
    key: dict[str, Any]


class FeedbackSource:
    """Base class. Subclasses set :attr:`name` and :attr:`sensors` and implement :meth:`estimate`.

    Args:
        options: the source's own options (the env's ``sensing=`` dict); a source without
            options refuses any.
    """

    name: ClassVar[str] = ""
    sensors: ClassVar[tuple[str, ...]] = ()
    """Sensor names the source reads (see :data:`soft_gym.sensors.SENSORS`)."""
    calibrates: ClassVar[bool] = False
    """Whether :meth:`calibrate` does anything (``reset(options={"recalibrate": True})``)."""
    estimates_shape: ClassVar[bool] = False
    """Whether the source gives the backbone points of the env's ``shape`` part
    (:meth:`shape_points`)."""

    def __init__(self, options: dict | None = None) -> None:
        if options:
            raise ValueError(f"sensing options are for the camera/F-emp pipeline (feedback "
                             f"'fused', 'camera' or 'fbg'); feedback {self.name!r} takes none, "
                             f"got {sorted(options)}")

    def sensor_options(self) -> dict[str, dict]:
        """Default keyword arguments of the sensors the source needs (the user's override)."""
        return {}

    def calibrate(self, context: CalibrationContext, use_cache: bool = True) -> None:
        """Calibrate from the arm at rest (default: nothing to calibrate)."""

    def restore(self) -> None:
        """Return to the state right after calibration (``reset(seed=...)``)."""

    def estimate(self, measurement: Measurement, sim) -> FeedbackEstimate:
        """The estimate from one step's measurement."""
        raise NotImplementedError

    def shape_points(self, estimate: FeedbackEstimate, sim) -> np.ndarray:
        """``P_0..P_6`` (m, (7, 3)) of this step's ``estimate``, asked for only by an env with a
        ``shape`` part (default: the estimate's ``shape_points_m``)."""
        return estimate.shape_points_m


FEEDBACK_SOURCES: dict[str, type[FeedbackSource]] = {}
"""Registered feedback sources by name."""


def register_feedback_source(cls: type[FeedbackSource]) -> type[FeedbackSource]:
    """Class decorator: make ``cls`` available as ``feedback=cls.name``."""
    if not cls.name or cls.name in FEEDBACK_SOURCES:
        raise ValueError(f"feedback source name must be new and non-empty, got {cls.name!r}")
    FEEDBACK_SOURCES[cls.name] = cls
    return cls


def make_feedback_source(name: str, options: dict | None = None) -> FeedbackSource:
    """Build the registered source ``name`` with its options."""
    if not isinstance(name, str) or name not in FEEDBACK_SOURCES:
        raise ValueError(f"feedback must be one of {sorted(FEEDBACK_SOURCES)}, got {name!r}")
    if options is not None and not isinstance(options, dict):
        raise ValueError(f"sensing must be None or a dict of options, got {options!r}")
    return FEEDBACK_SOURCES[name](options)
