"""ASES: the arm's 3-D shape from a stereo pair (Zou et al. 2022, Section 4, eqs. 11-16, Table 1).

Zou et al. 2022 estimate the backbone of their soft manipulator with a ZED stereo camera in front
of a plain white background. Per image (Section 4.1): a Gaussian filter, an HSV threshold on the
arm's colour, a morphological filter and the arm's contour; then (Section 4.2) a self-organising
map (SOM) whose ``b = 7`` output neurons, a chain, cluster the contour pixels into centre points
ordered along the arm; thanks to that ordering the ``k``-th neurons of the left and right images
are the same point of the arm "without any sorting algorithm", and triangulation (Section 4.3,
eqs. 13-16) gives the backbone in the arm's frame.

SOM (eqs. 11-12, Table 1: ``S = 3``, ``alpha(0) = 0.01``, ``lambda = 15``, ``b = 7``). For each
input ``m_r`` drawn at random from the contour, the winner is ``k* = argmin_k ||m_r - W_k||``
(eq. 11) and every neuron of the winning neighbourhood moves,
``W_k <- W_k + eta(delta) alpha(t) (m_r - W_k)`` (eq. 12), ``delta = |k - k*|``. The paper is
vague about the schedule; here (documented choices):

* the "training number" ``lambda`` counts epochs: ``t = 0 .. lambda - 1`` passes over every contour
  pixel in a seeded random order (15 single draws, the literal reading, would leave a neuron
  within 15 % of its start at ``alpha = 0.01``);
* ``alpha(t) = alpha(0) / (1 + t / lambda)`` (the paper's formula);
* the neighbourhood radius shrinks linearly, ``S(t) = S (1 - t / lambda)``, and
  ``eta(delta) = exp(-delta^2 / (2 (S(t) / 2)^2))`` for ``delta <= S(t)``, 0 beyond ("decreases
  gradually with time", "usually represented by Gaussian function"); the last third of the
  epochs (``S(t) < 1``) move the winner alone, so the chain settles on the cells' centroids;
* the chain starts on the straight line from the contour pixel nearest the projected base
  (the camera's calibration gives it) to the contour pixel farthest from it, so both images'
  chains run from the base to the tip and match neuron by neuron.

:func:`train_som` runs eq. 12 exactly as the sequential loop does, but vectorised: for a run of
inputs it assumes the winners found with the weights at the run's start, computes every
intermediate weight of the run in closed form (each neuron follows the linear recurrence
``W <- (1 - a_n) W + a_n m_n``, solved with cumulative products), checks each input's winner
against the weights just before it and accepts the run up to the first input whose winner was
wrong, from where it goes on. The result equals the sequential loop's up to rounding.

From neurons to the seven points. The SOM's end neurons sit at the centroids of the end cells,
half a cell inside the arm's ends (a chain of neurons on a uniform line settles at the midpoints
of equal cells), while the paper's ``Q_1`` and ``Q_7`` are the base and the tip. So the neurons of
both images are triangulated (``cv2.triangulatePoints`` with the two projection matrices; the
stereo sensor's matrices map the arm's base frame to pixels, so the result is already in that
frame: eq. 16's ``T_{L-g}``, "determined ... with multiple known markers"), the tip end is the
last neuron continued by half its spacing, the base end is the arm's base (the origin of the
calibrated frame, where the arm is clamped; the chain's own base end, continued the same way,
must triangulate within ``base_tolerance_m`` of it), and this polyline is resampled at seven
equal arc-length steps: the points ``P_0 .. P_6`` at sixths of the arm's length (the ``shape``
observation's points; material points at sixths for an evenly stretched arm). On 40 random
poses of the zou2022 arm in 320 x 180 frames the points were 2.8 mm from the true ones on average
(base 0, tip 6.5 mm; the depth resolution is ~9 mm per pixel of disparity there); walking from the
end neurons to the mask's end instead gave 5.1 mm (the silhouette's ends are rims, not the axis).

Failure is explicit (Section 4.4, Fig. 13: poor light, self-occlusion): the result is ``lost``,
with a reason and NaN points, when an image has too few arm pixels, the arm's mask is broken
into pieces, it touches the image border, the arm's tip end is hidden by an occluder (below),
matched neurons leave their common epipolar line (the cameras are parallel: a point has the same
image row in both), or the backbone's base end does not triangulate at the arm's base.

The occlusion check. Something in front of the arm's tip half (a plate coming up from below)
leaves a shorter arm that passes every other check, and the visible part is taken for the whole
arm: with a grey plate over the bottom 60 % of the pair's view, 20 random poses gave 46 mm mean
point error (90 mm at the tip) and none was lost. zou2022's set-up gives the test: the background
is plain white ("the single white is selected as the experimental background"), so in a clean
frame all that lies just outside the arm's silhouette is backdrop, and where the silhouette's tip
end meets something that is neither arm nor backdrop, the arm may go on behind it.
:func:`tip_occlusion` looks at a ring of pixels ``occlusion_gap_px`` (3) to 4 px outside the
filled silhouette (beyond the Gaussian filter's reach, which mixes the arm's colour into the first
pixels around it), in the filtered image. The backdrop's colour is the median of the ring (the
arm's surroundings: mostly backdrop even where a plate cuts the arm). A ring pixel within
``w + 5`` px of the chain's tip end (``w`` the arm's width, the silhouette's area over the chain's
length) counts as occluder when its colour is more than ``backdrop_tolerance`` (15 %) of the
backdrop's away from it, ``||c - c_ref|| > 0.15 ||c_ref||`` (relative: dim light scales both
alike), and it is not arm-coloured (inside the HSV threshold before the opening: the arm's own
darkest rim, which the opening drops, is no occluder). The occluders' count over the ring's width
is the length of the occluder's edge at the tip; from ``tip_occlusion_widths`` (0.75) arm widths
on, the pair is lost ("tip end is hidden by an occluder"). A straight cut across the arm gives
~1.5 (the cut and the ring's corners). Measured on 100 random settled poses of the zou2022 arm in
the 320 x 180 pair (20 + 40 in front of the renderer's white, 40 in front of the stereo sensor's
backdrop board): the largest value on clean frames was 0.0, with 70 % less light 0.1 (backdrop
pixels: 99.9 % within 0.08 of the reference), on tips cut by a plate at least 1.55; no clean or
dimmed (50 % / 70 % less light) frame was lost, every frame with the bottom 60 % covered was. The
same test catches a tip washed out by LED glare (pale: neither the arm's colour nor white; at
glare strength 0.5 the frames not lost went from 12 mm mean error, up to 78 mm, to 2.7 mm) and a
tip lost in the dark (with 75 % less light the dim tip drops out of the mask first: of 20
frames, 10 were found, with 13 mm mean error; now all 20 are lost). It also flags a tip that
merely touches an occluder's edge (it cannot tell whether the arm ends there: with the bottom
30 % covered, 4 of 20 frames), and it cannot see an occluder of the backdrop's colour, nor glare
that saturates the tip to the backdrop's white. It costs ~0.7 ms per pair.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import cv2
import numpy as np

from soft_gym._validation import (as_finite_array, fields_from_options, require_in_range,
                                  require_integer, require_number, require_positive, require_seed)

N_POINTS = 7
"""``b`` of Table 1: centre points per image, and points ``P_0 .. P_6`` of the backbone."""


@dataclass(frozen=True)
class ASESConfig:
    """Image processing and SOM settings (defaults: Table 1 and a 320 x 180 frame of the zou2022
    arm, the builder's orange, hue ~13 of OpenCV's 0-180).

    Attributes:
        blur_kernel_px: Gaussian filter size (px, odd), Section 4.1.
        blur_sigma_px: Gaussian filter standard deviation (px).
        hsv_low, hsv_high: inclusive HSV bounds of the arm's colour (OpenCV ranges: H 0-180,
            S and V 0-255).
        open_kernel_px: morphological opening size (px; 1 disables it), removes isolated pixels.
        min_mask_px: fewer arm pixels in an image than this -> lost.
        min_main_fraction: the largest connected region must hold at least this fraction of the
            arm's pixels, else the contour is broken -> lost.
        som_radius: ``S`` (neurons).
        som_alpha0: ``alpha(0)``.
        som_epochs: ``lambda`` (epochs; see the module docstring).
        n_points: ``b``, neurons of the chain and points of the result.
        max_contour_points: a longer contour is subsampled evenly to this many pixels (bounds
            the SOM's time on large frames).
        epipolar_tolerance_px: largest row difference of matched neurons (px).
        base_tolerance_m: largest distance of the triangulated base end from the base (m).
        seed: seeds the SOM's input order (a frame gives the same shape every time).
        occlusion_gap_px: the occlusion check (module docstring) looks at the pixels
            ``occlusion_gap_px`` to ``occlusion_gap_px + 1`` px outside the arm's silhouette
            (px, >= 1; beyond the Gaussian filter's reach, where a clean frame shows pure
            backdrop).
        backdrop_tolerance: such a pixel is backdrop when its (filtered) colour lies within
            this relative RGB distance ``||c - c_ref|| / ||c_ref||`` of the backdrop's colour
            ``c_ref`` (the median of those pixels around the arm); > 0.
        tip_occlusion_widths: the pair is lost when the pixels around an image's tip end that
            are neither arm nor backdrop make an edge at least this long, in arm widths (> 0;
            a cut across the arm makes ~1.5, a clean frame ~0; ``math.inf`` turns the check
            off).
    """

    blur_kernel_px: int = 5
    blur_sigma_px: float = 1.0
    hsv_low: tuple[int, int, int] = (3, 90, 40)
    hsv_high: tuple[int, int, int] = (25, 255, 255)
    open_kernel_px: int = 3
    min_mask_px: int = 40
    min_main_fraction: float = 0.9
    som_radius: float = 3.0
    som_alpha0: float = 0.01
    som_epochs: int = 15
    n_points: int = N_POINTS
    max_contour_points: int = 600
    epipolar_tolerance_px: float = 4.0
    base_tolerance_m: float = 0.02
    seed: int = 0
    occlusion_gap_px: int = 3
    backdrop_tolerance: float = 0.15
    tip_occlusion_widths: float = 0.75

    def __post_init__(self) -> None:
        kernel = require_integer("blur_kernel_px", self.blur_kernel_px, 1)
        if kernel % 2 == 0:
            raise ValueError(f"blur_kernel_px must be an odd integer >= 1, got {kernel!r}")
        require_positive("blur_sigma_px", self.blur_sigma_px)
        for name in ("hsv_low", "hsv_high"):
            value = getattr(self, name)
            limits = (180, 255, 255)
            if (not isinstance(value, (tuple, list)) or len(value) != 3 or not all(
                    isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                    and 0 <= v <= m for v, m in zip(value, limits))):
                raise ValueError(f"{name} must be 3 integers (H 0-180, S 0-255, V 0-255), got "
                                 f"{value!r}")
        if any(lo > hi for lo, hi in zip(self.hsv_low, self.hsv_high)):
            raise ValueError(f"hsv_low must be <= hsv_high element-wise, got {self.hsv_low!r} "
                             f"and {self.hsv_high!r}")
        require_integer("open_kernel_px", self.open_kernel_px, 1)
        require_integer("min_mask_px", self.min_mask_px, 1)
        require_in_range("min_main_fraction", self.min_main_fraction, 0.0, 1.0)
        require_positive("som_radius", self.som_radius)
        require_in_range("som_alpha0", self.som_alpha0, 1e-9, 0.5)
        require_integer("som_epochs", self.som_epochs, 1)
        require_integer("n_points", self.n_points, 3)
        require_integer("max_contour_points", self.max_contour_points, 10)
        require_positive("epipolar_tolerance_px", self.epipolar_tolerance_px)
        require_positive("base_tolerance_m", self.base_tolerance_m)
        require_seed("seed", self.seed)
        require_integer("occlusion_gap_px", self.occlusion_gap_px, 1)
        require_positive("backdrop_tolerance", self.backdrop_tolerance)
        widths = require_number("tip_occlusion_widths", self.tip_occlusion_widths)
        if math.isnan(widths) or widths <= 0:
            raise ValueError(f"tip_occlusion_widths must be a number > 0 (math.inf turns the "
                             f"check off), got {self.tip_occlusion_widths!r}")

    @classmethod
    def from_options(cls, options: dict[str, Any]) -> "ASESConfig":
        """From a dict of some of the fields; an unknown name is refused by name."""
        values = {k: tuple(v) if k in ("hsv_low", "hsv_high") and isinstance(v, list) else v
                  for k, v in fields_from_options(cls, options, "ASES").items()}
        return cls(**values)

    def describe(self) -> dict[str, Any]:
        """The settings as plain values (a cache key)."""
        return asdict(self)


@dataclass
class StereoShape:
    """One ASES result.

    Attributes:
        points_m: ``P_0 .. P_6`` (m, the projection matrices' world frame, (7, 3)), NaN if lost.
        lost: the pair gave no trustworthy shape.
        reason: why it was lost ("" when not).
        som_px: the SOM's neurons (px, (b, 2) per side; absent where the image failed first).
        ends_px: the chain's base and tip ends, half a cell beyond the end neurons (px, (2, 2)
            per side).
        mask_px: arm pixels per side.
        tip_occlusion: per side, the length of the edge that is neither arm nor backdrop at
            the tip end (arm widths; see :func:`tip_occlusion`; absent where the image failed
            first).
    """

    points_m: np.ndarray
    lost: bool
    reason: str = ""
    som_px: dict[str, np.ndarray] = field(default_factory=dict)
    ends_px: dict[str, np.ndarray] = field(default_factory=dict)
    mask_px: dict[str, int] = field(default_factory=dict)
    tip_occlusion: dict[str, float] = field(default_factory=dict)


# ---------------------------------------------------------------------------------- the SOM
def som_learning_rate(t: int, alpha0: float, epochs: int) -> float:
    """``alpha(t) = alpha(0) / (1 + t / lambda)`` (Section 4.2), ``t`` the epoch."""
    return alpha0 / (1.0 + t / epochs)


def som_neighbourhood(t: int, radius: float, epochs: int, n_nodes: int) -> np.ndarray:
    """``eta`` of eq. 12 at epoch ``t`` as a table ``(b, b)``: row ``k*``, column ``k``.

    ``S(t) = S (1 - t / lambda)``; ``eta(delta) = exp(-delta^2 / (2 (S(t)/2)^2))`` for
    ``delta = |k - k*| <= S(t)``, else 0; the winner always gets 1.
    """
    reach = radius * (1.0 - t / epochs)
    delta = np.abs(np.arange(n_nodes)[:, None] - np.arange(n_nodes)[None, :]).astype(float)
    sigma = max(0.5 * reach, 1e-12)
    table = np.where(delta <= reach, np.exp(-delta ** 2 / (2.0 * sigma ** 2)), 0.0)
    table[delta == 0] = 1.0
    return table


def train_som(points: np.ndarray, initial: np.ndarray, radius: float = 3.0,
              alpha0: float = 0.01, epochs: int = 15,
              rng: np.random.Generator | int = 0) -> np.ndarray:
    """The chain SOM of eqs. 11-12 trained on ``points`` (h, 2) from ``initial`` (b, 2).

    Each epoch ``t`` presents every input once, in an order drawn from ``rng``
    (``rng.permutation(h)`` per epoch); the result equals the sequential per-input loop's up to
    rounding (see the module docstring for the vectorised evaluation).

    Returns:
        The trained neurons ``W`` (b, 2), same units as ``points``.
    """
    data = as_finite_array("points", points)
    weights = as_finite_array("initial", initial).copy()
    if data.ndim != 2 or data.shape[0] < 1 or data.shape[1] < 1:
        raise ValueError(f"points must have shape (h >= 1, dim), got {data.shape}")
    if weights.ndim != 2 or weights.shape[1] != data.shape[1] or weights.shape[0] < 1:
        raise ValueError(f"initial must have shape (b >= 1, {data.shape[1]}), got "
                         f"{weights.shape}")
    require_positive("radius", radius)
    require_in_range("alpha0", alpha0, 1e-9, 0.5)
    epochs = require_integer("epochs", epochs, 1)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(
        require_integer("rng", rng, 0))
    n_nodes = weights.shape[0]
    # runs short enough that the cumulative products stay above 1e-3 (no cancellation)
    longest = max(1, min(128, int(math.log(1e-3) / math.log(1.0 - alpha0))))
    for t in range(epochs):
        alpha = som_learning_rate(t, alpha0, epochs)
        rates = alpha * som_neighbourhood(t, radius, epochs, n_nodes)
        weights = _som_epoch(data[generator.permutation(len(data))], weights, rates, longest)
    return weights


def _som_epoch(inputs: np.ndarray, weights: np.ndarray, rates: np.ndarray,
               longest: int) -> np.ndarray:
    """One pass of eq. 12 over ``inputs`` in order; ``rates[k*, k] = alpha eta(|k - k*|)``."""
    start, run, n = 0, min(16, longest), len(inputs)
    while start < n:
        chunk = inputs[start:start + run]
        distance = ((chunk[:, None, :] - weights[None]) ** 2).sum(axis=-1)
        winners = distance.argmin(axis=1)                           # eq. 11, weights at start
        a = rates[winners]                                          # (c, b)
        keep = np.cumprod(1.0 - a, axis=0)                          # prod_{j <= n} (1 - a_j)
        # W after input n: keep_n (W_0 + sum_{j <= n} a_j m_j / keep_j)
        terms = (a / keep)[:, :, None] * chunk[:, None, :]
        trajectory = keep[:, :, None] * (weights[None] + np.cumsum(terms, axis=0))
        check = ((chunk[1:, None, :] - trajectory[:-1]) ** 2).sum(axis=-1).argmin(axis=1)
        wrong = np.flatnonzero(check != winners[1:])
        if wrong.size:
            accepted = int(wrong[0]) + 1
            weights = trajectory[accepted - 1]
            start += accepted
            run = max(4, accepted)
        else:
            weights = trajectory[-1]
            start += len(chunk)
            run = min(2 * run, longest)
    return weights


# ---------------------------------------------------------------------------------- one image
def _segment(image: np.ndarray, config: ASESConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Section 4.1 on a uint8 RGB image: the filtered image (uint8 (H, W, 3)), the HSV
    threshold before the opening and the arm's mask after it (uint8 (H, W) of 0 / 255)."""
    blurred = cv2.GaussianBlur(image, (config.blur_kernel_px, config.blur_kernel_px),
                               config.blur_sigma_px)
    hsv = cv2.cvtColor(blurred, cv2.COLOR_RGB2HSV)
    thresholded = cv2.inRange(hsv, np.array(config.hsv_low, np.uint8),
                              np.array(config.hsv_high, np.uint8))
    mask = thresholded
    if config.open_kernel_px > 1:
        kernel = np.ones((config.open_kernel_px, config.open_kernel_px), np.uint8)
        mask = cv2.morphologyEx(thresholded, cv2.MORPH_OPEN, kernel)
    return blurred, thresholded, mask


def arm_mask(image: np.ndarray, config: ASESConfig = ASESConfig()) -> np.ndarray:
    """Section 4.1: Gaussian filter, HSV threshold, opening; uint8 mask (H, W) of 0 / 255."""
    return _segment(image, config)[2]


OCCLUSION_RING_PX = 2
"""Width of the ring of pixels the occlusion check looks at (px)."""


def _disk(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def tip_occlusion(blurred: np.ndarray, thresholded: np.ndarray, silhouette: np.ndarray,
                  chain_px: np.ndarray, config: ASESConfig = ASESConfig()) -> float:
    """How much of an occluder's edge the arm's tip end abuts in one image (arm widths).

    Args:
        blurred: the Gaussian-filtered RGB image (uint8 (H, W, 3)).
        thresholded: its HSV threshold before the opening (uint8 (H, W), 0 / 255): arm-coloured
            pixels.
        silhouette: the arm's main region, filled (uint8 (H, W), 0 / 255).
        chain_px: the chain from the base end through the SOM's neurons to the tip end (px,
            (b + 2, 2)).
        config: ``occlusion_gap_px`` and ``backdrop_tolerance``.

    Returns:
        The number of occluder pixels (neither arm-coloured nor backdrop) in the ring
        ``occlusion_gap_px .. occlusion_gap_px + 1`` px outside the silhouette within
        ``w + occlusion_gap_px + 2`` px of the tip end, divided by the ring's width (2 px) and
        the arm's width ``w`` (px, the silhouette's area over the chain's length): the length
        of the occluder's edge at the tip in arm widths. The backdrop's colour is the median of
        the ring's pixels away from the tip. See the module docstring.
    """
    blurred = np.asarray(blurred)
    if blurred.ndim != 3 or blurred.shape[2] != 3 or blurred.dtype != np.uint8:
        raise ValueError(f"blurred must be a uint8 RGB image (H, W, 3), got {blurred.dtype} "
                         f"{blurred.shape}")
    for name, value in (("thresholded", thresholded), ("silhouette", silhouette)):
        array = np.asarray(value)
        if array.shape != blurred.shape[:2] or array.dtype != np.uint8:
            raise ValueError(f"{name} must be a uint8 mask of the image's size "
                             f"{blurred.shape[:2]}, got {array.dtype} {array.shape}")
    chain = as_finite_array("chain_px", chain_px)
    if chain.ndim != 2 or chain.shape[0] < 2 or chain.shape[1] != 2:
        raise ValueError(f"chain_px must have shape (n >= 2, 2) (px), got {chain.shape}")
    silhouette = np.ascontiguousarray(silhouette)
    gap = config.occlusion_gap_px
    near = cv2.dilate(silhouette, _disk(gap - 1)) if gap > 1 else silhouette
    far = cv2.dilate(silhouette, _disk(gap - 1 + OCCLUSION_RING_PX))
    rows, cols = np.nonzero(cv2.subtract(far, near))
    if rows.size == 0:
        return 0.0
    length = max(float(np.linalg.norm(np.diff(chain, axis=0), axis=1).sum()), 1.0)
    width = max(cv2.countNonZero(silhouette) / length, 1.0)
    reach = width + gap + OCCLUSION_RING_PX
    at_tip = (cols - chain[-1, 0]) ** 2 + (rows - chain[-1, 1]) ** 2 <= reach ** 2
    if not at_tip.any():
        return 0.0
    colours = blurred[rows, cols].astype(np.float32)
    around = colours[~at_tip] if np.count_nonzero(~at_tip) >= 8 else colours
    backdrop = np.median(around, axis=0)
    tip_colours = colours[at_tip]
    distance = (np.linalg.norm(tip_colours - backdrop, axis=1)
                / max(float(np.linalg.norm(backdrop)), 1.0))
    occluder = (distance > config.backdrop_tolerance) & (thresholded[rows[at_tip],
                                                                      cols[at_tip]] == 0)
    return float(np.count_nonzero(occluder)) / (OCCLUSION_RING_PX * width)


def _check_image(name: str, image: Any) -> np.ndarray:
    array = np.asarray(image)
    if (array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8
            or min(array.shape[:2]) < 8):
        raise ValueError(f"{name} must be a uint8 RGB image (H >= 8, W >= 8, 3), got "
                         f"{array.dtype} {array.shape}")
    return np.ascontiguousarray(array)


def _check_projection(name: str, matrix: Any) -> np.ndarray:
    array = as_finite_array(name, matrix, (3, 4))
    if np.linalg.matrix_rank(array[:, :3]) < 3:
        raise ValueError(f"{name} must be a 3 x 4 projection matrix with an invertible left "
                         f"3 x 3 block, got {array.tolist()}")
    return array


def _project(matrix: np.ndarray, point: np.ndarray) -> np.ndarray:
    homogeneous = matrix @ np.append(point, 1.0)
    return homogeneous[:2] / homogeneous[2]


def _centreline(mask: np.ndarray, base_px: np.ndarray, config: ASESConfig, side: str
                ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None, str]:
    """SOM neurons (b, 2), half-cell ends (2, 2) and the main contour (OpenCV's (n, 1, 2)) of
    one image's arm, or why it failed."""
    count = int(cv2.countNonZero(mask))
    if count < config.min_mask_px:
        return None, None, None, f"{side}: {count} arm pixels (fewer than {config.min_mask_px})"
    if (mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any()):
        return None, None, None, f"{side}: the arm touches the image border"
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    areas = [cv2.contourArea(c) + 0.5 * len(c) for c in contours]
    main = int(np.argmax(areas))
    if areas[main] < config.min_main_fraction * count:
        return None, None, None, (f"{side}: broken contour ({len(contours)} pieces, the "
                                  f"largest {areas[main] / count:.0%} of the arm's pixels)")
    points = contours[main][:, 0, :].astype(float)
    if len(points) > config.max_contour_points:
        points = points[np.linspace(0, len(points) - 1, config.max_contour_points).astype(int)]
    start = points[np.argmin(((points - base_px) ** 2).sum(axis=1))]
    end = points[np.argmax(((points - start) ** 2).sum(axis=1))]
    initial = start + np.linspace(0.0, 1.0, config.n_points)[:, None] * (end - start)
    nodes = train_som(points, initial, config.som_radius, config.som_alpha0, config.som_epochs,
                      np.random.default_rng(config.seed))
    ends = np.array([nodes[0] + 0.5 * (nodes[0] - nodes[1]),
                     nodes[-1] + 0.5 * (nodes[-1] - nodes[-2])])
    return nodes, ends, contours[main], ""


def resample_polyline(points: np.ndarray, n_points: int = N_POINTS) -> np.ndarray:
    """``n_points`` points at equal arc-length steps along the polyline ``points`` (m, (n, 3)),
    the first and last at its ends."""
    points = as_finite_array("points", points)
    if points.ndim != 2 or points.shape[0] < 2:
        raise ValueError(f"points must have shape (n >= 2, dim), got {points.shape}")
    n_points = require_integer("n_points", n_points, 2)
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    targets = np.linspace(0.0, arc[-1], n_points)
    return np.stack([np.interp(targets, arc, points[:, i]) for i in range(points.shape[1])],
                    axis=1)


# ---------------------------------------------------------------------------------- the pair
def estimate_stereo_shape(left: np.ndarray, right: np.ndarray, P_left: np.ndarray,
                          P_right: np.ndarray, config: ASESConfig = ASESConfig(),
                          base_m: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0)
                          ) -> StereoShape:
    """ASES on one stereo pair (zou2022 Section 4): the backbone's ``P_0 .. P_6`` or ``lost``.

    Args:
        left, right: uint8 RGB frames (H, W, 3) of the parallel cameras.
        P_left, P_right: their 3 x 4 projection matrices (world to pixels), as the
            :class:`~soft_gym.sensors.stereo.StereoCamera` reading carries them.
        config: image processing and SOM settings.
        base_m: the arm's base in the world frame (m): orients the chains (base first) and
            checks the triangulated base end.

    Returns:
        A :class:`StereoShape`; ``points_m`` in the projection matrices' world frame.
    """
    images = {"left": _check_image("left", left), "right": _check_image("right", right)}
    matrices = {"left": _check_projection("P_left", P_left),
                "right": _check_projection("P_right", P_right)}
    if images["left"].shape != images["right"].shape:
        raise ValueError(f"right must have the left image's shape {images['left'].shape}, got "
                         f"{images['right'].shape}")
    if not isinstance(config, ASESConfig):
        raise ValueError(f"config must be an ASESConfig, got {config!r}")
    base = as_finite_array("base_m", base_m, (3,))
    lost = np.full((config.n_points, 3), np.nan)
    result = StereoShape(lost, True)
    for side in ("left", "right"):
        blurred, thresholded, mask = _segment(images[side], config)
        result.mask_px[side] = int(cv2.countNonZero(mask))
        nodes, ends, contour, reason = _centreline(mask, _project(matrices[side], base), config,
                                                   side)
        if nodes is None:
            result.reason = reason
            return result
        result.som_px[side], result.ends_px[side] = nodes, ends
        if math.isfinite(config.tip_occlusion_widths):
            silhouette = cv2.drawContours(np.zeros_like(mask), [contour], -1, 255, cv2.FILLED)
            chain = np.vstack([ends[0], nodes, ends[1]])
            occluded = tip_occlusion(blurred, thresholded, silhouette, chain, config)
            result.tip_occlusion[side] = occluded
            if occluded >= config.tip_occlusion_widths:
                result.reason = (f"{side}: the tip end is hidden by an occluder (an edge "
                                 f"{occluded:.2f} arm widths long that is neither arm nor "
                                 f"backdrop abuts it, limit {config.tip_occlusion_widths}): the "
                                 f"arm may go on behind it")
                return result
    chains = {side: np.vstack([result.ends_px[side][0], result.som_px[side],
                               result.ends_px[side][1]]) for side in ("left", "right")}
    rows = np.abs(chains["left"][:, 1] - chains["right"][:, 1])
    if rows.max() > config.epipolar_tolerance_px:
        result.reason = (f"matched points leave the epipolar line by {rows.max():.1f} px (more "
                         f"than {config.epipolar_tolerance_px} px)")
        return result
    homogeneous = cv2.triangulatePoints(matrices["left"], matrices["right"],
                                        chains["left"].T.copy(), chains["right"].T.copy())
    if np.any(np.abs(homogeneous[3]) < 1e-12):
        result.reason = "a matched point triangulates at infinity (no disparity)"
        return result
    triangulated = (homogeneous[:3] / homogeneous[3]).T       # base end, neurons, tip end
    offset = float(np.linalg.norm(triangulated[0] - base))
    if offset > config.base_tolerance_m:
        result.reason = (f"the backbone's base end triangulates {offset * 1e3:.1f} mm from the "
                         f"base (more than {config.base_tolerance_m * 1e3:.1f} mm)")
        return result
    result.points_m = resample_polyline(np.vstack([base, triangulated[1:]]), config.n_points)
    result.lost = False
    return result


__all__ = ["N_POINTS", "OCCLUSION_RING_PX", "ASESConfig", "StereoShape", "som_learning_rate",
           "som_neighbourhood", "train_som", "arm_mask", "tip_occlusion", "resample_polyline",
           "estimate_stereo_shape"]
