"""Visual faults of the cameras, each on a time schedule (wang2023, Section IV-C; zou2022 Fig. 13).

Wang et al. 2023 test their visual-strain fusion against what defeats ORB-SLAM2 on a tip camera:

* moving obstacles (Fig. 6): a hand held statically or moved quickly in front of the camera so that
  it partly shields the field of view (②, ③), and a hand covering the whole view "for ~2 s each
  time" (④), after 100 s of undisturbed tracking;
* varying lighting (Fig. 7): weak lighting (②), complete darkness during 75-150 s ("entire
  black image feedback"), and a moving LED source oriented at the camera from 150 to 200 s (③)
  whose spot wipes out the features around it;
* motion blur when the tip moves fast (Section IV-E2, finger flicks: "vision-based estimation
  deteriorated by motion blur");
* and the sensor's own noise.

Each fault acts where it acts in reality. :class:`MovingOccluder` is geometry: a PyBullet body
placed between the camera and the scene before every frame, following the camera. The others
work on the rendered frame with numpy/OpenCV, in a fixed physical order: scene light
(:class:`LowLight`), extra light (:class:`LEDGlare`), exposure (:class:`MotionBlur`), read-out
(:class:`SensorNoise`).

Cameras. The same faults serve the eye-in-hand camera (:class:`~soft_gym.sensors.camera.
EyeInHandCamera`, wang2023) and the fixed stereo pair (:class:`~soft_gym.sensors.stereo.
StereoCamera`, zou2022 Section 4.4: "poor light", Fig. 13). A camera rig is one or more cameras
sharing a rotation, their optical centres spread ``FrameContext.baseline_m`` along the camera x
axis about ``FrameContext.position`` (0 for one camera). A geometric fault is placed once per
rig frame, relative to the rig; every camera of the rig then renders it from its own pose, so a
plate in front of a stereo pair covers one view, both or parts of each depending on where it is.
An image fault is applied to every image of the frame with that image's own context: the same
light at the same time for both images of a pair, with per-image noise.

Schedules. Every fault has ``start_s`` and ``end_s`` (``None``: until the episode ends) on the
simulator's clock (``sim.time_s``) and a ``strength`` in [0, 1]: a number, or a schedule list of
``(time_s, strength)`` knots (times non-decreasing, linear in between, held before the first and
after the last knot; a repeated time makes a step). Outside its window a fault does nothing.

Randomness. A fault draws its episode parameters (paths, phases, sides) from the generator given
to :meth:`VisualFault.reset` and its per-frame noise from the frame's generator, both the camera's
(the env's ``np_random``), so a seed fixes every frame.

Selection: ``make_faults`` accepts ``None``, a name (a fault or a preset such as
``"wang2023_lighting"``), a dict with ``"name"`` and parameters, an instance, or a list of these.
The env's ``faults=`` takes such a description for every camera it simulates, or one per camera
in a dict keyed by sensor name (:func:`faults_per_sensor`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Callable, ClassVar, Sequence

import cv2
import numpy as np

from soft_gym._quaternion import matrix_to_quaternion
from soft_gym._registry import FORMS, Registry, Spec, build, parse_spec
from soft_gym._timing import TimeWindow
from soft_gym._validation import require_in_range, require_non_negative, require_positive
from soft_gym.sensors.intrinsics import CameraIntrinsics

StrengthLike = float | Sequence[tuple[float, float]]
"""A strength in [0, 1] or a schedule list of ``(time_s, strength)`` knots."""

_PARKED_POSITION = (0.0, 0.0, -1.0e3)
"""Where an inactive occluder waits (m): beyond every camera's far plane."""

EYE_IN_HAND_OCCLUDER_M = 0.015
"""Distance of an occluder in front of the eye-in-hand camera by default (m): a hand over the
tip camera, inside wang2023's 8-150 mm depth of field."""

FAULT_SENSORS = ("image", "stereo")
"""The sensors that take visual faults: the eye-in-hand camera and the stereo pair."""


