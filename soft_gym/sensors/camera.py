"""Eye-in-hand camera at the tip (wang2023, Sections II-B and IV-A, Figs. 5-7).

Wang et al. 2023 fix an endoscopic camera (depth of field 8-150 mm) and an LED on the tip cap and
run monocular ORB-SLAM2 on its frames at 20 Hz (one per 0.05 s control step) while the arm moves
over a LEGO-constructed scene. Here the frame is rendered by PyBullet's TinyRenderer (CPU, works
in DIRECT mode) from the tip pose composed with a fixed camera offset, looking along the tip's
+z axis, at the feature-rich scene of :func:`soft_gym.engines.pybullet.scene.build_scene`; the visual
faults of :mod:`soft_gym.sensors.faults` (occluder, low light, LED glare, motion blur, noise)
are applied to every frame.

Conventions (OpenCV): camera axes x right, y down, z forward; the pose is world-from-camera
``(R, t)`` (a camera point ``p_c`` is at ``R p_c + t`` in the world = arm base frame). The camera
axes are the tip's axes (x_cam = x_tip, y_cam = y_tip, z_cam = z_tip), the centre is
``offset_m`` from the tip in the tip frame. The pinhole model is
:class:`soft_gym.sensors.intrinsics.CameraIntrinsics`, whose ``K`` matches TinyRenderer's
sampling exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from soft_gym._quaternion import quaternion_to_matrix
from soft_gym._validation import as_finite_array
from soft_gym.sensors.base import Sensor
from soft_gym.sensors.faults import FrameContext, VisualFault, replace_faults
from soft_gym.sensors.intrinsics import CameraIntrinsics, as_intrinsics


class EyeInHandCamera(Sensor):
    """The tip camera of wang2023: a uint8 RGB frame (H, W, 3) per reading, faults applied.

    Args:
        intrinsics: a :class:`CameraIntrinsics`, or a dict of its fields (default 160 x 120,
            95 deg horizontal field of view, near 4 mm, far 2 m).
        offset_m: camera centre in the tip frame (m); default 3 mm along the tip's +z (the cap).
        faults: visual faults, anything :func:`soft_gym.sensors.faults.make_faults` accepts
            (default none: clean frames). See :meth:`set_faults`.
        rate_hz: frames per second; ``None`` renders at every read (wang2023 runs ORB-SLAM2 at
            the 20 Hz control rate).
        scene: build the feature-rich scene (the world's ``build_scene``,
            :func:`soft_gym.engines.pybullet.scene.build_scene`) at the first reset; ``False``
            leaves the world as it is.
        scene_seed: seed of the scene layout. The scene is the robot's surroundings: it is built
            once per simulator and does not change with the episode's seed.
        scene_options: extra keyword arguments for ``build_scene``.
        light_direction: direction towards the scene light in the world frame (the lamp of
            wang2023 Fig. 7 ①); the default lights the ground from the base side.

    Attributes:
        last_pose: world-from-camera ``(R, t)`` of the last frame (OpenCV axes).
        last_depth: metric depth (m) of the last frame, occluder included (for calibration).
        faults: the active list of :class:`~soft_gym.sensors.faults.VisualFault`.
    """

    engine_features = frozenset({"rendering"})

    def __init__(self, intrinsics: CameraIntrinsics | dict | None = None,
                 offset_m: tuple[float, float, float] = (0.0, 0.0, 0.003), faults: Any = None,
                 rate_hz: float | None = None, scene: bool = True, scene_seed: int = 0,
                 scene_options: dict | None = None,
                 light_direction: tuple[float, float, float] = (0.3, -0.2, -1.0)) -> None:
        super().__init__("image", rate_hz)
        self.intrinsics = as_intrinsics(intrinsics, CameraIntrinsics())
        self.offset_m = as_finite_array("offset_m", offset_m, shape=(3,))
        light = as_finite_array("light_direction", light_direction, shape=(3,))
        if np.linalg.norm(light) == 0:
            raise ValueError("light_direction must be a non-zero vector, got (0, 0, 0)")
        self.light_direction = light / np.linalg.norm(light)
        if not isinstance(scene, (bool, np.bool_)):
            raise ValueError(f"scene must be True or False, got {scene!r}")
        self.scene = bool(scene)
        if isinstance(scene_seed, bool) or not isinstance(scene_seed, (int, np.integer)):
            raise ValueError(f"scene_seed must be an integer, got {scene_seed!r}")
        self.scene_seed = int(scene_seed)
        if scene_options is not None and not isinstance(scene_options, dict):
            raise ValueError(f"scene_options must be None or a dict, got {scene_options!r}")
        self.scene_options = dict(scene_options or {})
        self.faults: list[VisualFault] = []
        self._world: Any = None
        self.scene_body_ids: list[int] = []
        self.set_faults(faults)
        self.last_pose: tuple[np.ndarray, np.ndarray] | None = None
        self.last_depth: np.ndarray | None = None
        self._previous: tuple[np.ndarray, np.ndarray, float] | None = None

    # ------------------------------------------------------------------ set-up
    def set_faults(self, faults: Any) -> None:
        """Replace the faults (any ``make_faults`` description); their bodies move along."""
        self.faults = replace_faults(self.faults, faults, self._world,
                                     lambda fault: fault.attach(self._world, self.intrinsics),
                                     self.rng)

    def _setup(self, sim) -> None:
        """Build the scene and the faults' bodies once per simulator world."""
        if self._world is sim.world:
            return
        self._world = sim.world
        if self.scene:
            options = {"seed": self.scene_seed, **self.scene_options}
            self.scene_body_ids = sim.world.build_scene(sim.spec.length_m, **options)
        for fault in self.faults:
            if fault.geometric:
                fault.attach(sim.world, self.intrinsics)

    def reset(self, sim, rng: np.random.Generator) -> None:
        """Start an episode: build the scene if needed and draw the faults' episode parameters."""
        super().reset(sim, rng)
        self._setup(sim)
        for fault in self.faults:
            fault.reset(rng)
        self._previous = None
        self.last_pose = None
        self.last_depth = None

    # ------------------------------------------------------------------ geometry
    def camera_pose(self, sim) -> tuple[np.ndarray, np.ndarray]:
        """World-from-camera rotation (3, 3) and camera centre (m) now, OpenCV axes."""
        tip, quaternion = sim.tip_pose()
        rotation = quaternion_to_matrix(quaternion)
        return rotation, tip + rotation @ self.offset_m

    def pose_matrix(self, sim) -> np.ndarray:
        """World-from-camera homogeneous transform (4, 4) now."""
        rotation, position = self.camera_pose(sim)
        matrix = np.eye(4)
        matrix[:3, :3], matrix[:3, 3] = rotation, position
        return matrix

    def K(self) -> np.ndarray:
        """OpenCV camera matrix (3, 3) of this camera (see :meth:`CameraIntrinsics.K`)."""
        return self.intrinsics.K()

    # ------------------------------------------------------------------ rendering
    def render_clean(self, sim) -> tuple[np.ndarray, np.ndarray]:
        """A fault-free RGB frame (uint8) and its metric depth (m) from the current pose.

        The occluder bodies are parked out of view first (they return at the next frame).
        """
        self._setup(sim)
        for fault in self.faults:
            fault.park(sim.world)
        rotation, position = self.camera_pose(sim)
        return sim.world.render_camera(self.intrinsics, rotation, position, self.light_direction)

    def _context(self, sim, rotation: np.ndarray, position: np.ndarray) -> FrameContext:
        previous = self._previous
        return FrameContext(
            time_s=sim.time_s, rotation=rotation, position=position,
            intrinsics=self.intrinsics, rng=self.rng,
            previous_rotation=None if previous is None else previous[0],
            previous_position=None if previous is None else previous[1],
            previous_time_s=None if previous is None else previous[2])

    def sample(self, sim) -> np.ndarray:
        """Render a frame at the current tip pose and apply the faults active at ``sim.time_s``."""
        self._setup(sim)
        rotation, position = self.camera_pose(sim)
        context = self._context(sim, rotation, position)
        for fault in self.faults:
            if fault.geometric:
                fault.place(sim.world, context)
        rgb, depth = sim.world.render_camera(self.intrinsics, rotation, position,
                                             self.light_direction)
        context.depth = depth
        image_faults = [fault for fault in self.faults
                        if not fault.geometric and fault.strength_at(context.time_s) > 0.0]
        if image_faults:
            image = rgb.astype(np.float32)
            for fault in image_faults:
                image = fault.apply(image, context)
            rgb = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        self._previous = (rotation, position, context.time_s)
        self.last_pose = (rotation, position)
        self.last_depth = depth
        return rgb

    def space(self, sim) -> spaces.Box:
        """``Box(0, 255, (H, W, 3), uint8)``."""
        return spaces.Box(0, 255, (self.intrinsics.height, self.intrinsics.width, 3), np.uint8)


__all__ = ["EyeInHandCamera"]
