"""The papers' estimators: from one step's sensor readings to the tip pose (and backbone).

One folder per paper (``wang2023/``, ``zhao2021/``, ``zou2022/``: its estimators and its feedback
sources); at the root, what they share: the protocol (:mod:`~soft_gym.sensing.feedback_base`),
the :class:`~soft_gym.sensors.measurement.Measurement`, the sources of no paper in particular
(:mod:`~soft_gym.sensing.feedback`: ``ground_truth``, ``em``) and the calibration cache.

One folder per paper (``wang2023/``, ``zhao2021/``, ``zou2022/``: its estimators and its feedback
sources); at the root, what they share: the protocol (:mod:`~soft_gym.sensing.feedback_base`),
the :class:`~soft_gym.sensors.measurement.Measurement`, the sources of no paper in particular
(:mod:`~soft_gym.sensing.feedback`: ``ground_truth``, ``em``) and the calibration cache.

Nothing here drives a simulator: an estimator sees a
:class:`~soft_gym.sensors.measurement.Measurement` (the readings and the commands sent) and what a
calibration procedure (:mod:`soft_gym.procedures`) gave it. ``feedback=`` of the env names a
source registered in :data:`FEEDBACK_SOURCES` (see :mod:`soft_gym.sensing.feedback`).
"""

from __future__ import annotations

from soft_gym._registry import Registry
from soft_gym.sensing.feedback import EMFeedback, GroundTruthFeedback
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackEstimate, FeedbackSource
from soft_gym.sensing.wang2023.feedback import CameraFeedback, FEmpFeedback, FusedFeedback
from soft_gym.sensing.zhao2021.feedback import StrainShapeFeedback
from soft_gym.sensing.zou2022.feedback import EncoderCCFeedback, EncoderDNNFeedback, StereoFeedback

FEEDBACK_SOURCES: Registry[type[FeedbackSource]] = Registry("feedback")
"""Feedback sources by name (the env's ``feedback=``)."""
for _source in (GroundTruthFeedback, EMFeedback, CameraFeedback, FEmpFeedback, FusedFeedback,
                StrainShapeFeedback, EncoderCCFeedback, StereoFeedback, EncoderDNNFeedback):
    FEEDBACK_SOURCES.register(_source.name, _source)


def make_feedback_source(name: str, options: dict | None = None) -> FeedbackSource:
    """Build the registered source ``name`` with its options (the env's ``sensing=``).

    Raises:
        ValueError: an unknown ``name`` or ``options`` that is not a dict.
    """
    source = FEEDBACK_SOURCES[name]
    if options is not None and not isinstance(options, dict):
        raise ValueError(f"sensing must be None or a dict of options, got {options!r}")
    return source(options)


__all__ = ["FEEDBACK_SOURCES", "make_feedback_source", "CalibrationContext", "FeedbackEstimate",
           "FeedbackSource"]
