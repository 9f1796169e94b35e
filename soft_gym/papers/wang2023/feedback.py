"""wang2023's feedback sources: the eye-in-hand camera, F-emp on the FBG, and their fusion.

``camera``, ``fbg`` and ``fused`` share one :class:`~soft_gym.papers.wang2023.pipeline.SensingPipeline`
each and report its camera, F-emp or fused pose (wang2023 Section III, eq. (18)).
"""

from __future__ import annotations

import copy
from typing import Any, ClassVar

import numpy as np

from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.wang2023.pipeline import SensingPipeline


class _PipelineFeedback(FeedbackSource):
    """The wang2023 robot's own sensing: eye-in-hand camera + FBG, F-emp and eq. (18) fusion.

    The pipeline (:class:`~soft_gym.papers.wang2023.pipeline.SensingPipeline`) is calibrated when the env
    is made (vision map at rest, F-emp from the spiral exploration labelled by the camera:
    :func:`soft_gym.papers.wang2023.calibration.calibrate_pipeline`) or taken from the
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

    def reset(self, rng: np.random.Generator) -> None:
        self.pipeline.reset(rng)

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
