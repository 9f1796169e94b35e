"""Eye-in-hand vision pose: ORB features against a keyframe map, RANSAC PnP and a weighted
Gauss-Newton refinement.

A stand-in for the ORB-SLAM2 tracking of Wang et al. 2023 (wang2023, Section II-B, IV), see
docs/architecture.md, "Vision pose":

* the first keyframe is built at calibration from the known camera pose and the depth buffer,
  which fixes the metric scale (the paper calibrates scale with the EM tracker);
* later keyframes are added from the *estimated* pose (and the depth buffer), so drift is real;
  a keyframe is re-posed a few frames after its own, from a quadratic fit in time through the
  estimated poses of the frames around it (a short sliding window in place of ORB-SLAM2's local
  bundle adjustment), which averages out the frame's own pose noise before the map inherits it;
* every frame, ORB descriptors are matched to the local map: by projection from the predicted
  pose (constant velocity, or a prior from another sensor), comparing only map points projected
  near each feature (ORB-SLAM2's search by projection); where that finds too few (a jerky
  motion), by projection from the last pose turned by the image's own shift since the last
  frame (phase correlation, as PTAM's small-blurry-image rotation estimate), then in a window
  twice as wide (ORB-SLAM2's second try); against every map point only after a loss or when all
  of these fail (Hamming distance, Lowe ratio test);
  ``cv2.solvePnPRansac`` finds the inliers and a Gauss-Newton refinement weights each by its
  pyramid levels (ORB-SLAM2's pose optimisation);
* the quality measure ``e_S`` is the RMS reprojection error of the inliers (px), as the paper's
  fusion uses it (wang2023 eq. (18));
* with fewer than ``min_inliers`` inliers, or inliers that constrain the tip position poorly
  (``max_position_std_m``), tracking is lost and the last valid pose is held, as the paper does.

Conventions: camera frame as OpenCV (x right, y down, z forward); poses are 4x4 homogeneous
``world_from_camera`` transforms; quaternions are (x, y, z, w).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.papers.wang2023.descriptor_search import (UNSET, as_words, nearest_two,
                                                         nearest_two_in_window)

# frames over which the motion model's misses are counted (image_motion_min_misses)
MISS_WINDOW = 10
# the matching stages of VisionPoseEstimator.update, in order (VisionPoseEstimator.match_stages)
MATCH_STAGES = ("prediction", "image_motion", "wide_window", "whole_map")

# OpenCV's parallel loops may order ORB keypoints differently from run to run; one thread keeps
# a seeded episode identical across processes (and the benchmarks measure one core anyway)
cv2.setNumThreads(1)


@dataclass
class VisionEstimate:
    """One frame's result.

    Attributes:
        position_m: tip position in the world (base) frame (m); held while lost.
        quaternion: tip orientation (x, y, z, w); held while lost.
        reprojection_error_px: ``e_S``, RMS reprojection error of the PnP inliers (px); ``inf``
            when tracking is lost.
        inliers: PnP inlier count (0 when lost before PnP).
        lost: whether this frame failed to track.
        world_from_camera: estimated camera pose (4x4), held while lost.
    """

    position_m: np.ndarray
    quaternion: np.ndarray
    reprojection_error_px: float
    inliers: int
    lost: bool
    world_from_camera: np.ndarray


@dataclass
class _Keyframe:
    descriptors: np.ndarray      # (n, 32) uint8
    points_world_m: np.ndarray   # (n, 3)
    world_from_camera: np.ndarray
    inliers_at_creation: int = 0
    # drift proxy in keyframe hops: 0 for the calibration keyframe, 1 + the mean over the
    # inliers' keyframes for a new one (see update)
    uncertainty: float = 0.0
    octaves: np.ndarray | None = None  # (n,) ORB pyramid level of each point's keypoint


@dataclass
class VisionPoseEstimator:
    """ORB + PnP tracker of the eye-in-hand camera pose, reported as the tip pose.

    Args:
        camera_matrix: OpenCV intrinsics K (3x3, px).
        tip_from_camera: pose of the camera in the tip frame (4x4), so that
            ``world_from_tip = world_from_camera @ inv(tip_from_camera)``.
        n_features: ORB features per frame.
        min_inliers: fewer PnP inliers than this means tracking is lost (30: ORB-SLAM2's bound).
        ratio: Lowe ratio for descriptor matching.
        ransac_threshold_px: RANSAC reprojection threshold (px).
        ransac_iterations: RANSAC iterations (the last pose seeds the solver, so few are needed).
        keyframe_inlier_ratio: a new keyframe is added when the inliers fall below this fraction
            of the nearest keyframe's own feature count.
        max_keyframes: beyond this the keyframe furthest from the calibration one (in keyframe
            hops, each keyframe one more than the mean of its inliers' keyframes) is dropped,
            never the calibration one. Dropping keyframes lets the map be rebuilt from drifted
            poses on every pass over the same views: with 200, dropping the oldest, the 0.6
            spiral's map was rebuilt ~5 times in 200 s; the map settles at ~500 keyframes.
        keyframe_spacing_m: no new keyframe closer than this to the nearest one (m): each
            keyframe built from an estimated pose adds its error to the map, so fewer is better
            (1 mm keeps the fused tracking error flat over repeated cycles; 2 mm starves the
            clean spiral of keyframes).
        match_keyframes: each frame is matched against this many keyframes nearest to the last
            pose (a local map, as ORB-SLAM2's covisible keyframes), which bounds the cost. With 3
            the matching is cheaper, but a loaded arm's fused feedback error rose from 0.9 to
            1.6 mm.
        search_radius_px: guided matching (ORB-SLAM2's search by projection): the local map is
            projected from the predicted camera pose (see :meth:`update`), and each feature is
            compared only with map points within this radius (px). The slow spiral moves the
            image ~0.4 px per frame, and the update takes ~10 instead of ~20 ms. If the
            guided search finds fewer than ``2 min_inliers`` matches, the next stage searches
            (``image_motion_prediction``, ``wide_search_factor``), and the frame is matched
            against the whole local map (relocalisation) when none finds enough; the first
            search that finds enough decides the frame (PnP failing on its matches loses the
            frame: a crowded or occluded view, not a wrong prediction). ``None`` always
            matches against the whole local map: 2x slower, and in the 100 s estimation spiral
            after calibration the camera's mean error was 0.87-0.90 mm against 1.0-1.3 mm with
            6 px (the window favours map points consistent with the current drift); on the
            slow spiral alone the two are equal (0.91 mm RMSE).
        image_motion_prediction: where the search by projection from the predicted pose finds
            too few matches while such misses are the rule (``image_motion_min_misses``), search
            again from the last pose turned by the image's shift since the last tracked frame
            (``cv2.phaseCorrelate`` of the two grey images; a shift of (dx, dy) px is a turn of
            (atan(dy / f_y), -atan(dx / f_x)) about the camera's x and y axes), as PTAM (Klein
            and Murray 2008) estimates the rotation of a fast camera from a small blurred image
            before it tracks. Under a random pressure every control period (wang2023 preset)
            the constant-velocity prediction missed the map points' pixels by 15 px (median)
            and 81 % of the frames were matched against the whole local map; the turned pose
            misses by 2.1 px and 98 % of those frames track from it. While the motion model
            missed the last frame, the turned pose is searched first. ``False``: the matching
            before this stage existed (motion model, then the whole local map).
        image_motion_min_misses: the image-motion stage (with the wider window and the second
            search) is used only while the motion model missed (its prediction further than
            ``search_radius_px`` from the estimated pose, median over the inliers) at least
            this many of the last ``MISS_WINDOW = 10`` tracked frames; below that a miss is
            matched against the whole local map, whose ratio test against every map point is
            the more discriminating. An isolated burst of misses (a flick: at most 4 in 10 over
            the 200 s flick run) keeps the whole-map matching, which there tracked at 0.60 mm
            against 0.74-0.81 mm with the image motion; random pressures every period miss 6 or
            more of 10 on 92 % of frames. 0 uses the stage after any miss.
        wide_search_factor: then search once more, from the image-motion prediction, in a window
            this many times ``search_radius_px`` (ORB-SLAM2's TrackWithMotionModel retries with
            twice its window) before matching the whole local map; ``None`` skips it.
        refine_radius_factor: a pose found by the image-motion stage or the wider window is
            searched again by projection from itself in a window this many times
            ``search_radius_px`` and solved again (ORB-SLAM2 tracks the local map after its
            motion model): the turned pose has no translation or roll, so its window admits
            wrong matches. Under random pressures over the whole range (200 frames) the mean
            tip error was 1.03 mm with 0.5, 0.87 mm with 1.0 and 1.57 mm without the second
            search, against 1.48 mm matching the whole map (with 3, 3, 2 and 10 frames lost);
            at 0.5 the random-action env ran 25-29 steps/s against 32 without the second search
            and 20-21 matching the whole map (``bench/sensor_speed.py``). ``None`` skips it.
        max_descriptor_distance: a guided match must be within this Hamming distance (bits of
            256; ORB-SLAM2's TH_HIGH is 100).
        min_depth_m, max_depth_m: depth range of map points accepted from the depth buffer.
        keyframe_window: a new keyframe is added at once from the frame's estimated pose (a
            fast camera keeps its map: added this many frames late, the zou2022 arm's
            calibration lost track for good), and this many frames later it is re-posed, its
            points moving with it, to the pose fitted (quadratic in time, translation and
            rotation) through the estimated poses of the tracked frames up to this many frames
            either side; 0 keeps the frame's own pose. With true keyframe poses each frame's pose error is nearly white
            (0.37 mm RMSE, lag-1 autocorrelation 0.03), so the fit removes most of the error a
            keyframe would pass on: on the 0.6 spiral (seed 0, 200 keyframes, weighted
            refinement, a straight-line fit, keyframes added late) the camera's RMSE fell from
            1.86 to 0.70 mm. The quadratic keeps a fast path's curvature out of the keyframe
            (one spiral turn a second: 0.51 mm, against 1.40 mm with the straight line).
        max_fit_residual_m: if the fit misses the poses by more than this RMS (m), the motion
            was not smooth (a flick) and the keyframe keeps its own estimated pose.
        max_position_std_m: tracking is lost when the tip position's standard deviation (m),
            from the refinement's covariance, exceeds this. Clean frames: 0.2 mm (99.9th
            percentile 0.4 mm); behind a partial occluder 40-90 inliers crowded in a corner gave
            1-2.3 mm, with errors of 5-14 mm at an ordinary ``e_S``, which the fusion trusted.
        keyframe_position_std_m: no keyframe from a frame less well constrained than this (m).
    """

    camera_matrix: np.ndarray
    tip_from_camera: np.ndarray
    n_features: int = 1000
    min_inliers: int = 30
    ratio: float = 0.8
    ransac_threshold_px: float = 2.0
    keyframe_inlier_ratio: float = 0.35
    max_keyframes: int = 1000
    match_keyframes: int = 6
    ransac_iterations: int = 200
    keyframe_spacing_m: float = 0.001
    search_radius_px: float | None = 6.0
    image_motion_prediction: bool = True
    image_motion_min_misses: int = 6
    wide_search_factor: float | None = 2.0
    refine_radius_factor: float | None = 0.5
    max_descriptor_distance: int = 80
    min_depth_m: float = 0.005
    max_depth_m: float = 1.0
    keyframe_window: int = 5
    max_fit_residual_m: float = 0.001
    max_position_std_m: float = 0.001
    keyframe_position_std_m: float = 0.0005
    keyframes: list = field(default_factory=list, init=False, repr=False)
    last: VisionEstimate | None = field(default=None, init=False, repr=False)
    previous: VisionEstimate | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        self.camera_matrix = as_finite_array("camera_matrix", self.camera_matrix, shape=(3, 3))
        self.tip_from_camera = as_finite_array("tip_from_camera", self.tip_from_camera,
                                               shape=(4, 4))
        if not isinstance(self.min_inliers, (int, np.integer)) or self.min_inliers < 4:
            raise ValueError(f"min_inliers must be an integer >= 4, got {self.min_inliers!r}")
        if not isinstance(self.n_features, (int, np.integer)) or self.n_features < 10:
            raise ValueError(f"n_features must be an integer >= 10, got {self.n_features!r}")
        if not 0 < self.ratio <= 1:
            raise ValueError(f"ratio must be in (0, 1], got {self.ratio!r}")
        require_positive("ransac_threshold_px", self.ransac_threshold_px)
        require_positive("max_depth_m", self.max_depth_m)
        if (isinstance(self.keyframe_window, bool)
                or not isinstance(self.keyframe_window, (int, np.integer))
                or self.keyframe_window < 0):
            raise ValueError(
                f"keyframe_window must be an integer >= 0, got {self.keyframe_window!r}")
        require_positive("max_fit_residual_m", self.max_fit_residual_m)
        require_positive("max_position_std_m", self.max_position_std_m)
        require_positive("keyframe_position_std_m", self.keyframe_position_std_m)
        if self.search_radius_px is not None:
            require_positive("search_radius_px", self.search_radius_px)
        if not isinstance(self.image_motion_prediction, (bool, np.bool_)):
            raise ValueError("image_motion_prediction must be True or False, got "
                             f"{self.image_motion_prediction!r}")
        if (isinstance(self.image_motion_min_misses, bool)
                or not isinstance(self.image_motion_min_misses, (int, np.integer))
                or not 0 <= self.image_motion_min_misses <= MISS_WINDOW):
            raise ValueError(f"image_motion_min_misses must be an integer in [0, {MISS_WINDOW}], "
                             f"got {self.image_motion_min_misses!r}")
        for name in ("wide_search_factor", "refine_radius_factor"):
            value = getattr(self, name)
            low, bound = (1, "> 1") if name == "wide_search_factor" else (0, "> 0")
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, (int, float, np.integer, np.floating)) or not np.isfinite(value)
                    or value <= low):
                raise ValueError(f"{name} must be a finite number {bound} or None, got "
                                 f"{value!r}")
        if (not isinstance(self.max_descriptor_distance, (int, np.integer))
                or not 0 < self.max_descriptor_distance <= 256):
            raise ValueError("max_descriptor_distance must be an integer in (0, 256], got "
                             f"{self.max_descriptor_distance!r}")
        self._camera_from_tip = np.linalg.inv(self.tip_from_camera)
        self._orb = cv2.ORB_create(nfeatures=int(self.n_features), edgeThreshold=15,
                                   patchSize=15, fastThreshold=10)
        self._scale_factor = float(self._orb.getScaleFactor())
        self._history: list = []   # (frame, world_from_camera) of the last tracked frames
        # (frame, keyframe, its own estimated pose) of keyframes waiting for the frames after them
        self._pending: list = []
        self._frame = 0
        # grey image (float32) of the last tracked frame, for the image-motion prediction
        self._last_gray: np.ndarray | None = None
        # whether the motion model missed each of the last tracked frames (see update)
        self._misses: list[bool] = []
        # frames each matching stage decided, tracked or lost (see update)
        self.match_stages: dict[str, int] = dict.fromkeys(MATCH_STAGES, 0)
        # (the keyframes' arrays, their uncertainties, their stacks) of the last local map
        # (see _local_map)
        self._local_map_cache: tuple | None = None
        # the episode's generator RANSAC's samples are drawn from (see set_rng)
        self._rng: np.random.Generator | None = None

    def set_rng(self, rng: np.random.Generator | None) -> None:
        """Draw RANSAC's samples from ``rng``: the episode's generator
        (:meth:`SensingPipeline.reset <soft_gym.papers.wang2023.pipeline.SensingPipeline.reset>`
        gives a child of the env's ``np_random``, seeded by ``reset(seed=...)``), so each seed
        gives its own RANSAC draws (see :meth:`_solve`). ``None`` (the default: calibration, an
        estimator used on its own): the samples OpenCV's fixed generator picks from the matches
        in their own order, the same in every run."""
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be None or a numpy Generator, got {rng!r}")
        self._rng = rng

    def __deepcopy__(self, memo: dict) -> "VisionPoseEstimator":
        """A copy with its own map (OpenCV's ORB is rebuilt, not copied)."""
        settings = {f.name: copy.deepcopy(getattr(self, f.name), memo)
                    for f in dataclasses.fields(self) if f.init}
        twin = VisionPoseEstimator(**settings)
        twin.keyframes = copy.deepcopy(self.keyframes, memo)
        twin.last = copy.deepcopy(self.last, memo)
        twin.previous = copy.deepcopy(self.previous, memo)
        twin._history = copy.deepcopy(self._history, memo)
        twin._pending = copy.deepcopy(self._pending, memo)
        twin._frame = self._frame
        twin._last_gray = copy.deepcopy(self._last_gray, memo)
        twin._misses = list(self._misses)
        twin.match_stages = dict(self.match_stages)
        twin._rng = copy.deepcopy(self._rng, memo)
        return twin

    def __getstate__(self) -> dict:
        """Pickled state: the settings and the map (OpenCV's ORB is rebuilt on load)."""
        return {name: value for name, value in self.__dict__.items()
                if name not in ("_orb", "_local_map_cache")}

    def __setstate__(self, state: dict) -> None:
        settings = {f.name: state[f.name] for f in dataclasses.fields(self) if f.init}
        self.__init__(**settings)
        self.__dict__.update(state)

    # ------------------------------------------------------------------ map
    def calibrate(self, image: np.ndarray, depth_m: np.ndarray,
                  world_from_camera: np.ndarray) -> int:
        """Start a new map from one frame with its known pose and depth; returns map points."""
        self.keyframes = []
        self.last = self.previous = None
        self._history, self._pending, self._frame = [], [], 0
        self._last_gray, self._misses = None, []
        self.match_stages = dict.fromkeys(MATCH_STAGES, 0)
        count = self.add_keyframe(image, depth_m, world_from_camera)
        if count < self.min_inliers:
            raise ValueError(
                f"calibration image gave {count} map points, fewer than min_inliers="
                f"{self.min_inliers}: the camera sees too little texture")
        self.last = self._estimate(np.asarray(world_from_camera, dtype=float), 0.0, count, False)
        return count

    def add_keyframe(self, image: np.ndarray, depth_m: np.ndarray,
                     world_from_camera: np.ndarray,
                     features: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> int:
        """Add a keyframe: ORB features back-projected with the depth buffer from the given pose.

        ``features`` (pixels (n, 2), descriptors (n, 32), pyramid levels (n,)) already detected
        in ``image`` are reused instead of detecting again."""
        if features is None:
            keypoints, descriptors = self._detect(image)
            if descriptors is None or not keypoints:
                return 0
            pixels = cv2.KeyPoint_convert(keypoints).astype(np.float64)
            octaves = np.array([k.octave for k in keypoints], dtype=np.int64)
        else:
            pixels, descriptors, octaves = features
        columns = np.clip(np.round(pixels[:, 0]).astype(int), 0, depth_m.shape[1] - 1)
        rows = np.clip(np.round(pixels[:, 1]).astype(int), 0, depth_m.shape[0] - 1)
        depth = depth_m[rows, columns]
        valid = (depth > self.min_depth_m) & (depth < self.max_depth_m)
        if not np.any(valid):
            return 0
        fx, fy = self.camera_matrix[0, 0], self.camera_matrix[1, 1]
        cx, cy = self.camera_matrix[0, 2], self.camera_matrix[1, 2]
        z = depth[valid]
        points_camera = np.stack([(pixels[valid, 0] - cx) / fx * z,
                                  (pixels[valid, 1] - cy) / fy * z, z], axis=1)
        pose = np.asarray(world_from_camera, dtype=float)
        points_world = points_camera @ pose[:3, :3].T + pose[:3, 3]
        self.keyframes.append(_Keyframe(descriptors[valid], points_world, pose.copy(),
                                        int(valid.sum()), octaves=octaves[valid]))
        if len(self.keyframes) > self.max_keyframes:
            # drop the keyframe furthest from the calibration one (never that one, nor the new)
            worst = 1 + int(np.argmax([k.uncertainty for k in self.keyframes[1:-1]]))
            del self.keyframes[worst]
        return int(valid.sum())

    def _local_map(self, world_from_camera: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, _Keyframe, np.ndarray]:
        """Descriptors, points and pyramid levels of the keyframes nearest a camera pose (the
        calibration keyframe always among them), and the nearest one."""
        centre = world_from_camera[:3, 3]
        positions = np.array([k.world_from_camera[:3, 3] for k in self.keyframes])
        distances = np.sqrt(np.sum((positions - centre) ** 2, axis=1))
        order = np.argsort(distances, kind="stable")
        nearest = [int(i) for i in order[: self.match_keyframes]]
        # the calibration keyframe (known pose, metric depth) always anchors the local map
        indices = [0] + [i for i in nearest if i != 0][: self.match_keyframes]
        chosen = [self.keyframes[i] for i in indices]
        # the stacked arrays are reused while the same keyframes, with the same arrays and
        # uncertainties, make up the local map (most frames: keyframes are added and re-posed
        # rarely)
        arrays = [array for k in chosen for array in (k.descriptors, k.points_world_m, k.octaves)]
        uncertainties = [k.uncertainty for k in chosen]
        cached = self._local_map_cache
        if (cached is None or cached[1] != uncertainties or len(cached[0]) != len(arrays)
                or any(old is not new for old, new in zip(cached[0], arrays))):
            stacked = (np.vstack([k.descriptors for k in chosen]),
                       np.vstack([k.points_world_m for k in chosen]),
                       np.concatenate([k.octaves for k in chosen]),
                       np.concatenate([np.full(len(k.points_world_m), k.uncertainty)
                                       for k in chosen]))
            cached = self._local_map_cache = (arrays, uncertainties, stacked)
        descriptors, points, octaves, self._local_uncertainty = cached[2]
        return descriptors, points, self.keyframes[int(order[0])], octaves

    # ------------------------------------------------------------------ tracking
    def update(self, image: np.ndarray, depth_m: np.ndarray | None = None,
               prior_world_from_tip: np.ndarray | None = None) -> VisionEstimate:
        """Track one frame. With ``depth_m`` a keyframe may be added from the estimated pose.

        ``prior_world_from_tip`` (4x4), a tip pose from another sensor (the pipeline passes
        F-emp's), replaces the constant-velocity prediction of the search by projection, as an
        IMU does for visual-inertial ORB-SLAM: the pose itself still comes from the image alone.
        """
        if self.last is None:
            raise ValueError("update() called before calibrate(): the map is empty")
        if prior_world_from_tip is not None:
            prior_world_from_tip = as_finite_array("prior_world_from_tip", prior_world_from_tip,
                                                   shape=(4, 4))
        gray = self._gray(image)
        keypoints, descriptors = self._orb.detectAndCompute(gray, None)
        self._frame += 1
        if descriptors is None or len(keypoints) < self.min_inliers:
            self.previous = None
            self._last_gray = None
            self._flush_pending()
            return self._lost(0)
        predicted = self._predicted_world_from_camera(prior_world_from_tip)
        # the local map and the PnP start from the prior when there is one, else the last pose
        guess = (predicted if prior_world_from_tip is not None
                 else self.last.world_from_camera)
        map_descriptors, map_points, nearest, map_octaves = self._local_map(guess)
        pixels = cv2.KeyPoint_convert(keypoints).astype(np.float64)
        octaves = np.array([k.octave for k in keypoints], dtype=np.int64)
        frame = (pixels, descriptors, octaves, image.shape[1], image.shape[0])
        local_map = (map_descriptors, map_points, map_octaves)
        found = None
        gray_float = gray.astype(np.float32) if self.image_motion_prediction else None
        # without a prediction (at the start, or after a loss without a prior): match all.
        # The first search that finds 2 min_inliers matches decides the frame, tracked or lost.
        if self.search_radius_px is not None and predicted is not None:
            radius = float(self.search_radius_px)
            turned: list[np.ndarray] = []   # the image-motion prediction, made when needed

            def poses(stage: str) -> tuple[np.ndarray, np.ndarray]:
                """(pose the map is projected from, pose PnP starts from) of a stage."""
                if stage == "prediction":
                    return predicted, guess
                if not turned:
                    turned.append(self._turned_by_image_motion(gray_float))
                return turned[0], turned[0]

            stages = ["prediction"]
            guided = (gray_float is not None and self._last_gray is not None
                      and self._last_gray.shape == gray_float.shape
                      and sum(self._misses) >= self.image_motion_min_misses)
            if guided:
                # while the motion is jerky (the motion model missed the last frame by more than
                # the window), the image's prediction first: the motion model's would miss again
                stages.insert(0 if self._misses[-1] else 1, "image_motion")
            for stage in stages:
                found = self._search_by_projection(frame, local_map, *poses(stage), radius)
                if found is not None:
                    break
            if found is None and guided and self.wide_search_factor is not None:
                centre, start = poses("image_motion")
                stage = "wide_window"
                found = self._search_by_projection(frame, local_map, centre, start,
                                                   radius * float(self.wide_search_factor))
        if (found is not None and stage != "prediction" and not found[0].lost
                and self.refine_radius_factor is not None):
            # the turned pose has no translation or roll, so its window admits wrong matches:
            # search the local map again from the pose they gave (ORB-SLAM2's tracking of the
            # local map after its motion model) and keep that pose if it tracks
            solved = found[0].world_from_camera
            again = self._search_by_projection(frame, local_map, solved, solved,
                                               radius * float(self.refine_radius_factor))
            if again is not None and not again[0].lost:
                found = again
        if found is None:
            stage = "whole_map"
            query, train = self._match_all(descriptors, map_descriptors)
            estimate = self._solve(map_points[train], pixels[query], guess,
                                   self._sigma2(octaves[query], map_octaves[train]))
        else:
            estimate, query, train = found
        self.match_stages[stage] += 1
        if estimate.lost:
            self.previous = None
            self._last_gray = None
            self._flush_pending()
            return estimate
        self._last_gray = gray_float
        if gray_float is not None and predicted is not None and self.search_radius_px is not None:
            # the motion model missed (counted only where the image-motion stage may use it)
            # when the inliers' map points, projected from its prediction, lie further than
            # the window from where this frame's pose puts them
            inlier_points = map_points[train[self._inliers]]
            miss_px = np.median(np.linalg.norm(
                self._project(inlier_points, predicted)
                - self._project(inlier_points, estimate.world_from_camera), axis=1))
            self._misses.append(bool(miss_px > self.search_radius_px))
            del self._misses[:-MISS_WINDOW]
        # after a loss, the held pose says nothing of the motion: predict none for the next frame
        self.previous = self.last if self.previous is not None else estimate
        self.last = estimate
        world_from_camera = estimate.world_from_camera
        self._history.append((self._frame, world_from_camera))
        del self._history[:-(2 * self.keyframe_window + 1)]
        self._flush_pending(self._frame - self.keyframe_window)
        moved = np.linalg.norm(world_from_camera[:3, 3] - nearest.world_from_camera[:3, 3])
        if (depth_m is not None and moved > self.keyframe_spacing_m
                and estimate.inliers < self.keyframe_inlier_ratio * nearest.inliers_at_creation
                and self._position_std <= self.keyframe_position_std_m):
            if self.add_keyframe(image, depth_m, world_from_camera,
                                 (pixels, descriptors, octaves)):
                keyframe = self.keyframes[-1]
                keyframe.uncertainty = float(
                    np.mean(self._local_uncertainty[train[self._inliers]])) + 1.0
                if self.keyframe_window > 0:
                    self._pending.append((self._frame, keyframe, world_from_camera))
        return estimate

    def _flush_pending(self, up_to_frame: float = np.inf) -> None:
        """Re-pose the keyframes added up to ``up_to_frame``: the pose fitted through the tracked
        frames around each (see ``keyframe_window``) replaces its own, and its points move
        with it (rigidly: their depths came from the depth buffer)."""
        while self._pending and self._pending[0][0] <= up_to_frame:
            frame, keyframe, raw = self._pending.pop(0)
            window = [(k - frame, T) for k, T in self._history
                      if abs(k - frame) <= self.keyframe_window]
            if len(window) < 3 or not any(t > 0 for t, _ in window):
                continue
            t = np.array([t for t, _ in window], dtype=float)
            # a quadratic through the window's middle has no bias from the path's curvature
            powers = 3 if len(t) >= 5 else 2
            design = np.stack([t**p for p in range(powers)], axis=1)
            translations = np.array([T[:3, 3] for _, T in window])
            rotvecs = Rotation.from_matrix(
                np.array([raw[:3, :3].T @ T[:3, :3] for _, T in window])).as_rotvec()
            coefficients, *_ = np.linalg.lstsq(design, np.hstack([translations, rotvecs]),
                                               rcond=None)
            residual = translations - design @ coefficients[:, :3]
            if np.sqrt(np.mean(np.sum(residual**2, axis=1))) > self.max_fit_residual_m:
                continue
            pose = np.eye(4)
            pose[:3, 3] = coefficients[0, :3]
            pose[:3, :3] = raw[:3, :3] @ Rotation.from_rotvec(coefficients[0, 3:]).as_matrix()
            change = pose @ np.linalg.inv(raw)
            keyframe.points_world_m = (keyframe.points_world_m @ change[:3, :3].T
                                       + change[:3, 3])
            keyframe.world_from_camera = pose

    def _match_all(self, descriptors: np.ndarray,
                   map_descriptors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Brute-force matching with Lowe's ratio test; each map point used once (query order)."""
        empty = np.empty(0, dtype=np.int64)
        if len(map_descriptors) < 2:
            return empty, empty
        best, best_train, second = nearest_two(as_words(descriptors), as_words(map_descriptors))
        query = np.flatnonzero(best < self.ratio * second)
        # the first feature (in feature order) to take a map point keeps it
        _, first = np.unique(best_train[query], return_index=True)
        query = query[np.sort(first)]
        return query, best_train[query]

    def _search_by_projection(self, frame: tuple, local_map: tuple,
                              centre_world_from_camera: np.ndarray,
                              start_world_from_camera: np.ndarray, radius_px: float
                              ) -> tuple[VisionEstimate, np.ndarray, np.ndarray] | None:
        """Search by projection from ``centre_world_from_camera`` within ``radius_px``, then PnP
        started at ``start_world_from_camera``: (estimate, feature indices, map indices), or
        ``None`` when fewer than ``2 min_inliers`` matches were found."""
        pixels, descriptors, octaves, width, height = frame
        map_descriptors, map_points, map_octaves = local_map
        query, train = self._match_by_projection(pixels, descriptors, map_descriptors, map_points,
                                                 np.linalg.inv(centre_world_from_camera),
                                                 width, height, radius_px)
        if len(query) < 2 * self.min_inliers:
            return None
        estimate = self._solve(map_points[train], pixels[query], start_world_from_camera,
                               self._sigma2(octaves[query], map_octaves[train]))
        return estimate, query, train

    def _project(self, points_world: np.ndarray, world_from_camera: np.ndarray) -> np.ndarray:
        """Pixels (n, 2) of world points (n, 3, m) seen from a camera pose (pinhole, no
        distortion)."""
        camera_from_world = np.linalg.inv(world_from_camera)
        points = points_world @ camera_from_world[:3, :3].T + camera_from_world[:3, 3]
        return (points[:, :2] / points[:, 2:3] * np.diag(self.camera_matrix)[:2]
                + self.camera_matrix[:2, 2])

    def _turned_by_image_motion(self, gray: np.ndarray) -> np.ndarray:
        """The last tracked camera pose turned by the image's shift since that frame (the
        ``image_motion_prediction`` stage): ``cv2.phaseCorrelate`` of the two grey images
        (float32, under a Hann window) gives the shift (dx, dy) px of this frame against that
        one, which a camera turn of atan(dy / f_y) about its x axis and -atan(dx / f_x) about
        its y axis makes (the pinhole model at the optical axis; the translation, small against
        the scene's depth, and the roll are left to the search's window)."""
        window = cv2.createHanningWindow((gray.shape[1], gray.shape[0]), cv2.CV_32F)
        (dx, dy), _ = cv2.phaseCorrelate(self._last_gray, gray, window)
        turn = Rotation.from_rotvec([np.arctan(dy / self.camera_matrix[1, 1]),
                                     -np.arctan(dx / self.camera_matrix[0, 0]), 0.0])
        pose = self.last.world_from_camera.copy()
        pose[:3, :3] = pose[:3, :3] @ turn.as_matrix()
        return pose

    def _predicted_world_from_camera(self, prior_world_from_tip: np.ndarray | None
                                     ) -> np.ndarray | None:
        """The camera pose expected now: from the prior tip pose if given, else ORB-SLAM2's
        constant-velocity model; ``None`` when neither is available (start, or after a loss)."""
        if prior_world_from_tip is not None:
            return prior_world_from_tip @ self.tip_from_camera
        if self.previous is None:
            return None
        last = self.last.world_from_camera
        return last @ np.linalg.inv(self.previous.world_from_camera) @ last

    def _match_by_projection(self, pixels: np.ndarray, descriptors: np.ndarray,
                             map_descriptors: np.ndarray, map_points: np.ndarray,
                             camera_from_world: np.ndarray, width: int,
                             height: int, radius_px: float | None = None
                             ) -> tuple[np.ndarray, np.ndarray]:
        """Match features to map points projected near them (search by projection).

        Each feature takes its nearest descriptor among the map points projected within
        ``radius_px`` (default ``search_radius_px``), if within ``max_descriptor_distance`` and
        below ``ratio`` times the second nearest; each map point keeps its closest feature.
        Returns (feature, map) indices.
        """
        empty = np.empty(0, dtype=np.int64)
        points_camera = map_points @ camera_from_world[:3, :3].T + camera_from_world[:3, 3]
        depth = points_camera[:, 2]
        front = np.flatnonzero(depth > self.min_depth_m)
        projected = (points_camera[front, :2] / depth[front, None]
                     * np.diag(self.camera_matrix)[:2] + self.camera_matrix[:2, 2])
        radius = float(self.search_radius_px if radius_px is None else radius_px)
        inside = ((projected[:, 0] > -radius) & (projected[:, 0] < width + radius)
                  & (projected[:, 1] > -radius) & (projected[:, 1] < height + radius))
        candidates = front[inside]
        if len(candidates) == 0:
            return empty, empty
        best, best_train, second = nearest_two_in_window(
            pixels, as_words(descriptors), np.ascontiguousarray(projected[inside]), candidates,
            as_words(map_descriptors), radius)
        accepted = ((best <= self.max_descriptor_distance)
                    & (best < self.ratio * np.where(second < UNSET, second, np.inf)))
        query = np.flatnonzero(accepted)
        train, best = best_train[query], best[query]
        if len(query) == 0:
            return empty, empty
        order = np.argsort((train * 257 + best) * len(pixels) + query)
        query, train = query[order], train[order]
        unique = np.r_[True, train[1:] != train[:-1]]
        return query[unique], train[unique]

    def _sigma2(self, octaves: np.ndarray, map_octaves: np.ndarray) -> np.ndarray:
        """Variance (px^2) of a match's reprojection: ORB-SLAM2's sigma = scale factor^level
        for the frame's keypoint, plus the same for the keypoint the map point came from."""
        scale2 = self._scale_factor ** 2
        return scale2 ** octaves + scale2 ** map_octaves

    def _solve(self, object_points: np.ndarray, image_points: np.ndarray,
               guess_world_from_camera: np.ndarray,
               sigma2: np.ndarray) -> VisionEstimate:
        """RANSAC PnP from the guessed pose, Gauss-Newton refinement on the inliers weighted by
        ``1 / sigma2`` (px^-2), and e_S; lost if too few inliers or if they constrain the tip
        position poorly (``max_position_std_m``)."""
        if len(image_points) < self.min_inliers:
            return self._lost(len(image_points))
        object_points = np.asarray(object_points, dtype=np.float64)
        image_points = np.asarray(image_points, dtype=np.float64)
        camera_from_world = np.linalg.inv(guess_world_from_camera)
        rvec, _ = cv2.Rodrigues(camera_from_world[:3, :3])
        tvec = camera_from_world[:3, 3].reshape(3, 1)
        # cv2.solvePnPRansac draws its minimal samples from a generator of its own with a fixed
        # seed (cv2.setRNGSeed does not reach it: any seed gives the same pose), so its samples
        # are a function of the order of the matches. The episode's draw is that order: a
        # permutation from the episode's generator (set_rng: a child of the env's np_random,
        # seeded by reset(seed=...)); without one (calibration, an estimator used on its own)
        # the matches go in their own order, the same in every run.
        order = None if self._rng is None else self._rng.permutation(len(image_points))
        ok, rvec, tvec, inliers = cv2.solvePnPRansac(
            object_points if order is None else object_points[order],
            image_points if order is None else image_points[order],
            self.camera_matrix, None, rvec.copy(), tvec.copy(),
            useExtrinsicGuess=True, iterationsCount=self.ransac_iterations,
            reprojectionError=self.ransac_threshold_px, confidence=0.999,
            flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok or inliers is None or len(inliers) < self.min_inliers:
            return self._lost(0 if inliers is None else len(inliers))
        inliers = inliers.ravel() if order is None else np.sort(order[inliers.ravel()])
        self._inliers = inliers
        weights = 1.0 / sigma2[inliers]
        rvec, tvec = self._refine_weighted(object_points[inliers], image_points[inliers],
                                           weights, rvec, tvec)
        rotation_cw, _ = cv2.Rodrigues(rvec)
        self._position_std = self._tip_position_std(object_points[inliers],
                                                    image_points[inliers], weights, rotation_cw,
                                                    np.asarray(tvec, dtype=float).ravel())
        if self._position_std > self.max_position_std_m:
            return self._lost(len(inliers))
        projected, _ = cv2.projectPoints(object_points[inliers], rvec, tvec, self.camera_matrix,
                                         None)
        residual = projected.reshape(-1, 2) - image_points[inliers]
        error_px = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
        rotation, _ = cv2.Rodrigues(rvec)
        world_from_camera = np.eye(4)
        world_from_camera[:3, :3] = rotation.T
        world_from_camera[:3, 3] = -rotation.T @ tvec.ravel()
        return self._estimate(world_from_camera, error_px, len(inliers), False)

    def _residuals(self, object_points: np.ndarray, image_points: np.ndarray,
                   rotation: np.ndarray, translation: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Reprojection residuals (2n, px: all u, then all v) of a camera_from_world pose and
        their Jacobian (2n, 6) for the update ``R <- exp(w) R``, ``t <- exp(w) t + dt`` with
        parameters ``(w, dt)``."""
        fx, fy = self.camera_matrix[0, 0], self.camera_matrix[1, 1]
        cx, cy = self.camera_matrix[0, 2], self.camera_matrix[1, 2]
        p = object_points @ rotation.T + translation
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        inv_z = 1.0 / z
        residual = np.concatenate([fx * x * inv_z + cx - image_points[:, 0],
                                   fy * y * inv_z + cy - image_points[:, 1]])
        # d(u)/d(p) = (fx/z, 0, -fx x/z^2) and d(v)/d(p) = (0, fy/z, -fy y/z^2) (pinhole);
        # d(p)/d(w) = -[p]x, d(p)/d(dt) = I: rows (p x d(u)/d(p), d(u)/d(p)), then the same
        # for v, written in place (the arithmetic of np.cross and np.stack, term for term)
        n = len(p)
        jacobian = np.zeros((2 * n, 6))
        du, dv = jacobian[:n, 3:], jacobian[n:, 3:]
        du[:, 0] = fx * inv_z
        du[:, 2] = -fx * x * inv_z**2
        dv[:, 1] = fy * inv_z
        dv[:, 2] = -fy * y * inv_z**2
        for rows, d in ((jacobian[:n], du), (jacobian[n:], dv)):
            rows[:, 0] = y * d[:, 2] - z * d[:, 1]
            rows[:, 1] = z * d[:, 0] - x * d[:, 2]
            rows[:, 2] = x * d[:, 1] - y * d[:, 0]
        return residual, jacobian

    def _refine_weighted(self, object_points: np.ndarray, image_points: np.ndarray,
                         weights: np.ndarray, rvec: np.ndarray, tvec: np.ndarray,
                         iterations: int = 10) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Newton on the reprojection errors weighted by ``weights`` (1/px^2), as
        ORB-SLAM2's pose optimisation weights each observation by its pyramid level."""
        rotation, _ = cv2.Rodrigues(rvec)
        translation = np.asarray(tvec, dtype=float).ravel().copy()
        w = np.concatenate([weights, weights])
        for _ in range(iterations):
            residual, jacobian = self._residuals(object_points, image_points, rotation,
                                                 translation)
            hessian = jacobian.T @ (jacobian * w[:, None])
            step = np.linalg.solve(hessian + 1e-12 * np.eye(6), -jacobian.T @ (residual * w))
            turn = Rotation.from_rotvec(step[:3]).as_matrix()
            rotation = turn @ rotation
            translation = turn @ translation + step[3:]
            if np.max(np.abs(step)) < 1e-9:
                break
        rvec, _ = cv2.Rodrigues(rotation)
        return rvec, translation.reshape(3, 1)

    def _tip_position_std(self, object_points: np.ndarray, image_points: np.ndarray,
                          weights: np.ndarray, rotation: np.ndarray,
                          translation: np.ndarray) -> float:
        """Standard deviation (m, root of the covariance's trace) of the tip position implied by
        the inliers' weighted reprojection scatter: large when the inliers sit in a small patch
        of the image (e.g. the rest hidden by an occluder), where a tilt and a sideways shift
        of the camera look alike."""
        residual, jacobian = self._residuals(object_points, image_points, rotation, translation)
        w = np.concatenate([weights, weights])
        dof = max(len(residual) - 6, 1)
        scale2 = float(np.sum(w * residual**2)) / dof
        try:
            covariance = scale2 * np.linalg.inv(jacobian.T @ (jacobian * w[:, None]))
        except np.linalg.LinAlgError:
            return float("inf")
        # tip = c + R^T o with the camera centre c = -R^T t and o the tip in the camera frame:
        # d(tip)/d(w) = R^T [o]x, d(tip)/d(dt) = -R^T
        offset = self._camera_from_tip[:3, 3]
        skew = np.array([[0.0, -offset[2], offset[1]], [offset[2], 0.0, -offset[0]],
                         [-offset[1], offset[0], 0.0]])
        d_tip = np.hstack([rotation.T @ skew, -rotation.T])
        return float(np.sqrt(max(np.trace(d_tip @ covariance @ d_tip.T), 0.0)))

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _gray(image: np.ndarray) -> np.ndarray:
        if image.ndim == 3:
            return cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY)
        return image

    def _detect(self, image: np.ndarray):
        return self._orb.detectAndCompute(self._gray(image), None)

    def _estimate(self, world_from_camera: np.ndarray, error_px: float, inliers: int,
                  lost: bool) -> VisionEstimate:
        world_from_tip = world_from_camera @ self._camera_from_tip
        quaternion = Rotation.from_matrix(world_from_tip[:3, :3]).as_quat()
        return VisionEstimate(world_from_tip[:3, 3].copy(), quaternion, error_px, inliers, lost,
                              world_from_camera)

    def _lost(self, inliers: int) -> VisionEstimate:
        held = self.last
        return VisionEstimate(held.position_m.copy(), held.quaternion.copy(), float("inf"),
                              int(inliers), True, held.world_from_camera.copy())
