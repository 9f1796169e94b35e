"""zou2022's three shape sources as feedback sources: ``encoder_cc``, ``stereo``, ``encoder_dnn``.

Zou et al. 2022 compare three estimates of their arm's backbone ``P_0 .. P_6``:

| name          | sensors   | estimate                                                          |
|---------------|-----------|-------------------------------------------------------------------|
| `encoder_cc`  | `encoder` | RSES: the CC shape from the chamber lengths (Section 3, eqs. 2-10) |
| `stereo`      | `stereo`  | ASES: the stereo pair's SOM centreline (Section 4, eqs. 11-16)     |
| `encoder_dnn` | `encoder` | the DNN on the chamber lengths, trained on ASES (Section 5)        |

Each fills ``FeedbackEstimate.shape_points_m`` (7, 3), so the env's ``shape`` part works; the tip
is the last point. Orientation: ``encoder_cc`` gives the CC tip frame (eq. 8); the point-based
sources give the rotation that turns the base ``+z`` onto the backbone's tangent at the tip, from
the one-sided second-order difference ``(3 P_6 - 4 P_5 + P_4) / 2`` of the last three points
(the CC frame's convention: CC rotations never twist about the axis, so the CC tip frame is this
rotation of its own tangent).

``stereo`` reports ``lost`` (and why) in ``details``; while lost it holds its last good estimate
(before any, the straight arm at rest). Its camera defaults to a 320 x 180 pair
(:data:`~soft_gym.papers.zou2022.shape_dnn.STEREO_INTRINSICS`; ``sensor_config={"stereo": ...}``
overrides it). Options (the env's ``sensing=``): the fields of
:class:`~soft_gym.papers.zou2022.stereo_shape.ASESConfig`.

``encoder_dnn`` calibrates when the env is made: the data set of
:func:`~soft_gym.papers.zou2022.dataset.collect_dataset` (random pressure exploration of a
private copy of the arm, labelled by ASES on a private stereo pair in a clear view) and the
network's training, both in the calibration cache. At run time it reads only the encoders, so it keeps
working when the env's stereo pair is blind. Options: the fields of
:class:`~soft_gym.papers.zou2022.shape_dnn.ShapeDNNConfig` (e.g. ``n_samples=300`` for a quick model;
the default is the paper's 29791), ``stereo`` (keyword arguments of the labelling
:class:`~soft_gym.sensors.stereo.StereoCamera`) and ``dataset`` (with ``dataset_root``, Minari's
root when left out): the id of a dataset written by ``python -m eval datasets``
(``"soft-arm/zou2022/stereo-labels-v0"``) to train on instead of collecting. It must hold the
data set this source would collect (same arm, encoder and stereo models, ASES settings,
``n_samples``, grid, settling, split and ``seed``; a ``ValueError`` names the setting that differs
when the env calibrates), so the DNN is that of the collection.

Registration: :mod:`soft_gym.sensing`'s ``__init__`` registers these classes with the others.

Visual faults: the env's ``faults=`` reach the stereo pair as they reach the eye-in-hand camera
(one description for every camera the env simulates, or a dict keyed by sensor name; see
:mod:`soft_gym.sensors.faults`). Darkness, strong glare or a plate over the pair make ASES report
lost, and so does a plate hiding only the tip half: ASES checks that the visible arm's tip end
meets the white backdrop, not an occluder (:func:`~soft_gym.papers.zou2022.stereo_shape.tip_occlusion`;
with 60 % of the view covered from the bottom, lost in 20 of 20 poses, where the truncated arm
was taken for the whole one with 46 mm mean error before). An occluder of the backdrop's colour
stays unseen.
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from soft_gym.robots.spec import ArmSpec
from soft_gym.papers.zou2022.cc_shape import cc_shape
from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource, dataset_option
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.zou2022.shape_dnn import STEREO_INTRINSICS, ShapeDNNConfig
from soft_gym.papers.zou2022.stereo_shape import N_POINTS, ASESConfig, estimate_stereo_shape
from soft_gym.sensors.stereo import StereoCamera


def tangent_quaternion(points_m: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w) of the rotation turning ``+z`` onto the backbone's tip tangent.

    The tangent is ``(3 P_-1 - 4 P_-2 + P_-3) / 2`` (one-sided, second order) for three or more
    points, the last chord for two; the rotation is the smallest one (no twist about the axis).
    """
    points = np.asarray(points_m, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
        raise ValueError(f"points_m must have shape (n >= 2, 3), got {points.shape}")
    if len(points) >= 3:
        tangent = 1.5 * points[-1] - 2.0 * points[-2] + 0.5 * points[-3]
    else:
        tangent = points[-1] - points[-2]
    norm = float(np.linalg.norm(tangent))
    if not np.isfinite(norm) or norm < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    t = tangent / norm
    # rotation from z = (0, 0, 1) to t: axis z x t = (-t_y, t_x, 0), half-angle quaternion
    w = 1.0 + t[2]
    if w < 1e-12:                                   # pointing straight back: half a turn
        return np.array([1.0, 0.0, 0.0, 0.0])
    quaternion = np.array([-t[1], t[0], 0.0, w])
    return quaternion / np.linalg.norm(quaternion)


def rest_shape_points(spec: ArmSpec) -> np.ndarray:
    """``P_0 .. P_6`` (m) of the straight arm at rest: sixths of the rest length along ``+z``."""
    points = np.zeros((7, 3))
    points[:, 2] = np.linspace(0.0, float(spec.length_m), 7)
    return points


def _from_points(points: np.ndarray, quaternion: np.ndarray | None = None,
                 details: dict[str, Any] | None = None) -> FeedbackEstimate:
    """A :class:`FeedbackEstimate` with the tip at the last point."""
    points = np.asarray(points, dtype=float)
    return FeedbackEstimate(points[-1].copy(),
                            tangent_quaternion(points) if quaternion is None
                            else np.asarray(quaternion, dtype=float),
                            shape_m=points.copy(), shape_points_m=points.copy(),
                            details=details or {})


def _rest_lengths(spec: ArmSpec) -> np.ndarray:
    return np.array([segment.length_m for segment in spec.segments])


class EncoderCCFeedback(FeedbackSource):
    """RSES: the CC shape of the encoders' chamber lengths (zou2022 Section 3, eqs. 2-10)."""

    name = "encoder_cc"
    sensors = ("encoder",)
    estimates_shape = True

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        lengths = np.asarray(measurement["encoder"], dtype=float)
        points, _, quaternion = cc_shape(lengths, self.spec.chamber_offset_m,
                                         _rest_lengths(self.spec))
        return _from_points(points, quaternion, {"lengths_m": lengths.copy()})

class StereoFeedback(FeedbackSource):
    """ASES: the stereo pair's SOM centreline, triangulated (zou2022 Section 4, eqs. 11-16).

    Holds the last good estimate while the pair is lost (``details["lost"]``,
    ``details["reason"]``); ``details["held_steps"]`` counts the steps held.
    """

    name = "stereo"
    sensors = ("stereo",)
    estimates_shape = True

    def __init__(self, options: dict | None = None) -> None:
        self.spec: ArmSpec | None = None
        self.config = ASESConfig.from_options(dict(options or {}))
        if self.config.n_points != N_POINTS:
            raise ValueError(f"n_points must be {N_POINTS} for the stereo feedback source (the "
                             f"env's shape part and the baselines read the points P_0..P_6), got "
                             f"{self.config.n_points!r}")
        self._last_good: np.ndarray | None = None
        self._held = 0
        self._last_time_s = -np.inf

    def sensor_options(self) -> dict[str, dict]:
        return {"stereo": {"intrinsics": dict(STEREO_INTRINSICS)}}

    def restore(self) -> None:
        self._last_good, self._held, self._last_time_s = None, 0, -np.inf

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        if measurement.time_s + 1e-9 < self._last_time_s:
            self.restore()  # the clock went back: a new episode
        self._last_time_s = measurement.time_s
        reading = measurement["stereo"]
        shape = estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                      reading["P_right"], self.config)
        if shape.lost:
            self._held += 1
            points = rest_shape_points(self.spec) if self._last_good is None else self._last_good
        else:
            self._held = 0
            points = self._last_good = shape.points_m.copy()
        details = {"lost": shape.lost, "reason": shape.reason, "held_steps": self._held,
                   "som_px": {k: v.copy() for k, v in shape.som_px.items()}}
        return _from_points(points, details=details)

