"""Eye-in-hand vision pose: ORB features against a keyframe map, RANSAC PnP and LM refinement.

A stand-in for the ORB-SLAM2 tracking of Wang et al. 2023 (wang2023, Section II-B, IV), see
DESIGN.md section 5:

* the first keyframe is built at calibration from the known camera pose and the depth buffer,
  which fixes the metric scale (the paper calibrates scale with the EM tracker);
* later keyframes are added from the *estimated* pose (and the depth buffer), so drift is real;
* every frame, ORB descriptors are matched to the map (Hamming, Lowe ratio test),
  ``cv2.solvePnPRansac`` finds the camera pose and ``cv2.solvePnPRefineLM`` refines it on the
  inliers;
* the quality measure ``e_S`` is the RMS reprojection error of the inliers (px), as the paper's
  fusion uses it (wang2023 eq. (18));
* with fewer than ``min_inliers`` inliers tracking is lost and the last valid pose is held, as
  the paper does.

Conventions: camera frame as OpenCV (x right, y down, z forward); poses are 4x4 homogeneous
``world_from_camera`` transforms; quaternions are (x, y, z, w).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from soft_gym._validation import as_finite_array, require_positive

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


@dataclass
class VisionPoseEstimator:
    """ORB + PnP tracker of the eye-in-hand camera pose, reported as the tip pose.

    Args:
        camera_matrix: OpenCV intrinsics K (3x3, px).
        tip_from_camera: pose of the camera in the tip frame (4x4), so that
            ``world_from_tip = world_from_camera @ inv(tip_from_camera)``.
        n_features: ORB features per frame.
        min_inliers: fewer PnP inliers than this means tracking is lost (DESIGN.md: ~30).
        ratio: Lowe ratio for descriptor matching.
        ransac_threshold_px: RANSAC reprojection threshold (px).
        ransac_iterations: RANSAC iterations (the last pose seeds the solver, so few are needed).
        keyframe_inlier_ratio: a new keyframe is added when the inliers fall below this fraction
            of the nearest keyframe's own feature count.
        max_keyframes: oldest keyframes beyond this are dropped (never the calibration one).
            Dropping them lets the map be rebuilt from drifted poses on every pass over the same
            views, so the default keeps a long run's map (a 3-cycle circle needs ~90).
        keyframe_spacing_m: no new keyframe closer than this to the nearest one (m): each
            keyframe built from an estimated pose adds its error to the map, so fewer is better
            (1 mm keeps the fused tracking error flat over repeated cycles; 2 mm starves the
            clean spiral of keyframes).
        match_keyframes: each frame is matched against this many keyframes nearest to the last
            pose (a local map, as ORB-SLAM2's covisible keyframes), which bounds the cost. With 3
            the update is 12.9 instead of 14.4 ms, but a loaded arm's fused feedback error rises
            from 0.9 to 1.6 mm.
        min_depth_m, max_depth_m: depth range of map points accepted from the depth buffer.
    """

    camera_matrix: np.ndarray
    tip_from_camera: np.ndarray
    n_features: int = 1000
    min_inliers: int = 30
    ratio: float = 0.8
    ransac_threshold_px: float = 2.0
    keyframe_inlier_ratio: float = 0.35
    max_keyframes: int = 200
    match_keyframes: int = 6
    ransac_iterations: int = 200
    keyframe_spacing_m: float = 0.001
    min_depth_m: float = 0.005
    max_depth_m: float = 1.0
    keyframes: list = field(default_factory=list, init=False, repr=False)
    last: VisionEstimate | None = field(default=None, init=False, repr=False)

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
        self._camera_from_tip = np.linalg.inv(self.tip_from_camera)
        self._orb = cv2.ORB_create(nfeatures=int(self.n_features), edgeThreshold=15,
                                   patchSize=15, fastThreshold=10)
        self._matcher = cv2.BFMatcher(cv2.NORM_HAMMING)

    def __deepcopy__(self, memo: dict) -> "VisionPoseEstimator":
        """A copy with its own map (OpenCV's ORB and matcher objects are rebuilt, not copied)."""
        import copy

        twin = VisionPoseEstimator(
            self.camera_matrix.copy(), self.tip_from_camera.copy(), self.n_features,
            self.min_inliers, self.ratio, self.ransac_threshold_px, self.keyframe_inlier_ratio,
            self.max_keyframes, self.match_keyframes, self.ransac_iterations,
            self.keyframe_spacing_m, self.min_depth_m, self.max_depth_m)
        twin.keyframes = copy.deepcopy(self.keyframes, memo)
        twin.last = copy.deepcopy(self.last, memo)
        return twin

    # ------------------------------------------------------------------ map
    def calibrate(self, image: np.ndarray, depth_m: np.ndarray,
                  world_from_camera: np.ndarray) -> int:
        """Start a new map from one frame with its known pose and depth; returns map points."""
        self.keyframes = []
        self.last = None
        count = self.add_keyframe(image, depth_m, world_from_camera)
        if count < self.min_inliers:
            raise ValueError(
                f"calibration image gave {count} map points, fewer than min_inliers="
                f"{self.min_inliers}: the camera sees too little texture")
        self.last = self._estimate(np.asarray(world_from_camera, dtype=float), 0.0, count, False)
        return count

    def add_keyframe(self, image: np.ndarray, depth_m: np.ndarray,
                     world_from_camera: np.ndarray) -> int:
        """Add a keyframe: ORB features back-projected with the depth buffer from the given pose."""
        keypoints, descriptors = self._detect(image)
        if descriptors is None or not keypoints:
            return 0
        pixels = np.array([kp.pt for kp in keypoints])
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
                                        int(valid.sum())))
        if len(self.keyframes) > self.max_keyframes:
            del self.keyframes[1]
        return int(valid.sum())

    def _local_map(self) -> tuple[np.ndarray, np.ndarray, _Keyframe]:
        """Descriptors and points of the keyframes nearest the last pose, and the nearest one."""
        centre = self.last.world_from_camera[:3, 3]
        distances = [np.linalg.norm(k.world_from_camera[:3, 3] - centre) for k in self.keyframes]
        nearest = [int(i) for i in np.argsort(distances)[: self.match_keyframes]]
        # the calibration keyframe (known pose, metric depth) always anchors the local map
        indices = [0] + [i for i in nearest if i != 0][: self.match_keyframes]
        chosen = [self.keyframes[i] for i in indices]
        return (np.vstack([k.descriptors for k in chosen]),
                np.vstack([k.points_world_m for k in chosen]), self.keyframes[nearest[0]])

    # ------------------------------------------------------------------ tracking
    def update(self, image: np.ndarray, depth_m: np.ndarray | None = None) -> VisionEstimate:
        """Track one frame. With ``depth_m`` a keyframe may be added from the estimated pose."""
        if self.last is None:
            raise ValueError("update() called before calibrate(): the map is empty")
        keypoints, descriptors = self._detect(image)
        if descriptors is None or len(keypoints) < self.min_inliers:
            return self._lost(0)
        map_descriptors, map_points, nearest = self._local_map()
        matches = self._matcher.knnMatch(descriptors, map_descriptors, k=2)
        image_points, object_points, used = [], [], set()
        for pair in matches:
            if len(pair) < 2:
                continue
            best, second = pair
            if best.distance < self.ratio * second.distance and best.trainIdx not in used:
                used.add(best.trainIdx)
                image_points.append(keypoints[best.queryIdx].pt)
                object_points.append(map_points[best.trainIdx])
        if len(image_points) < self.min_inliers:
            return self._lost(len(image_points))
        object_points = np.asarray(object_points, dtype=np.float64)
        image_points = np.asarray(image_points, dtype=np.float64)
        camera_from_world = np.linalg.inv(self.last.world_from_camera)
        rvec, _ = cv2.Rodrigues(camera_from_world[:3, :3])
        tvec = camera_from_world[:3, 3].reshape(3, 1)
        # OpenCV's RANSAC draws from a process-wide generator: seed it per frame so that a frame
        # gives the same pose whatever ran before it in the process
        cv2.setRNGSeed(len(image_points))
        ok, rvec, tvec, inliers = cv2.solvePnPRansac(
            object_points, image_points, self.camera_matrix, None, rvec.copy(), tvec.copy(),
            useExtrinsicGuess=True, iterationsCount=self.ransac_iterations,
            reprojectionError=self.ransac_threshold_px, confidence=0.999,
            flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok or inliers is None or len(inliers) < self.min_inliers:
            return self._lost(0 if inliers is None else len(inliers))
        inliers = inliers.ravel()
        rvec, tvec = cv2.solvePnPRefineLM(object_points[inliers], image_points[inliers],
                                          self.camera_matrix, None, rvec, tvec)
        projected, _ = cv2.projectPoints(object_points[inliers], rvec, tvec, self.camera_matrix,
                                         None)
        residual = projected.reshape(-1, 2) - image_points[inliers]
        error_px = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
        rotation, _ = cv2.Rodrigues(rvec)
        world_from_camera = np.eye(4)
        world_from_camera[:3, :3] = rotation.T
        world_from_camera[:3, 3] = -rotation.T @ tvec.ravel()
        estimate = self._estimate(world_from_camera, error_px, len(inliers), False)
        self.last = estimate
        moved = np.linalg.norm(world_from_camera[:3, 3] - nearest.world_from_camera[:3, 3])
        if (depth_m is not None and moved > self.keyframe_spacing_m
                and len(inliers) < self.keyframe_inlier_ratio * nearest.inliers_at_creation):
            self.add_keyframe(image, depth_m, world_from_camera)
        return estimate

    # ------------------------------------------------------------------ helpers
    def _detect(self, image: np.ndarray):
        gray = cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
        return self._orb.detectAndCompute(gray, None)

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
