"""The robot's own pose sensing (wang2023 Fig. 1): camera pose, F-emp from the FBG, and fusion.

Each control step:

1. the eye-in-hand camera renders a frame (with any visual faults) and the vision tracker
   (:mod:`soft_gym.papers.wang2023.vision_pose`) returns the camera-based tip pose, ``e_S`` and a lost flag;
2. the FBG fiber is read and F-emp (:mod:`soft_gym.papers.wang2023.femp`) predicts the tip pose from it;
3. F-emp is updated with the camera pose when ``e_S`` is small (selective update, never ground
   truth);
4. eq. (18) fuses the two (:mod:`soft_gym.papers.wang2023.fusion`).

Calibration builds the vision map at the rest pose (known pose, depth buffer) and initialises
F-emp from ``n_init`` steps of the predefined spiral exploration
(:mod:`soft_gym.papers.wang2023.exploration`) labelled by the camera. The pipeline never drives the arm:
:func:`soft_gym.papers.wang2023.calibration.calibrate_pipeline` runs the exploration on a
simulator and hands each step to :meth:`SensingPipeline.begin_calibration`,
:meth:`~SensingPipeline.calibration_sample` and :meth:`~SensingPipeline.finish_calibration`.
The pipeline is the robot's sensing: it persists across episodes unless recalibrated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soft_gym._quaternion import quaternion_to_matrix
from soft_gym.papers.wang2023.femp import FEmpEstimator
from soft_gym.papers.wang2023.fusion import PoseFusion
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.wang2023.vision_pose import VisionEstimate, VisionPoseEstimator
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.fbg import FBGFiber


@dataclass
class PoseEstimates:
    """One step's estimates: positions (m), quaternions (x, y, z, w), ``e_S`` (px)."""

    camera: tuple[np.ndarray, np.ndarray]
    femp: tuple[np.ndarray, np.ndarray]
    fused: tuple[np.ndarray, np.ndarray]
    reprojection_error_px: float
    inliers: int
    lost: bool
    femp_updated: bool


