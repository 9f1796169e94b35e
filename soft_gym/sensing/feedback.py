"""Feedback sources: where the env's ``pose`` observation comes from, one small class each.

A source declares the sensors it needs (the env simulates them), may be calibrated once when the
env is made (by a procedure of :mod:`soft_gym.procedures.calibration`), and turns one step's
:class:`~soft_gym.sensing.measurement.Measurement` into a :class:`FeedbackEstimate` (tip pose, and
the backbone where the source has one). ``feedback=`` of the env takes a registered name
(:data:`soft_gym.sensing.FEEDBACK_SOURCES`); a new estimator is one subclass registered there.
See docs/architecture.md, "Feedback sources".

| name           | sensors         | estimate                                                     |
|----------------|-----------------|--------------------------------------------------------------|
| `ground_truth` | `truth`         | the simulator's tip pose and backbone                        |
| `em`           | `em`            | the EM tracker's noisy tip pose (ho2018)                     |
| `camera`       | `image`, `fbg`  | the eye-in-hand vision tracker (wang2023 Section III-B)      |
| `fbg`          | `image`, `fbg`  | F-emp, the online ELM on the FBG shifts (wang2023 eqs. 9-17) |
| `fused`        | `image`, `fbg`  | camera and F-emp fused by wang2023 eq. (18)                  |
| `strain_sr`    | `strain`        | zhao2021's shape reconstruction: SFE-PD key points + fit     |
| `encoder_cc`   | `encoder`       | zou2022's RSES: CC shape of the chamber lengths              |
| `stereo`       | `stereo`        | zou2022's ASES: HSV mask, SOM centreline, triangulation      |
| `encoder_dnn`  | `encoder`       | zou2022's DNN on the chamber lengths, trained on ASES labels |

The protocol lives in :mod:`soft_gym.sensing.feedback_base`, the zou2022 sources in
:mod:`soft_gym.sensing.zou_feedback`.
"""

from __future__ import annotations

import copy
from typing import Any, ClassVar

import numpy as np

from soft_gym._validation import require_positive
from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource
from soft_gym.sensing.measurement import Measurement
from soft_gym.sensing.pipeline import SensingPipeline
from soft_gym.sensing.shape_exploration import key_points_from_backbone
from soft_gym.sensing.shape_reconstruction import ReconstructionConfig


class GroundTruthFeedback(FeedbackSource):
    """The simulator's own tip pose and backbone, read by the privileged ``truth`` sensor
    (:class:`~soft_gym.sensors.truth.TruthSensor`; no noise, no lag)."""

    name = "ground_truth"
    sensors = ("truth",)
    estimates_shape = True

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        truth = measurement["truth"]
        return FeedbackEstimate(truth["position_m"], truth["quaternion"],
                                shape_m=truth["backbone_m"])

    def shape_points(self, estimate: FeedbackEstimate) -> np.ndarray:
        """The base and the simulated key points (only when the env has a ``shape`` part)."""
        return np.vstack([estimate.shape_m[0], key_points_from_backbone(self.spec,
                                                                         estimate.shape_m)])


class EMFeedback(FeedbackSource):
    """The electromagnetic tracker's tip pose (ho2018's Aurora coil; 0.8 mm / 0.7 deg noise)."""

    name = "em"
    sensors = ("em",)

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        reading = np.asarray(measurement["em"], dtype=float)
        return FeedbackEstimate(reading[:3], reading[3:])


class _PipelineFeedback(FeedbackSource):
    """The wang2023 robot's own sensing: eye-in-hand camera + FBG, F-emp and eq. (18) fusion.

    The pipeline (:class:`~soft_gym.sensing.pipeline.SensingPipeline`) is calibrated when the env
    is made (vision map at rest, F-emp from the spiral exploration labelled by the camera:
    :func:`soft_gym.procedures.wang2023_calibration.calibrate_pipeline`) or taken from the
    calibration cache (:mod:`soft_gym.sensing.calibration_cache`), keeps learning across
    episodes, and returns to its calibrated state on :meth:`restore`.
    """

    sensors = ("image", "fbg")
    calibrates = True
    output: ClassVar[str] = ""

    def __init__(self, options: dict | None = None) -> None:
        self.spec = None
        self.options = dict(options or {})
        known = set(SensingPipeline.OPTIONS)
        unknown = sorted(set(self.options) - known)
        if unknown:
            raise ValueError(f"sensing options must be among {sorted(known)}, got {unknown}")
        self.pipeline: Any = None
        self._calibrated: tuple | None = None

    def sensor_options(self) -> dict[str, dict]:
        return {"fbg": {"rate_hz": None}}  # F-emp reads the fiber every control step

    def calibration_key(self) -> dict[str, Any]:
        return {"sensing": repr(sorted(self.options.items()))}

    def set_calibration(self, calibration: tuple[SensingPipeline, tuple]) -> None:
        """Take a pipeline and its calibrated ``(vision, femp, samples)`` state."""
        self.pipeline, self._calibrated = calibration
        self.restore()

    def restore(self) -> None:
        vision, femp, samples = copy.deepcopy(self._calibrated)
        self.pipeline.vision, self.pipeline.femp = vision, femp
        self.pipeline.calibration_samples = samples

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
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


class CameraFeedback(_PipelineFeedback):
    """The vision tracker's tip pose alone (wang2023 Section III-B)."""

    name = "camera"
    output = "camera"


class FEmpFeedback(_PipelineFeedback):
    """F-emp's tip pose from the FBG fiber (wang2023 eqs. (9)-(17)), trained online by the camera."""

    name = "fbg"
    output = "femp"


class FusedFeedback(_PipelineFeedback):
    """Camera and F-emp fused by wang2023 eq. (18)."""

    name = "fused"
    output = "fused"


class StrainShapeFeedback(FeedbackSource):
    """zhao2021's shape reconstruction from the strain gauges (Section III): the SFE-PD networks'
    key points, the backbone fitted through them, the tip at the last key point.

    Calibration is the paper's model preparation (Section VI-A): a random exploration of a
    private copy of the arm with the env's gauge model, then the networks' training
    (:func:`soft_gym.procedures.zhao2021_exploration.cached_reconstruction`; cached on disk).
    The networks read the commanded pressures from the measurement (what the controller sent). The networks read the last
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
        self.spec = None
        options = dict(options or {})
        self.history_step_s = require_positive("history_step_s",
                                               options.pop("history_step_s", 1.0))
        self.config = ReconstructionConfig.from_options(options)
        self.reconstructor: Any = None
        self.report: dict[str, Any] = {}
        self._history: list[np.ndarray] = []
        self._next_history_s = 0.0
        self._last_time_s = -np.inf

    def set_calibration(self, calibration: tuple[Any, dict[str, Any]]) -> None:
        """Take the trained reconstructor and its training report."""
        self.reconstructor, self.report = calibration
        self.restore()

    def restore(self) -> None:
        self._history = []
        self._next_history_s = 0.0
        self._last_time_s = -np.inf

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        state = np.concatenate([np.asarray(measurement.command_pa, dtype=float),
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
        n = self.spec.n_chambers
        shape = self.reconstructor.reconstruct(steps[:, :n], steps[:, n:])
        return FeedbackEstimate(shape.tip_position_m, shape.tip_quaternion,
                                shape_m=shape.backbone_m,
                                shape_points_m=np.vstack([np.zeros(3), shape.key_points_m]),
                                details={"key_points_m": shape.key_points_m.copy()})
