"""Feedback sources: where the env's ``pose`` observation comes from, one small class each.

A source declares the sensors it needs (the env simulates them), may calibrate once when the env
is made, and turns one step's :class:`~soft_gym.sensing.measurement.Measurement` into a
:class:`FeedbackEstimate` (tip pose, and the backbone where the source has one). ``feedback=`` of
the env takes a registered name; a new estimator (strain-gauge shape reconstruction, a stereo
centreline) is one subclass registered with :func:`register_feedback_source`. See
docs/architecture.md, "Feedback sources".

| name           | sensors         | estimate                                                     |
|----------------|-----------------|--------------------------------------------------------------|
| `ground_truth` | none            | the simulator's tip pose and backbone                        |
| `em`           | `em`            | the EM tracker's noisy tip pose (ho2018)                     |
| `camera`       | `image`, `fbg`  | the eye-in-hand vision tracker (wang2023 Section III-B)      |
| `fbg`          | `image`, `fbg`  | F-emp, the online ELM on the FBG shifts (wang2023 eqs. 9-17) |
| `fused`        | `image`, `fbg`  | camera and F-emp fused by wang2023 eq. (18)                  |
| `strain_sr`    | `strain`        | zhao2021's shape reconstruction: SFE-PD key points + fit     |
| `encoder_cc`   | `encoder`       | zou2022's RSES: CC shape of the chamber lengths              |
| `stereo`       | `stereo`        | zou2022's ASES: HSV mask, SOM centreline, triangulation      |
| `encoder_dnn`  | `encoder`       | zou2022's DNN on the chamber lengths, trained on ASES labels |

The protocol and the registry live in :mod:`soft_gym.sensing.feedback_base`; the zou2022 sources
in :mod:`soft_gym.sensing.zou_feedback`.
"""

from __future__ import annotations

import copy
from typing import Any, ClassVar

import numpy as np

from soft_gym.sensing.feedback_base import (FEEDBACK_SOURCES, CalibrationContext,  # noqa: F401
                                            FeedbackEstimate, FeedbackSource,
                                            make_feedback_source, register_feedback_source)
from soft_gym.sensing.measurement import Measurement
from soft_gym.sensing.zou_feedback import (EncoderCCFeedback, EncoderDNNFeedback,  # noqa: F401
                                           StereoFeedback)  # registered on import (zou2022)


@register_feedback_source
class GroundTruthFeedback(FeedbackSource):
    """The simulator's own tip pose and backbone (no sensor, no noise)."""

    name = "ground_truth"
    estimates_shape = True

    def estimate(self, measurement: Measurement, sim) -> FeedbackEstimate:
        position, quaternion = sim.tip_pose()
        return FeedbackEstimate(position, quaternion, shape_m=sim.backbone())

    def shape_points(self, estimate: FeedbackEstimate, sim) -> np.ndarray:
        """The base and the simulated key points (only when the env has a ``shape`` part)."""
        from soft_gym.sensing.shape_exploration import key_points_from_backbone

        return np.vstack([estimate.shape_m[0], key_points_from_backbone(sim.spec,
                                                                         estimate.shape_m)])


@register_feedback_source
class EMFeedback(FeedbackSource):
    """The electromagnetic tracker's tip pose (ho2018's Aurora coil; 0.8 mm / 0.7 deg noise)."""

    name = "em"
    sensors = ("em",)

    def estimate(self, measurement: Measurement, sim) -> FeedbackEstimate:
        reading = np.asarray(measurement["em"], dtype=float)
        return FeedbackEstimate(reading[:3], reading[3:])


class _PipelineFeedback(FeedbackSource):
    """The wang2023 robot's own sensing: eye-in-hand camera + FBG, F-emp and eq. (18) fusion.

    The pipeline (:class:`~soft_gym.sensing.pipeline.SensingPipeline`) is calibrated when the env
    is made (vision map at rest, F-emp from the spiral exploration labelled by the camera) or
    taken from the calibration cache (:mod:`soft_gym.sensing.calibration_cache`), keeps learning
    across episodes, and returns to its calibrated state on :meth:`restore`.
    """

    sensors = ("image", "fbg")
    calibrates = True
    output: ClassVar[str] = ""

    def __init__(self, options: dict | None = None) -> None:
        from soft_gym.sensing.pipeline import SensingPipeline

        self.options = dict(options or {})
        known = set(SensingPipeline.OPTIONS)
        unknown = sorted(set(self.options) - known)
        if unknown:
            raise ValueError(f"sensing options must be among {sorted(known)}, got {unknown}")
        self.pipeline: Any = None
        self._calibrated: tuple | None = None

    def sensor_options(self) -> dict[str, dict]:
        return {"fbg": {"rate_hz": None}}  # F-emp reads the fiber every control step

    def calibrate(self, context: CalibrationContext, use_cache: bool = True) -> None:
        from soft_gym.sensing.calibration_cache import cached
        from soft_gym.sensing.pipeline import SensingPipeline

        self.pipeline = SensingPipeline(context.sensors["image"], context.sensors["fbg"],
                                        **self.options)
        sim, camera = context.sim, self.pipeline.camera

        def compute() -> tuple:
            faults = camera.faults
            camera.set_faults(None)  # calibration happens in a clear view
            sim.reset(settle_s=context.settle_s)
            self.pipeline.calibrate(sim, np.random.default_rng(0))
            camera.set_faults(faults)
            return (self.pipeline.vision, self.pipeline.femp, self.pipeline.calibration_samples)

        key = {**context.key, "sensing": repr(sorted(self.options.items()))}
        self._calibrated = cached(key, compute, use_cache=use_cache)
        self.restore()

    def restore(self) -> None:
        vision, femp, samples = copy.deepcopy(self._calibrated)
        self.pipeline.vision, self.pipeline.femp = vision, femp
        self.pipeline.calibration_samples = samples

    def estimate(self, measurement: Measurement, sim) -> FeedbackEstimate:
        estimates = self.pipeline.observe(measurement)
        position, quaternion = getattr(estimates, self.output)
        details = {"camera": estimates.camera[0].copy(), "femp": estimates.femp[0].copy(),
                   "fused": estimates.fused[0].copy(),
                   "reprojection_error_px": estimates.reprojection_error_px,
                   "lost": estimates.lost,
                   "femp_weight": self.pipeline.fusion.weight(estimates.reprojection_error_px,
                                                              estimates.lost),
                   "femp_updated": estimates.femp_updated}
        return FeedbackEstimate(np.array(position), np.array(quaternion), details=details)


