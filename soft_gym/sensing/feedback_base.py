"""The feedback-source protocol: what a source is, what it is given, and what it returns.

A source estimates from one step's :class:`~soft_gym.sensors.measurement.Measurement` alone (the
sensors' readings and the commands sent), as a real robot's estimator does: it never holds the
simulator. What it learns before the first step (a calibration) is computed by a procedure
(:mod:`soft_gym.procedures.calibration`) that drives a private simulator and hands the result
to :meth:`FeedbackSource.set_calibration`. Kept apart from the sources themselves
(:mod:`soft_gym.sensing.feedback`, :mod:`soft_gym.papers.zou2022.feedback`), so every module
defining sources imports this one and none imports another; the registry
(:data:`soft_gym.sensing.FEEDBACK_SOURCES`) is filled in the package's ``__init__``. See
docs/architecture.md, "Feedback sources".
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar

import numpy as np

from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.measurement import Measurement


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
    """What a source knows of the arm and what a calibration procedure may build.

    Attributes:
        spec: the arm (:class:`~soft_gym.robots.spec.ArmSpec`).
        settle_s: rest before a calibration starts (s).
        key: the calibration cache key of everything else that changes a calibration (arm,
            fixed loads, settle time, sensor settings).
        make_sensor: a fresh sensor by name, configured as the env's own but without visual
            faults (calibration happens in a clear view).
        make_loads: fresh copies of the env's fixed loads, for a private simulator.
    """

    spec: ArmSpec
    settle_s: float = 0.0
    key: dict[str, Any] = field(default_factory=dict)
    make_sensor: Callable[[str], Any] | None = None
    make_loads: Callable[[], list] = list


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
    """Whether a calibration procedure must run before the first estimate
    (:data:`soft_gym.procedures.calibration.CALIBRATIONS`; ``reset(options={"recalibrate":
    True})`` runs it again)."""
    estimates_shape: ClassVar[bool] = False
    """Whether the source gives the backbone points of the env's ``shape`` part
    (:meth:`shape_points`)."""

    def __init__(self, options: dict | None = None) -> None:
        if options:
            raise ValueError(f"feedback {self.name!r} takes no sensing options, got "
                             f"{sorted(options)}")
        self.spec: ArmSpec | None = None

    def sensor_options(self) -> dict[str, dict]:
        """Default keyword arguments of the sensors the source needs (the user's override)."""
        return {}

    def prepare(self, context: CalibrationContext) -> None:
        """Learn the arm the source estimates for (called once, when the env is made)."""
        self.spec = context.spec

    def calibration_key(self) -> dict[str, Any]:
        """What besides the context's key changes this source's calibration (its options)."""
        return {}

    def set_calibration(self, calibration: Any) -> None:
        """Take a calibration procedure's result and :meth:`restore` to it (calibrating
        sources only)."""
        raise ValueError(f"feedback {self.name!r} does not calibrate")

    def restore(self) -> None:
        """Return to the state right after calibration (``reset(seed=...)``)."""

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode (every ``reset``, after :meth:`restore`): draw any randomness of
        the estimates from ``rng``, the env's ``np_random`` (default: none)."""

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        """The estimate from one step's measurement."""
        raise NotImplementedError

    def shape_points(self, estimate: FeedbackEstimate) -> np.ndarray:
        """``P_0..P_6`` (m, (7, 3)) of this step's ``estimate``, asked for only by an env with a
        ``shape`` part (default: the estimate's ``shape_points_m``)."""
        return estimate.shape_points_m


def dataset_option(options: dict[str, Any]) -> tuple[str | None, str | os.PathLike | None]:
    """Pop ``dataset`` (a dataset id, or ``None``) and ``dataset_root`` (a directory, or
    ``None``) from a source's ``options``; ``ValueError`` for another type."""
    dataset, root = options.pop("dataset", None), options.pop("dataset_root", None)
    if dataset is not None and not isinstance(dataset, str):
        raise ValueError(f"dataset must be a dataset id (str) or None, got {dataset!r}")
    if root is not None and not isinstance(root, (str, os.PathLike)):
        raise ValueError(f"dataset_root must be a directory (str or path) or None, got {root!r}")
    if root is not None and dataset is None:
        raise ValueError("dataset_root is given without a dataset")
    return dataset, root