class EncoderDNNFeedback(FeedbackSource):
    """The DNN of zou2022 Section 5 on the encoders' chamber lengths, trained on ASES labels."""

    name = "encoder_dnn"
    sensors = ("encoder",)
    calibrates = True
    estimates_shape = True

    def __init__(self, options: dict | None = None) -> None:
        options = dict(options or {})
        stereo = options.pop("stereo", None)
        if stereo is not None and not isinstance(stereo, dict):
            raise ValueError(f"stereo must be a dict of StereoCamera keyword arguments, got "
                             f"{stereo!r}")
        allowed = [name for name in inspect.signature(StereoCamera).parameters]
        unknown = [name for name in (stereo or {}) if name not in allowed]
        if unknown:
            raise ValueError(f"stereo: unknown StereoCamera option {unknown[0]!r}; allowed: "
                             f"{allowed}")
        self.dataset, self.dataset_root = dataset_option(options)
        self.spec: ArmSpec | None = None
        self.stereo_options = dict(stereo or {})
        self.config = ShapeDNNConfig.from_options(options)
        self.dnn: Any = None
        self.report: dict[str, Any] = {}

    def labelling_stereo_options(self) -> dict[str, Any]:
        """Keyword arguments of the stereo pair that labels the data set."""
        return {"intrinsics": dict(STEREO_INTRINSICS), **self.stereo_options}

    def set_calibration(self, calibration: tuple[Any, dict[str, Any]]) -> None:
        """Take the trained DNN and its report
        (:func:`~soft_gym.papers.zou2022.dataset.cached_shape_dnn`)."""
        self.dnn, self.report = calibration

    def estimate(self, measurement: Measurement) -> FeedbackEstimate:
        lengths = np.asarray(measurement["encoder"], dtype=float)
        return _from_points(self.dnn.predict(lengths),
                            details={"lengths_m": lengths.copy()})


__all__ = ["tangent_quaternion", "rest_shape_points", "EncoderCCFeedback", "StereoFeedback",
           "EncoderDNNFeedback"]