@dataclass
class FrameContext:
    """What a fault may use for one frame.

    Attributes:
        time_s: simulator time of the frame (s).
        rotation: world-from-camera rotation (3, 3), OpenCV axes (x right, y down, z forward).
        position: camera centre in the world frame (m).
        previous_rotation, previous_position, previous_time_s: the same for the camera's
            previous frame, ``None`` for the first frame after a reset.
        intrinsics: the camera's :class:`~soft_gym.sensors.intrinsics.CameraIntrinsics`.
        rng: the generator for per-frame noise.
        depth: metric depth of the rendered frame (m, (H, W)), ``None`` before rendering.
        baseline_m: spread of the rig's optical centres along the camera x axis about
            ``position`` (m): 0 for one camera, the baseline for a stereo pair's rig context (the
            one geometric faults are placed with; each image's own context has 0).
    """

    time_s: float
    rotation: np.ndarray
    position: np.ndarray
    intrinsics: CameraIntrinsics
    rng: np.random.Generator
    previous_rotation: np.ndarray | None = None
    previous_position: np.ndarray | None = None
    previous_time_s: float | None = None
    depth: np.ndarray | None = None
    baseline_m: float = 0.0


def _check_strength(strength: Any) -> float | tuple[tuple[float, float], ...]:
    """Validate a strength or schedule; returns a float or a tuple of (time, value) knots."""
    number = (int, float, np.integer, np.floating)
    if isinstance(strength, number) and not isinstance(strength, bool):
        return require_in_range("strength", float(strength), 0.0, 1.0)
    try:
        knots = np.asarray(strength, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError("strength must be a number in [0, 1] or a list of (time_s, strength) "
                         f"pairs, got {strength!r}") from error
    if knots.ndim != 2 or knots.shape[1] != 2 or len(knots) == 0:
        raise ValueError("strength must be a number in [0, 1] or a non-empty list of "
                         f"(time_s, strength) pairs, got {strength!r}")
    if not np.all(np.isfinite(knots)):
        raise ValueError(f"strength schedule must be finite, got {knots.tolist()}")
    if np.any(np.diff(knots[:, 0]) < 0):
        raise ValueError("strength schedule times must be non-decreasing, got "
                         f"{knots[:, 0].tolist()}")
    if np.any((knots[:, 1] < 0) | (knots[:, 1] > 1)):
        raise ValueError(f"strength schedule values must be within [0, 1], got "
                         f"{knots[:, 1].tolist()}")
    return tuple((float(t), float(v)) for t, v in knots)


@dataclass
class VisualFault(TimeWindow):
    """Base of all visual faults: a time window (:class:`~soft_gym._timing.TimeWindow`) and a
    strength (number or schedule).

    Subclasses set ``stage`` (order of application) and implement :meth:`apply` (image faults)
    or :meth:`attach` / :meth:`place` / :meth:`detach` (geometry faults).
    """

    strength: StrengthLike = 1.0

    stage: ClassVar[int] = 0
    geometric: ClassVar[bool] = False

    def __post_init__(self) -> None:
        self.check_window()
        self.strength = _check_strength(self.strength)

    # ------------------------------------------------------------------ schedule
    def strength_at(self, time_s: float) -> float:
        """Strength in [0, 1] at ``time_s`` (s): 0 outside the window, else the schedule."""
        if not self.active(time_s):
            return 0.0
        if isinstance(self.strength, float):
            return self.strength
        times = [t for t, _ in self.strength]
        values = [v for _, v in self.strength]
        i = int(np.searchsorted(times, time_s, side="right"))
        if i == 0:
            return values[0]
        if i == len(times):
            return values[-1]
        t0, t1, v0, v1 = times[i - 1], times[i], values[i - 1], values[i]
        return v0 if t1 <= t0 else v0 + (v1 - v0) * (time_s - t0) / (t1 - t0)

    # ------------------------------------------------------------------ life cycle
    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: draw this fault's random parameters from ``rng``."""

    def attach(self, world, intrinsics: CameraIntrinsics, *, baseline_m: float = 0.0,
               default_distance_m: float = EYE_IN_HAND_OCCLUDER_M) -> None:
        """Create this fault's bodies in the simulator's ``world`` (geometry faults only).

        ``baseline_m``: the rig's spread of optical centres along the camera x axis (m; 0 for
        one camera); ``default_distance_m``: the camera's distance for a body whose own is
        ``None`` (m).
        """

    def detach(self, world) -> None:
        """Remove this fault's bodies from ``world``."""

    def place(self, world, context: FrameContext) -> None:
        """Move this fault's bodies for the frame about to be rendered (geometry faults only)."""

    def park(self, world) -> None:
        """Move this fault's bodies out of every camera's view (geometry faults only)."""

    def apply(self, image: np.ndarray, context: FrameContext) -> np.ndarray:
        """Return the frame (float32 (H, W, 3), 0-255 scale, may leave that range) faulted."""
        return image


_SIDES = ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))
"""Directions (camera x, y) an occluder can come in from: right, left, bottom, top."""


