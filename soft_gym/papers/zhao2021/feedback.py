"""zhao2021's feedback source: shape reconstruction from the strain gauges (``strain_sr``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from soft_gym._validation import require_positive
from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource, dataset_option
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig


class StrainShapeFeedback(FeedbackSource):
    """zhao2021's shape reconstruction from the strain gauges (Section III): the SFE-PD networks'
    key points, the backbone fitted through them, the tip at the last key point.

    Calibration is the paper's model preparation (Section VI-A): a random exploration of a
    private copy of the arm with the env's gauge model, then the networks' training
    (:func:`soft_gym.papers.zhao2021.exploration.cached_reconstruction`; cached on disk).
    The networks read the commanded pressures from the measurement (what the controller sent). The networks read the last
    ``w + 1 = 6`` steps of commanded pressures and readings; in the paper a step is one command
    and 1 s of settling, so the source keeps the state of every ``history_step_s`` (1 s) of
    simulated time and hands the networks the last five of them plus the present one.

    Options (the env's ``sensing=``): the fields of
    :class:`~soft_gym.papers.zhao2021.shape_reconstruction.ReconstructionConfig` (e.g. ``n_free``,
    ``n_loaded``, ``max_iterations`` for a quick model), ``history_step_s`` (s, > 0), and
    ``dataset`` (with ``dataset_root``, Minari's root when left out): the id of a dataset written
    by ``python -m eval datasets`` (``"soft-arm/zhao2021/exploration-v0"``) to train on instead of
    exploring. It must hold the exploration this source would take (same arm, gauge model,
    ``n_free``, ``n_loaded``, ``load_kg`` and ``seed``; a ``ValueError`` names the setting that
    differs when the env calibrates), so the networks are those of the collection.
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
        self.dataset, self.dataset_root = dataset_option(options)
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
