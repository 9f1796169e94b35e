"""The calibration of every feedback source that learns before its first estimate, by name.

A calibrating source (``calibrates = True``) is handed its calibration by the procedure
registered for it in :data:`CALIBRATIONS`: the procedure drives a private simulator of the arm
(the env's fixed loads on it, its own fresh sensors in a clear view), computes what the source
learns, keeps it in the calibration cache (:mod:`soft_gym.sensing.calibration_cache`) and calls
``source.set_calibration(...)``. The env's own simulator is never touched, so making an env or
recalibrating leaves its episodes as they were.

| source                       | procedure                                                        |
|------------------------------|------------------------------------------------------------------|
| `fused`, `camera`, `fbg`     | wang2023: vision map at rest, F-emp from the spiral exploration  |
| `strain_sr`                  | zhao2021: random exploration, SFE-PD networks' training          |
| `encoder_dnn`                | zou2022: ASES-labelled data set, the DNN's training              |

``strain_sr`` and ``encoder_dnn`` given ``sensing={"dataset": <id>}`` (and ``"dataset_root"``)
train on that dataset of ``python -m eval datasets`` instead of collecting (checked against the
settings they would collect with; see :mod:`soft_gym.datasets.training`).
"""

from __future__ import annotations

from typing import Any, Callable

from soft_gym._registry import Registry
from soft_gym.engines import make_simulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackSource
from soft_gym.simulator import Simulator

Calibration = Callable[[FeedbackSource, CalibrationContext, bool], None]


def calibration_key(spec: ArmSpec, loads: list, settle_s: float,
                    sensor_settings: dict[str, Any]) -> dict[str, Any]:
    """The cache key of everything an env decides that changes a calibration: the arm, its
    fixed loads, the rest before calibrating (s) and each simulated sensor's user settings (the
    source adds its own options, :meth:`~soft_gym.sensing.feedback_base.FeedbackSource.calibration_key`;
    the cache adds the package's source digest and the libraries' versions)."""
    return {"arm": repr(spec), "scenario": repr(loads), "settle_s": settle_s,
            "sensors": repr(sorted((name, repr(settings))
                                   for name, settings in sensor_settings.items()))}


def private_simulator(context: CalibrationContext) -> Simulator:
    """A new simulator of the context's arm with fresh copies of the env's fixed loads."""
    sim = make_simulator(context.spec)
    try:
        for load in context.make_loads():
            sim.add_load(load)
    except Exception:
        sim.close()
        raise
    return sim


def dataset_options(source: FeedbackSource) -> dict[str, Any]:
    """``dataset`` and ``dataset_root`` of a source given a dataset to train on (its
    ``sensing={"dataset": id}``), else nothing (the procedure collects)."""
    dataset = getattr(source, "dataset", None)
    if dataset is None:
        return {}
    return {"dataset": dataset, "dataset_root": getattr(source, "dataset_root", None)}


CALIBRATIONS: Registry[Calibration] = Registry("calibration")
"""Calibration procedures by feedback-source name, filled by each paper's registration
(:func:`soft_gym.papers.register_paper`)."""


def calibrate(source: FeedbackSource, context: CalibrationContext,
              use_cache: bool = True) -> None:
    """Run ``source``'s calibration procedure (nothing for a source that does not calibrate).

    Raises:
        ValueError: a calibrating source without a registered procedure.
    """
    if not source.calibrates:
        return
    if source.name not in CALIBRATIONS:
        raise ValueError(f"feedback {source.name!r} calibrates but has no calibration "
                         f"procedure: register one in CALIBRATIONS (registered: "
                         f"{list(CALIBRATIONS)})")
    CALIBRATIONS[source.name](source, context, use_cache)


__all__ = ["CALIBRATIONS", "calibrate", "calibration_key", "dataset_options",
           "private_simulator"]
