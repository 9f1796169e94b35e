"""The estimators' shared layer: from one step's sensor readings to the tip pose (and backbone).

Here: the protocol (:mod:`~soft_gym.sensing.feedback_base`), the
:class:`~soft_gym.sensors.measurement.Measurement`, the backbone's key points
(:mod:`~soft_gym.sensing.key_points`), the sources of no paper in particular
(:mod:`~soft_gym.sensing.feedback`: ``ground_truth``, ``em``) and the calibration cache. Each
paper's estimators and sources are in its folder, ``soft_gym/papers/<key>/``, and join
:data:`FEEDBACK_SOURCES` when the paper is registered (:mod:`soft_gym.papers`).

Nothing here drives a simulator: an estimator sees a
:class:`~soft_gym.sensors.measurement.Measurement` (the readings and the commands sent) and what a
calibration procedure (:mod:`soft_gym.procedures`) gave it. ``feedback=`` of the env names a
source registered in :data:`FEEDBACK_SOURCES` (see :mod:`soft_gym.sensing.feedback`).
"""

from __future__ import annotations

from soft_gym._registry import Registry
from soft_gym.sensing.feedback import EMFeedback, GroundTruthFeedback
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackEstimate, FeedbackSource

FEEDBACK_SOURCES: Registry[type[FeedbackSource]] = Registry("feedback")
"""Feedback sources by name (the env's ``feedback=``): the two of no paper in particular here,
each paper's own added by its registration (:func:`soft_gym.papers.register_paper`)."""
for _source in (GroundTruthFeedback, EMFeedback):
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