@dataclass
class MovingOccluder(VisualFault):
    """A hand-like plate moving between the camera and the scene (wang2023 Fig. 6 ②-④).

    A real PyBullet body (visual only: it never touches the arm) is placed ``distance_m`` in front
    of the camera before every frame, so it follows the tip and always stays between camera and
    scene. In front of a stereo pair it is placed relative to the pair (the midpoint of the
    optical centres) and sized for the union of both views; each camera sees it from its own
    pose, so a partial plate coming in from the right covers the right camera's view first.
    It slides in from one side of the view (right, left, bottom or top) so that it covers
    a fraction of the view equal to ``strength * s(t)`` (default strength: 0.6 partial, 1 full):

    * ``mode="partial"`` (Fig. 6 ②/③, a hand moving across the view): ``s(t)`` rises and falls
      smoothly with period ``sweep_s``; each sweep comes in from a side drawn from the episode's
      generator, with a random phase, so the covered part moves and never stays whole;
    * ``mode="full"`` (Fig. 6 ④, "the hand would statically cover the whole field-of-view for
      ~2 s each time"): ``s(t) = 1`` for ``cover_s`` seconds once every ``period_s`` (each start
      delayed by up to ``jitter_s``, drawn per episode), else the plate is away. With
      ``strength = 1`` it covers the whole view.

    Args:
        mode: ``"partial"`` or ``"full"``.
        distance_m: distance of the plate in front of the camera (m); must lie beyond the
            camera's near plane and before the scene. ``None`` (default): the camera's own
            choice, 15 mm for the eye-in-hand camera (suits wang2023's 60 mm working distance)
            and 40 % of the way to the arm for the stereo pair
            (:class:`~soft_gym.sensors.stereo.StereoCamera`).
        sweep_s: period of one partial sweep (s).
        cover_s: duration of one full cover (s).
        period_s: interval between the starts of full covers (s), > ``cover_s``.
        jitter_s: largest random delay of a full cover's start (s), <= ``period_s - cover_s``;
            ``None``: ``min(1, period_s - cover_s)``.
        rgba: colour of the plate (skin-like by default, uniform, so it carries no features).
            Skin lies inside ASES's orange HSV range: the stereo pair's shape estimator takes a
            skin plate for the arm (zou2022's colour segmentation would); a grey ``rgba`` makes
            a plain obstacle.
    """

    strength: StrengthLike | None = None
    mode: str = "partial"
    distance_m: float | None = None
    sweep_s: float = 3.0
    cover_s: float = 2.0
    period_s: float = 6.0
    jitter_s: float | None = None
    rgba: tuple[float, float, float, float] = (0.87, 0.67, 0.56, 1.0)

    stage: ClassVar[int] = 0
    geometric: ClassVar[bool] = True
    _body: int = field(default=-1, init=False, repr=False)
    _world: Any = field(default=None, init=False, repr=False)
    _half_size_m: float = field(default=0.0, init=False, repr=False)
    _distance_m: float = field(default=EYE_IN_HAND_OCCLUDER_M, init=False, repr=False)
    _phase: float = field(default=0.0, init=False, repr=False)
    _sides: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=int), init=False,
                               repr=False)
    _delays: np.ndarray = field(default_factory=lambda: np.zeros(1), init=False, repr=False)

    def __post_init__(self) -> None:
        if self.mode not in ("partial", "full"):
            raise ValueError(f"mode must be one of ['full', 'partial'], got {self.mode!r}")
        if self.strength is None:
            self.strength = 0.6 if self.mode == "partial" else 1.0
        super().__post_init__()
        if self.distance_m is not None:
            require_positive("distance_m", self.distance_m)
        require_positive("sweep_s", self.sweep_s)
        require_positive("cover_s", self.cover_s)
        require_positive("period_s", self.period_s)
        if self.period_s <= self.cover_s:
            raise ValueError(f"period_s must be > cover_s={self.cover_s}, got {self.period_s!r}")
        if self.jitter_s is None:
            self.jitter_s = min(1.0, self.period_s - self.cover_s)
        require_non_negative("jitter_s", self.jitter_s)
        if self.jitter_s > self.period_s - self.cover_s:
            raise ValueError(f"jitter_s must be <= period_s - cover_s = "
                             f"{self.period_s - self.cover_s}, got {self.jitter_s!r}")
        rgba = np.asarray(self.rgba, dtype=float)
        if rgba.shape != (4,) or np.any(~np.isfinite(rgba)) or np.any((rgba < 0) | (rgba > 1)):
            raise ValueError(f"rgba must be 4 numbers in [0, 1], got {self.rgba!r}")

    def reset(self, rng: np.random.Generator) -> None:
        self._phase = float(rng.uniform(0.0, 1.0))
        self._sides = rng.integers(0, len(_SIDES), size=256)
        self._delays = rng.uniform(0.0, self.jitter_s, size=256)

    @property
    def plate_distance_m(self) -> float:
        """The distance in use (m): ``distance_m``, or the camera's default once attached."""
        return self._distance_m

    def attach(self, world, intrinsics: CameraIntrinsics, *, baseline_m: float = 0.0,
               default_distance_m: float = EYE_IN_HAND_OCCLUDER_M) -> None:
        distance = self.distance_m if self.distance_m is not None else float(default_distance_m)
        if intrinsics.near_m >= distance:
            raise ValueError(f"distance_m must be > the camera's near_m={intrinsics.near_m}, "
                             f"got {distance!r}")
        baseline = require_non_negative("baseline_m", baseline_m)
        self._distance_m = distance
        # a square plate larger than the (rig's) view's diagonal at the distance, so it can
        # cover it all
        half_diagonal = math.hypot(distance * intrinsics.width / (2 * intrinsics.fx)
                                   + 0.5 * baseline,
                                   distance * intrinsics.height / (2 * intrinsics.fy))
        self._half_size_m = 1.2 * half_diagonal
        self._body = world.add_body(
            "box", half_extents_m=[self._half_size_m, self._half_size_m, 2e-4], collide=False,
            rgba=self.rgba, position_m=list(_PARKED_POSITION))
        self._world = world

    def detach(self, world) -> None:
        if self._body >= 0 and world is self._world:
            world.remove_body(self._body)
        self._body, self._world = -1, None

    def park(self, world) -> None:
        if self._body >= 0 and world is self._world:
            world.set_body_pose(self._body, list(_PARKED_POSITION), [0, 0, 0, 1])

    def motion(self, time_s: float) -> tuple[float, int]:
        """The profile ``s(t)`` in [0, 1] and the side index (into right/left/bottom/top)."""
        elapsed = time_s - self.start_s
        if self.mode == "partial":
            cycles = elapsed / self.sweep_s + self._phase
            side = int(self._sides[int(math.floor(cycles)) % len(self._sides)])
            return 0.5 - 0.5 * math.cos(2.0 * math.pi * cycles), side
        k = int(math.floor(elapsed / self.period_s))
        into = elapsed - k * self.period_s - float(self._delays[k % len(self._delays)])
        side = int(self._sides[k % len(self._sides)])
        return (1.0 if 0.0 <= into < self.cover_s else 0.0), side

    def covered_fraction(self, time_s: float) -> float:
        """Fraction of the view the plate covers at ``time_s`` (s)."""
        if not self.active(time_s):
            return 0.0
        return self.strength_at(time_s) * self.motion(time_s)[0]

    def place(self, world, context: FrameContext) -> None:
        if self._body < 0:
            return
        fraction = self.covered_fraction(context.time_s)
        if fraction <= 0.0:
            self.park(world)
            return
        _, side = self.motion(context.time_s)
        direction = np.array(_SIDES[side])
        intrinsics = context.intrinsics
        distance = self._distance_m
        # half the (rig's) view at the plate: the union of its cameras' views along x
        half_view = (distance * intrinsics.width / (2 * intrinsics.fx) + 0.5 * context.baseline_m
                     if direction[0] else distance * intrinsics.height / (2 * intrinsics.fy))
        # the plate covers the points p with p . direction >= edge
        edge = half_view * (1.0 - 2.0 * min(fraction, 1.0))
        centre = (edge + self._half_size_m) * direction
        local = np.array([centre[0], centre[1], distance])
        position = context.position + context.rotation @ local
        world.set_body_pose(self._body, position.tolist(),
                            matrix_to_quaternion(context.rotation).tolist())