@register_feedback_source
class CameraFeedback(_PipelineFeedback):
    """The vision tracker's tip pose alone (wang2023 Section III-B)."""

    name = "camera"
    output = "camera"


@register_feedback_source
class FEmpFeedback(_PipelineFeedback):
    """F-emp's tip pose from the FBG fiber (wang2023 eqs. (9)-(17)), trained online by the camera."""

    name = "fbg"
    output = "femp"


@register_feedback_source
class FusedFeedback(_PipelineFeedback):
    """Camera and F-emp fused by wang2023 eq. (18)."""

    name = "fused"
    output = "fused"


@register_feedback_source
class StrainShapeFeedback(FeedbackSource):
    """zhao2021's shape reconstruction from the strain gauges (Section III): the SFE-PD networks'
    key points, the backbone fitted through them, the tip at the last key point.

    Calibration is the paper's model preparation (Section VI-A): a random exploration of a
    private copy of the arm with the env's gauge model, then the networks' training
    (:mod:`soft_gym.sensing.shape_reconstruction`; cached on disk). The networks read the last
    ``w + 1 = 6`` steps of commanded pressures and readings; in the paper a step is one command
    and 1 s of settling, so the source keeps the state of every ``history_step_s`` (1 s) of
    simulated time and hands the networks the last five of them plus the present one.

    Options (the env's ``sensing=``): the fields of
    :class:`~soft_gym.sensing.shape_reconstruction.ReconstructionConfig` (e.g. ``n_free``,
    ``n_loaded``, ``max_iterations`` for a quick model) and ``history_step_s`` (s, > 0).
    """

    name = "strain_sr"
    sensors = ("strain",)
    calibrates = True
    estimates_shape = True

    def __init__(self, options: dict | None = None) -> None:
        from soft_gym.sensing.shape_reconstruction import ReconstructionConfig
        from soft_gym._validation import require_positive

        options = dict(options or {})
        self.history_step_s = require_positive("history_step_s",
                                               options.pop("history_step_s", 1.0))
        self.config = ReconstructionConfig.from_options(options)
        self.reconstructor: Any = None
        self.report: dict[str, Any] = {}
        self._history: list[np.ndarray] = []
        self._next_history_s = 0.0
        self._last_time_s = -np.inf

    def calibrate(self, context: CalibrationContext, use_cache: bool = True) -> None:
        from soft_gym.sensing.shape_reconstruction import cached_reconstruction

        # the paper's exploration and training take ~10 minutes on one core: show their bars
        # (nothing is shown when the model comes from the cache)
        self.reconstructor, self.report = cached_reconstruction(
            context.sim.spec, context.sensors["strain"], self.config, use_cache=use_cache,
            progress=True)
        self.restore()

    def restore(self) -> None:
        self._history = []
        self._next_history_s = 0.0
        self._last_time_s = -np.inf

    def estimate(self, measurement: Measurement, sim) -> FeedbackEstimate:
        state = np.concatenate([np.asarray(sim.supply.command_pa, dtype=float),
                                np.asarray(measurement["strain"], dtype=float)])
        if measurement.time_s + 1e-9 < self._last_time_s:
            self.restore()  # the clock went back: a new episode, whose history starts afresh
        self._last_time_s = measurement.time_s
        if not self._history:
            self._history = [state] * self.reconstructor.window
            self._next_history_s = measurement.time_s + self.history_step_s
        elif measurement.time_s + 1e-9 >= self._next_history_s:
            self._history = self._history[1:] + [state]
            self._next_history_s += self.history_step_s
        steps = np.array(self._history + [state])
        n = sim.spec.n_chambers
        shape = self.reconstructor.reconstruct(steps[:, :n], steps[:, n:])
        return FeedbackEstimate(shape.tip_position_m, shape.tip_quaternion,
                                shape_m=shape.backbone_m,
                                shape_points_m=np.vstack([np.zeros(3), shape.key_points_m]),
                                details={"key_points_m": shape.key_points_m.copy()})
