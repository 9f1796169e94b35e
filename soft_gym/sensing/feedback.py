"""Feedback sources: where the env's ``pose`` observation comes from, one small class each.

A source declares the sensors it needs (the env simulates them), may be calibrated once when the
env is made (by a procedure of :mod:`soft_gym.procedures.calibration`), and turns one step's
:class:`~soft_gym.sensors.measurement.Measurement` into a :class:`FeedbackEstimate` (tip pose, and
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

This module holds the two sources of no paper in particular (``ground_truth``, ``em``); the
papers' own are in :mod:`soft_gym.papers.wang2023.feedback`, :mod:`soft_gym.papers.zhao2021.feedback`
and :mod:`soft_gym.papers.zou2022.feedback`; the protocol in :mod:`soft_gym.sensing.feedback_base`.
"""

from __future__ import annotations

import numpy as np

from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource
from soft_gym.sensors.measurement import Measurement
from soft_gym.sensing.key_points import key_points_from_backbone


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