def _add_sensor_noise(image: np.ndarray, shot_gain: float, read_noise_dn: float,
                      rng: np.random.Generator) -> np.ndarray:
    """``image + n`` with ``n ~ N(0, shot_gain I + read_noise_dn^2)`` per pixel (DN)."""
    variance = shot_gain * np.clip(image, 0.0, None) + read_noise_dn ** 2
    noise = rng.standard_normal(image.shape, dtype=np.float32)
    return image + noise * np.sqrt(variance, dtype=np.float32)


@dataclass
class LowLight(VisualFault):
    """Weak lighting down to complete darkness (wang2023 Fig. 7 ②; darkness during 75-150 s).

    The scene light is scaled by ``1 - strength`` (strength 1: "entire black image feedback"),
    and the sensor's noise grows relative to the signal, as it does when fewer photons arrive:
    per pixel, ``I' = b I + n`` with ``b = 1 - strength`` and ``n ~ N(0, strength (g b I) +
    (strength r)^2)``: shot noise of gain ``g = shot_noise_gain`` (DN per DN) and read noise of
    ``r = read_noise_dn`` (DN). "Low-level light would reduce the number of visual features"
    (Section IV-C2): the contrast drops below ORB's FAST threshold while the noise rises.
    """

    shot_noise_gain: float = 1.0
    read_noise_dn: float = 3.0

    stage: ClassVar[int] = 10

    def __post_init__(self) -> None:
        super().__post_init__()
        require_non_negative("shot_noise_gain", self.shot_noise_gain)
        require_non_negative("read_noise_dn", self.read_noise_dn)

    def apply(self, image: np.ndarray, context: FrameContext) -> np.ndarray:
        strength = self.strength_at(context.time_s)
        if strength <= 0.0:
            return image
        signal = np.clip(image, 0.0, None) * (1.0 - strength)
        return _add_sensor_noise(signal, strength * self.shot_noise_gain,
                                 strength * self.read_noise_dn, context.rng)