class SensingPipeline:
    """Camera + FBG + F-emp + fusion, as on the wang2023 robot.

    Args:
        camera: the eye-in-hand camera (its faults are the episode's visual faults).
        fbg: the FBG fiber.
        n_init: exploration steps that initialise F-emp (paper: ``N0 = 450``).
        femp: F-emp settings (keyword arguments of :class:`FEmpEstimator`).
        fusion: eq. (18) bounds (a :class:`PoseFusion`).
        vision: keyword arguments of :class:`VisionPoseEstimator`.
        exploration: keyword arguments of :func:`spiral_fractions` for the calibration sequence.
        map_steps: steps of the exploration spent on the vision map alone before the ``n_init``
            steps that label F-emp (wang2023 moves the arm "until the initialization for visual
            features was ready" before the ELM initialisation). The vision map grows from
            drifted estimated poses, so the camera's accuracy depends on how long it has
            explored; comparing F-emp initialised from different ``n_init`` on the same vision
            map needs the same ``map_steps + n_init``. Default 0: the map is built while F-emp's
            samples are collected.
        femp_prior: give the vision tracker F-emp's pose (from this step's FBG reading) as the
            prediction for its search by projection, instead of the constant-velocity model.
            Off by default: the camera estimate is then independent of F-emp, as the paper's
            SLAM is, and F-emp learns from labels it did not shape. On, F-emp follows the arm
            within ~1 mm whatever the actuation, so with a random action every step the tracker
            rarely falls back to matching the whole local map (faster under jerky actuation;
            ``bench/sensor_speed.py`` measures both).
    """

    OPTIONS = ("n_init", "femp", "fusion", "vision", "exploration", "map_steps", "femp_prior")
    """Keyword options of the pipeline (the env's ``sensing=`` dict)."""

    def __init__(self, camera: EyeInHandCamera, fbg: FBGFiber, n_init: int = 450,
                 femp: dict | None = None, fusion: PoseFusion | None = None,
                 vision: dict | None = None, exploration: dict | None = None,
                 map_steps: int = 0, femp_prior: bool = False) -> None:
        if not isinstance(n_init, int) or n_init < 10:
            raise ValueError(f"n_init must be an integer >= 10, got {n_init!r}")
        if isinstance(map_steps, bool) or not isinstance(map_steps, int) or map_steps < 0:
            raise ValueError(f"map_steps must be an integer >= 0, got {map_steps!r}")
        self.map_steps = map_steps
        if not isinstance(femp_prior, (bool, np.bool_)):
            raise ValueError(f"femp_prior must be True or False, got {femp_prior!r}")
        self.femp_prior = bool(femp_prior)
        self.camera = camera
        self.fbg = fbg
        self.n_init = n_init
        if isinstance(fusion, dict):
            fusion = PoseFusion(**fusion)
        self.fusion = fusion or PoseFusion()
        if not isinstance(self.fusion, PoseFusion):
            raise ValueError("fusion must be None, a PoseFusion or a dict of its bounds "
                             f"(lower_px, upper_px), got {self.fusion!r}")
        # F-emp learns from the frames the fusion trusts (one e_S scale for both rules)
        self.femp_options = {"update_threshold_px": self.fusion.trust_threshold_px,
                             **dict(femp or {})}
        self.vision_options = dict(vision or {})
        self.exploration = {"turn_s": 8.0, "breath_s": 45.0, "low": 0.05, "high": 0.6,
                            "common": 0.3, "common_s": 11.0,
                            **(exploration or {})}
        self.vision: VisionPoseEstimator | None = None
        self.femp: FEmpEstimator | None = None
        self.calibration_samples = 0

    @property
    def is_calibrated(self) -> bool:
        return self.femp is not None and self.femp.is_ready

    @property
    def calibration_steps(self) -> int:
        """Steps of the calibration's exploration: ``map_steps`` for the map, then ``n_init``."""
        return self.map_steps + self.n_init

    def begin_calibration(self, image: np.ndarray, depth_m: np.ndarray,
                          camera_pose: np.ndarray) -> None:
        """Start a calibration: the vision map from a clean frame at the rest pose (uint8 RGB,
        metric depth in m, and the world-from-camera transform (4, 4) it was taken from)."""
        tip_from_camera = np.eye(4)
        tip_from_camera[:3, 3] = self.camera.offset_m
        self.vision = VisionPoseEstimator(self.camera.K(), tip_from_camera, **self.vision_options)
        self.vision.calibrate(image, depth_m, camera_pose)

    def calibration_sample(self, step: int, measurement: Measurement
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Track one exploration step's frame; returns the FBG shifts with the camera's pose
        (position m, quaternion) that label them, or ``None`` for a map-only step or a frame
        the camera does not trust."""
        estimate = self.vision.update(measurement["image"], measurement.depth_m["image"])
        if step < self.map_steps:
            return None
        if estimate.lost or estimate.reprojection_error_px >= self.femp_options[
                "update_threshold_px"]:
            return None
        return (np.asarray(measurement["fbg"], dtype=float), estimate.position_m,
                estimate.quaternion)

    def finish_calibration(self, samples: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
                           ) -> int:
        """Initialise F-emp from the camera-labelled samples; returns how many there were.

        Raises:
            ValueError: fewer than 10 samples (the camera could not track the exploration).
        """
        if len(samples) < 10:
            raise ValueError(
                f"calibration gave {len(samples)} camera-labelled samples out of n_init="
                f"{self.n_init}: the camera could not track the exploration")
        shifts, positions, quaternions = (np.array(column) for column in zip(*samples))
        self.femp = FEmpEstimator(**self.femp_options)
        self.femp.initialize(shifts, positions, quaternions)
        self.calibration_samples = len(samples)
        return len(samples)

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: the vision tracker's RANSAC draws from a child of ``rng`` (the
        env's ``np_random``, seeded by ``reset(seed=...)``), spawned so that ``rng``'s own
        stream (the sensors' noise, the targets) does not move."""
        if self.vision is not None:
            self.vision.set_rng(rng.spawn(1)[0])

    def observe(self, measurement: Measurement) -> PoseEstimates:
        """Estimate from one step's camera frame and FBG reading: F-emp predicts, the vision
        tracker solves the camera pose, F-emp is updated selectively, eq. (18) fuses (wang2023)."""
        if not self.is_calibrated:
            raise ValueError("the sensing pipeline is not calibrated: call calibrate() first")
        reading = np.asarray(measurement["fbg"], dtype=float)
        femp_pose = self.femp.predict(reading)
        prior = None
        if self.femp_prior:
            prior = np.eye(4)
            prior[:3, :3] = quaternion_to_matrix(femp_pose[1])
            prior[:3, 3] = femp_pose[0]
        vision: VisionEstimate = self.vision.update(measurement["image"],
                                                    measurement.depth_m["image"], prior)
        updated = self.femp.update(reading, vision.position_m, vision.quaternion,
                                   vision.reprojection_error_px, vision.lost)
        fused = self.fusion.fuse(vision.position_m, vision.quaternion, *femp_pose,
                                 vision.reprojection_error_px, vision.lost)
        return PoseEstimates((vision.position_m, vision.quaternion), femp_pose, fused,
                             vision.reprojection_error_px, vision.inliers, vision.lost, updated)
