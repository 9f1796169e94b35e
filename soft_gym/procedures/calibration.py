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

import numpy as np

from soft_gym._registry import Registry
from soft_gym.engines import make_simulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.procedures.wang2023_calibration import calibrate_pipeline
from soft_gym.procedures.zhao2021_exploration import cached_reconstruction
from soft_gym.procedures.zou2022_dataset import cached_shape_dnn
from soft_gym.sensing.calibration_cache import cached
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackSource
from soft_gym.sensing.wang2023.pipeline import SensingPipeline
from soft_gym.sensors.stereo import StereoCamera
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


def calibrate_wang2023_pipeline(source: FeedbackSource, context: CalibrationContext,
                                use_cache: bool = True) -> None:
    """The camera/F-emp pipeline of ``fused``, ``camera`` and ``fbg`` (wang2023 Section IV-B):
    calibrated on the arm at rest after ``settle_s``, with the sensors' noise seeded by 0."""
    pipeline = SensingPipeline(context.make_sensor("image"), context.make_sensor("fbg"),
                               **source.options)

    def compute() -> tuple:
        sim = private_simulator(context)
        try:
            sim.reset(settle_s=context.settle_s)
            calibrate_pipeline(pipeline, sim, np.random.default_rng(0))
        finally:
            sim.close()
        return (pipeline.vision, pipeline.femp, pipeline.calibration_samples)

    key = {**context.key, **source.calibration_key()}
    source.set_calibration((pipeline, cached(key, compute, use_cache=use_cache)))


def _dataset_options(source: FeedbackSource) -> dict[str, Any]:
    """``dataset`` and ``dataset_root`` of a source given a dataset to train on (its
    ``sensing={"dataset": id}``), else nothing (the procedure collects)."""
    dataset = getattr(source, "dataset", None)
    if dataset is None:
        return {}
    return {"dataset": dataset, "dataset_root": getattr(source, "dataset_root", None)}


def calibrate_zhao2021_reconstruction(source: FeedbackSource, context: CalibrationContext,
                                      use_cache: bool = True) -> None:
    """``strain_sr``: zhao2021's exploration with the env's gauge model, then the networks."""
    # the paper's exploration and training take ~10 minutes on one core: show their bars
    # (nothing is shown when the model comes from the cache)
    source.set_calibration(cached_reconstruction(context.spec, context.make_sensor("strain"),
                                                 source.config, use_cache=use_cache,
                                                 progress=True, **_dataset_options(source)))


def calibrate_zou2022_dnn(source: FeedbackSource, context: CalibrationContext,
                          use_cache: bool = True) -> None:
    """``encoder_dnn``: zou2022's ASES-labelled data set, then the DNN's training."""
    options = source.labelling_stereo_options()
    try:
        stereo = StereoCamera(**options)
    except TypeError as error:
        raise ValueError(f"stereo must hold StereoCamera keyword arguments, got "
                         f"{sorted(source.stereo_options)} ({error})") from None
    # the paper-sized data set takes ~25 minutes on one core: show the bars (nothing is
    # shown when the data set and network come from the cache)
    source.set_calibration(cached_shape_dnn(context.spec, context.make_sensor("encoder"), stereo,
                                            source.config, use_cache=use_cache, progress=True,
                                            **_dataset_options(source)))


CALIBRATIONS: Registry[Calibration] = Registry("calibration")
"""Calibration procedures by feedback-source name."""
for _name in ("fused", "camera", "fbg"):
    CALIBRATIONS.register(_name, calibrate_wang2023_pipeline)
CALIBRATIONS.register("strain_sr", calibrate_zhao2021_reconstruction)
CALIBRATIONS.register("encoder_dnn", calibrate_zou2022_dnn)


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


__all__ = ["CALIBRATIONS", "calibrate", "calibration_key", "private_simulator",
                      "calibrate_wang2023_pipeline", "calibrate_zhao2021_reconstruction",
                      "calibrate_zou2022_dnn"]