@dataclass
class LEDGlare(VisualFault):
    """A moving LED shining into the camera (wang2023 Fig. 7 ③, 150-200 s).

    A bright blob moves over the image along a Lissajous path (frequencies in
    ``frequency_range_hz`` and phases drawn per episode). Its added light is
    ``255 strength (core_gain g(r / radius) + veil g(r / (3 radius)))`` with
    ``g(x) = exp(-x^2 / 2)``
    and ``radius = radius_fraction * width``: a saturating core ("most of the features
    (especially on the lighting spot area) would be lost") and a wide veil that washes out
    the contrast around it. With the defaults, the core is saturated white within about
    ``1.4 radius`` at strength 1.

    Args:
        radius_fraction: core radius over the image width.
        core_gain: peak of the core in full-scale units (> 1 saturates).
        veil: peak of the wide veil in full-scale units. An LED shining straight into a small
            endoscope lens scatters over much of the frame; at 0.6 the veil alone lifts the
            image by 60 % of full scale at the blob and still by 48 % two core radii away
            (``0.6 exp(-4 / 18)``), and the vision tracker's mean error on the slow spiral
            doubles (2.3x clean).
        frequency_range_hz: range of the path's frequencies (Hz).
        colour: RGB of the LED light (0..1).
    """

    radius_fraction: float = 0.1
    core_gain: float = 3.0
    veil: float = 0.6
    frequency_range_hz: tuple[float, float] = (0.05, 0.25)
    colour: tuple[float, float, float] = (1.0, 0.97, 0.9)

    stage: ClassVar[int] = 20
    _frequencies: np.ndarray = field(default_factory=lambda: np.array([0.1, 0.13]), init=False,
                                     repr=False)
    _phases: np.ndarray = field(default_factory=lambda: np.zeros(2), init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        require_in_range("radius_fraction", self.radius_fraction, 1e-3, 1.0)
        require_non_negative("core_gain", self.core_gain)
        require_non_negative("veil", self.veil)
        low, high = (float(v) for v in self.frequency_range_hz)
        if not (np.isfinite(low) and np.isfinite(high) and 0 < low <= high):
            raise ValueError("frequency_range_hz must be (low, high) with 0 < low <= high, got "
                             f"{self.frequency_range_hz!r}")
        colour = np.asarray(self.colour, dtype=float)
        if (colour.shape != (3,) or np.any(~np.isfinite(colour))
                or np.any((colour < 0) | (colour > 1))):
            raise ValueError(f"colour must be 3 numbers in [0, 1], got {self.colour!r}")

    def reset(self, rng: np.random.Generator) -> None:
        self._frequencies = rng.uniform(*self.frequency_range_hz, size=2)
        self._phases = rng.uniform(0.0, 2.0 * math.pi, size=2)

    def centre_px(self, time_s: float, width: int, height: int) -> np.ndarray:
        """Blob centre (u, v) in pixels at ``time_s`` (s); it stays within the middle 70 %."""
        s = np.sin(2.0 * math.pi * self._frequencies * time_s + self._phases)
        return np.array([(0.5 + 0.35 * s[0]) * (width - 1), (0.5 + 0.35 * s[1]) * (height - 1)])

    def radius_px(self, width: int) -> float:
        """Core radius (px) for an image ``width`` pixels wide."""
        return self.radius_fraction * width

    def apply(self, image: np.ndarray, context: FrameContext) -> np.ndarray:
        strength = self.strength_at(context.time_s)
        if strength <= 0.0:
            return image
        height, width = image.shape[:2]
        cu, cv = self.centre_px(context.time_s, width, height)
        radius = self.radius_px(width)
        u = (np.arange(width, dtype=np.float32) - cu) / radius
        v = (np.arange(height, dtype=np.float32) - cv) / radius
        r2 = v[:, None] ** 2 + u[None, :] ** 2
        light = 255.0 * strength * (self.core_gain * np.exp(-0.5 * r2)
                                    + self.veil * np.exp(-r2 / 18.0))
        return image + light[:, :, None] * np.asarray(self.colour, dtype=np.float32)


@dataclass
class MotionBlur(VisualFault):
    """Blur along the image motion during the exposure (wang2023 Section IV-E2, finger flicks).

    The image motion is estimated from the camera's pose change since its previous frame: the
    points seen at a 3 x 3 grid of pixels, at the frame's median depth, are projected into the
    previous camera; the mean pixel displacement over the frame interval ``dt`` times
    ``exposure_s / dt`` (at most 1) times ``strength`` is the length of a linear blur kernel
    along that direction. (Rotation about the optical axis, which blurs the corners more than
    the centre, is reduced to its mean.)

    Args:
        exposure_s: exposure time (s); an endoscope camera at 20-30 frames/s exposes ~1/30 s.
        max_length_px: longest blur (px).
    """

    exposure_s: float = 1.0 / 30.0
    max_length_px: float = 40.0

    stage: ClassVar[int] = 30

    def __post_init__(self) -> None:
        super().__post_init__()
        require_positive("exposure_s", self.exposure_s)
        require_positive("max_length_px", self.max_length_px)

    def blur_vector_px(self, context: FrameContext) -> np.ndarray:
        """Image displacement (px, (du, dv)) during the exposure; zeros when unknown."""
        strength = self.strength_at(context.time_s)
        if (strength <= 0.0 or context.previous_rotation is None or context.previous_time_s is None
                or context.depth is None):
            return np.zeros(2)
        dt = context.time_s - context.previous_time_s
        if dt <= 0.0:
            return np.zeros(2)
        intrinsics = context.intrinsics
        depth = context.depth
        valid = depth[depth < 0.999 * intrinsics.far_m]
        if valid.size == 0:
            return np.zeros(2)
        z = float(np.median(valid))
        K = intrinsics.K()
        grid = np.array([[u, v] for u in (0.2, 0.5, 0.8) for v in (0.2, 0.5, 0.8)])
        pixels = grid * [intrinsics.width - 1, intrinsics.height - 1]
        rays = np.linalg.solve(K, np.vstack([pixels.T, np.ones(len(pixels))]))
        world = context.rotation @ (rays * z) + context.position[:, None]
        previous = context.previous_rotation.T @ (world - context.previous_position[:, None])
        if np.any(previous[2] <= 1e-6):
            return np.zeros(2)
        projected = (K @ (previous / previous[2]))[:2].T
        displacement = (pixels - projected).mean(axis=0)
        vector = displacement * min(1.0, self.exposure_s / dt) * strength
        length = float(np.linalg.norm(vector))
        if length > self.max_length_px:
            vector *= self.max_length_px / length
        return vector

    @staticmethod
    def kernel(vector_px: np.ndarray) -> np.ndarray:
        """Normalised linear blur kernel along ``vector_px`` (sub-pixel, bilinear splats).

        The exposure ends at the frame's time: a scene point now at pixel ``x`` was at
        ``x - s vector_px`` a fraction ``s`` of the exposure earlier, so the blurred frame is the
        mean of the sharp frame sampled at ``x + s vector_px``, ``s`` in [0, 1]. The kernel is
        one-sided (it starts at its centre, the filter's anchor): the streak trails the motion,
        and its centroid lies half a blur behind the frame's pose, which is where a feature
        tracker finds the blurred features.
        """
        length = float(np.linalg.norm(vector_px))
        size = 2 * int(math.ceil(length)) + 3
        kernel = np.zeros((size, size), dtype=np.float32)
        centre = (size - 1) / 2.0
        n = max(2, int(math.ceil(4 * length)) + 1)
        for s in np.linspace(0.0, 1.0, n):
            x = centre + s * vector_px[0]
            y = centre + s * vector_px[1]
            x0, y0 = int(math.floor(x)), int(math.floor(y))
            fx, fy = x - x0, y - y0
            kernel[y0, x0] += (1 - fx) * (1 - fy)
            kernel[y0, x0 + 1] += fx * (1 - fy)
            kernel[y0 + 1, x0] += (1 - fx) * fy
            kernel[y0 + 1, x0 + 1] += fx * fy
        return kernel / kernel.sum()

    def apply(self, image: np.ndarray, context: FrameContext) -> np.ndarray:
        vector = self.blur_vector_px(context)
        if np.linalg.norm(vector) < 0.5:
            return image
        return cv2.filter2D(image, -1, self.kernel(vector), borderType=cv2.BORDER_REPLICATE)


@dataclass
class SensorNoise(VisualFault):
    """Image sensor noise: shot noise (variance ``shot_noise_gain * I``) and Gaussian read noise
    (std ``read_noise_dn``), both scaled by ``strength``; the read-out then rounds and clips to
    8 bits. A small endoscope camera is noisy even in good light (wang2023 Fig. 6 ①)."""

    read_noise_dn: float = 2.0
    shot_noise_gain: float = 0.2

    stage: ClassVar[int] = 40

    def __post_init__(self) -> None:
        super().__post_init__()
        require_non_negative("read_noise_dn", self.read_noise_dn)
        require_non_negative("shot_noise_gain", self.shot_noise_gain)

    def apply(self, image: np.ndarray, context: FrameContext) -> np.ndarray:
        strength = self.strength_at(context.time_s)
        if strength <= 0.0:
            return image
        return _add_sensor_noise(image, strength * self.shot_noise_gain,
                                 strength * self.read_noise_dn, context.rng)


FAULTS: Registry[type[VisualFault]] = Registry("fault")
"""Fault names and classes."""
FAULTS.register("moving_occluder", MovingOccluder)
FAULTS.register("low_light", LowLight)
FAULTS.register("led_glare", LEDGlare)
FAULTS.register("motion_blur", MotionBlur)
FAULTS.register("sensor_noise", SensorNoise)


FAULT_PRESETS: Registry[Callable[..., list[VisualFault]]] = Registry("fault preset")
"""Preset names and the functions building their fault lists (parameters as keywords): a paper's
fault protocols, registered with it (``Paper.fault_presets``, e.g. wang2023's Figs. 6-7 in
:mod:`soft_gym.papers.wang2023.faults`)."""


def make_faults(faults: Any) -> list[VisualFault]:
    """Turn a fault description into a list of fault instances.

    ``faults`` is ``None``, a fault or preset name (``"low_light"``, ``"wang2023_lighting"``), a
    dict with ``"name"`` and parameters (``{"name": "low_light", "strength": 0.5}``,
    ``{"name": "wang2023_occlusion", "time_scale": 0.1}``), a :class:`VisualFault`, or a list or
    tuple of these (parsed by :func:`soft_gym._registry.parse_spec`).
    """
    made: list[VisualFault] = []
    for item in parse_spec(faults, "faults", list(FAULTS) + list(FAULT_PRESETS), forms=FORMS,
                           instance_types=(VisualFault,)):
        if not isinstance(item, Spec):
            made.append(item)
            continue
        built = build("faults", item.name, FAULTS.get(item.name) or FAULT_PRESETS[item.name],
                      item.params)
        made.extend(built if isinstance(built, list) else [built])
    return made


def replace_faults(current: list[VisualFault], faults: Any, world,
                   attach: Callable[[VisualFault], None],
                   rng: np.random.Generator) -> list[VisualFault]:
    """A camera's new faults for the description ``faults``, in stage order: the geometric ones
    of ``current`` leave the simulator's ``world`` and, where the camera is already built
    (``world`` not ``None``), the new geometric ones are placed by ``attach`` and every new one
    is reset with ``rng``."""
    new = sorted(make_faults(faults), key=lambda fault: fault.stage)
    if world is not None:
        for fault in current:
            if fault.geometric:
                fault.detach(world)
        for fault in new:
            if fault.geometric:
                attach(fault)
            fault.reset(rng)
    return new


def faults_per_sensor(faults: Any) -> dict[str, Any] | None:
    """The per-camera form of a fault description, or ``None`` for one shared description.

    A dict without ``"name"`` whose keys are camera sensor names (:data:`FAULT_SENSORS`:
    ``"image"``, ``"stereo"``) gives each camera its own description, e.g.
    ``{"stereo": "low_light", "image": None}``; its values are checked with :func:`make_faults`.
    Anything else is one description (:func:`make_faults`) for every camera.
    """
    if not isinstance(faults, dict) or "name" in faults:
        return None
    if not faults or not all(isinstance(key, str) and key in FAULT_SENSORS for key in faults):
        raise ValueError(f"faults as a dict is one fault ({{'name': ..., parameters}}) or one "
                         f"description per camera keyed by {list(FAULT_SENSORS)}, got keys "
                         f"{sorted(map(str, faults))!r}")
    for key, value in faults.items():
        try:
            make_faults(value)
        except ValueError as error:
            raise ValueError(f"faults[{key!r}]: {error}") from None
    return dict(faults)


def copy_faults(faults: Any) -> list[VisualFault]:
    """Fresh faults with the parameters of ``faults`` (any :func:`make_faults` description),
    sharing no state: neither episode draws nor bodies. For giving one description to two
    cameras: a fault instance can serve one camera only."""
    fresh = []
    for fault in make_faults(faults):
        values = {f.name: getattr(fault, f.name) for f in fields(fault) if f.init}
        fresh.append(type(fault)(**values))
    return fresh


__all__ = ["FrameContext", "VisualFault", "MovingOccluder", "LowLight", "LEDGlare", "MotionBlur",
           "SensorNoise", "FAULTS", "FAULT_PRESETS", "FAULT_SENSORS", "EYE_IN_HAND_OCCLUDER_M",
           "make_faults", "faults_per_sensor", "copy_faults"]
