"""wang2023's sensing calibration: the vision map at rest, then F-emp from the spiral exploration.

The robot's sensing (:class:`~soft_gym.papers.wang2023.pipeline.SensingPipeline`) learns from the arm it
watches: :func:`calibrate_pipeline` drives a simulator through the predefined spiral actuation
(wang2023 Section IV-B; :func:`~soft_gym.papers.wang2023.exploration.spiral_fractions`), reads the
pipeline's camera and fiber every control step and hands each step to the pipeline, which keeps
the camera-labelled FBG samples and initialises F-emp from them (eqs. 9-17). It takes about 7 s
on an idle core (longer on a loaded one; then cached on disk), so a tqdm bar shows its progress
once it has run for :data:`PROGRESS_DELAY_S`.
"""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from soft_gym.robots.actuation import pressure_at_fraction
from soft_gym.papers.wang2023.exploration import spiral_fractions
from soft_gym.papers.wang2023.pipeline import SensingPipeline
from soft_gym.sensors.reading import measure
from soft_gym.simulator import Simulator
from soft_gym.procedures.calibration import private_simulator
from soft_gym.sensing.calibration_cache import cached
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackSource


PROGRESS_DELAY_S = 2.0
"""Seconds a calibration runs before its progress bar appears (a quick one shows none)."""


def calibrate_pipeline(pipeline: SensingPipeline, sim: Simulator,
                       rng: np.random.Generator, progress: bool = True) -> int:
    """Vision map at the current (rest) pose, then F-emp from the spiral exploration
    (``map_steps`` steps for the map alone, then ``n_init`` labelled steps).

    Args:
        pipeline: the pipeline to calibrate (its camera and fiber are read on ``sim``).
        sim: the arm at rest; the exploration leaves it wherever it ends.
        rng: the sensors' noise generator.
        progress: show a tqdm bar (on stderr) once the calibration has run for
            :data:`PROGRESS_DELAY_S`.

    Returns:
        The number of camera-labelled samples F-emp was initialised with.
    """
    camera, fiber = pipeline.camera, pipeline.fbg
    camera.reset(sim, rng)
    fiber.reset(sim, rng)
    image, depth = camera.render_clean(sim)
    pipeline.begin_calibration(image, depth, camera.pose_matrix(sim))
    spec = sim.spec
    sensors = {"image": camera, "fbg": fiber}
    samples = []
    for step in tqdm(range(pipeline.calibration_steps), desc="wang2023 sensing calibration",
                     disable=not progress, leave=False, delay=PROGRESS_DELAY_S):
        fraction = spiral_fractions(step * spec.control_period_s, spec.n_segments,
                                    **pipeline.exploration)
        sim.set_pressures(pressure_at_fraction(spec, fraction))
        sim.step_physics(spec.control_period_s)
        sample = pipeline.calibration_sample(step, measure(sensors, sim))
        if sample is not None:
            samples.append(sample)
    return pipeline.finish_calibration(samples)


__all__ = ["calibrate_pipeline", "calibrate_wang2023_pipeline"]


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
