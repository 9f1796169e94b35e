"""External stereo camera looking at the arm against a plain background (zou2022, Section 4).

Zou et al. 2022 estimate the arm's shape with a ZED stereo camera: "the single white is selected
as the experimental background", the arm is segmented by its colour in HSV, its centreline is
found with a SOM in each image, and the matched centre points are triangulated; "left and right
cameras of ZED are strictly parallel" with baseline ``T_x`` and focal length ``f`` (eqs. 13-15),
the result is moved into the arm's frame with a fixed transform (eq. 16).

Here two fixed pinhole cameras, parallel and ``baseline_m`` apart, look horizontally at the arm
from the side (along +y of the base frame, image "down" along +z, where the hanging arm goes) at
``distance_m``; a large plain backdrop stands behind the arm. Each reading renders both images
with TinyRenderer and returns their 3 x 4 projection matrices ``P = K [R | t]`` (OpenCV:
``R, t`` camera-from-world), so ``cv2.triangulatePoints(P_left, P_right, uv_left, uv_right)``
gives points in the arm's base frame directly (the role of eq. 16's ``T_{L-g}``).
The arm's colour is the builder's orange.

Visual faults (zou2022 Section 4.4, Fig. 13a "poor light"): the faults of
:mod:`soft_gym.sensors.faults` act on the pair as on the eye-in-hand camera. Geometric faults (an
occluding plate) are placed once per reading relative to the pair (the midpoint of the optical
centres, the pair's rotation, ``FrameContext.baseline_m`` the baseline) and both cameras render
them from their own poses; the plates are parked again after the pair is rendered, so no other
camera sees them. Image faults hit both images, each with its own context (its camera's pose
and depth, the same time: the same light for both) and per-image noise drawn from the sensor's
generator, left image first. The cameras are fixed, so :class:`~soft_gym.sensors.faults.
MotionBlur` (which models camera motion) leaves their images sharp. Self-occlusion (Fig. 13b) is
no fault here: it happens when the simulated arm bends towards the cameras.

What ASES (:func:`~soft_gym.papers.zou2022.stereo_shape.estimate_stereo_shape`) makes of them, measured
on 20 random settled poses of the zou2022 arm in the 320 x 180 pair (clean: never lost, 3.0 mm
mean point error): ``low_light`` at strength 0.5 / 0.7 is never lost (3.0 / 3.1 mm), at 0.75 always
(the dim tip drops out of the mask: a broken contour or a tip end that meets neither arm nor
backdrop), at 0.85 or 1 always (no arm pixels); ``led_glare`` at strength 1 is lost on 17 of 20
(9.0 mm on the other 3), at 0.5 on 13 of 20 (2.7 mm on the other 7; a tip washed out by the glare
is caught by the occlusion check); a neutral plate (``rgba`` grey) over the whole pair, or over
60 % of it from either side, from the top (the base hidden) or from the bottom (the tip half
hidden: the occlusion check of :mod:`~soft_gym.papers.zou2022.stereo_shape` finds the plate at the
visible arm's tip end, where the truncated arm gave 46 mm mean error before) is lost on every
frame. From the bottom, 45 % is lost on 18 of 20 frames (3.1 mm on the other 2) and 30 % on 4 of
20 (tips touching the plate's edge; 3.2 mm on the rest). The default skin-coloured plate lies
inside ASES's orange HSV range: where it is in view ASES takes it for the arm, which then touches
the image border (lost).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.sensors.base import Sensor
from soft_gym.sensors.faults import FrameContext, VisualFault, replace_faults
from soft_gym.sensors.intrinsics import CameraIntrinsics, as_intrinsics

OCCLUDER_FRACTION = 0.4
"""Where an occluder without its own ``distance_m`` stands: this fraction of the way from the
pair to the arm's axis (a hand or an object between the cameras and the arm)."""


class StereoCamera(Sensor):
    """Two calibrated cameras outside the arm (zou2022): images and projection matrices.

    A reading is a dict ``{"left": uint8 (H, W, 3), "right": uint8 (H, W, 3),
    "P_left": float64 (3, 4), "P_right": float64 (3, 4)}``, faults applied.

    Args:
        intrinsics: :class:`~soft_gym.sensors.intrinsics.CameraIntrinsics` or a dict of its fields;
            default 320 x 240, 70 deg horizontal field of view, near 5 cm, far 5 m (zou2022 uses a
            ZED at 1280 x 720; a smaller frame keeps the simulation fast).
        baseline_m: distance between the optical centres (m); 0.12 m is the ZED's.
        distance_m: distance from the arm axis to the cameras (m); ``None`` frames the arm's
            reach (its rest length times ``max_extension_ratio``) with a margin.
        target_m: the point midway between the two optical axes' aims (m, base frame); ``None``
            is halfway down the reach on the arm axis.
        backdrop: put a plain board ``backdrop_distance_m`` behind the arm axis. Without it the
            background is the renderer's empty white, which costs nothing to draw (TinyRenderer
            spends ~0.1 us per covered pixel: a full-frame board triples the render time).
        backdrop_distance_m: distance of the backdrop behind the arm axis (m).
        backdrop_rgba: colour of the backdrop (plain white, zou2022).
        light_direction: direction towards the light in the world frame; default from the
            cameras' side and above, so the arm facing them is lit ("the light is supplemented
            throughout the above experiment", Section 4.4).
        noise_std_dn: std of Gaussian pixel noise (DN); 0 gives exact renders. It is added
            after the faults (the read-out of each camera).
        faults: visual faults on both cameras, anything
            :func:`soft_gym.sensors.faults.make_faults` accepts (default none: clean frames); see
            :meth:`set_faults` and the module docstring. An occluder without ``distance_m``
            stands ``OCCLUDER_FRACTION`` (40 %) of the way from the pair to the arm's axis.
        rate_hz: frames per second; ``None`` renders at every read.

    Attributes:
        faults: the active list of :class:`~soft_gym.sensors.faults.VisualFault`.
        last_depth: metric depth (m, (H, W)) of the last reading per side, occluders included.
    """

    engine_features = frozenset({"rendering"})

    def __init__(self, intrinsics: CameraIntrinsics | dict | None = None,
                 baseline_m: float = 0.12, distance_m: float | None = None,
                 target_m: tuple[float, float, float] | None = None,
                 backdrop: bool = False, backdrop_distance_m: float = 0.6,
                 backdrop_rgba: tuple[float, float, float, float] = (0.95, 0.95, 0.95, 1.0),
                 light_direction: tuple[float, float, float] = (0.2, -1.0, -0.6),
                 noise_std_dn: float = 0.0, faults: Any = None,
                 rate_hz: float | None = None) -> None:
        super().__init__("stereo", rate_hz)
        self.intrinsics = as_intrinsics(intrinsics, CameraIntrinsics(
            width=320, height=240, hfov_deg=70.0, near_m=0.05, far_m=5.0))
        self.baseline_m = require_positive("baseline_m", baseline_m)
        self.distance_m = None if distance_m is None else require_positive("distance_m", distance_m)
        self.target_m = None if target_m is None else as_finite_array("target_m", target_m, (3,))
        if not isinstance(backdrop, (bool, np.bool_)):
            raise ValueError(f"backdrop must be True or False, got {backdrop!r}")
        self.backdrop = bool(backdrop)
        self.backdrop_distance_m = require_positive("backdrop_distance_m", backdrop_distance_m)
        rgba = np.asarray(backdrop_rgba, dtype=float)
        if rgba.shape != (4,) or np.any(~np.isfinite(rgba)) or np.any((rgba < 0) | (rgba > 1)):
            raise ValueError(f"backdrop_rgba must be 4 numbers in [0, 1], got {backdrop_rgba!r}")
        self.backdrop_rgba = tuple(rgba.tolist())
        light = as_finite_array("light_direction", light_direction, shape=(3,))
        if np.linalg.norm(light) == 0:
            raise ValueError("light_direction must be a non-zero vector, got (0, 0, 0)")
        self.light_direction = light / np.linalg.norm(light)
        if not np.isfinite(noise_std_dn) or noise_std_dn < 0:
            raise ValueError(f"noise_std_dn must be a finite number >= 0, got {noise_std_dn!r}")
        self.noise_std_dn = float(noise_std_dn)
        self._world: Any = None
        self._occluder_distance_m = 0.0
        self.backdrop_id = -1
        self.poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self.faults: list[VisualFault] = []
        self.last_depth: dict[str, np.ndarray] = {}
        self._previous: dict[str, tuple[np.ndarray, np.ndarray, float]] = {}
        self.set_faults(faults)

    # ------------------------------------------------------------------ geometry
    def _layout(self, sim) -> tuple[float, np.ndarray]:
        """Camera distance (m) and aim point (m) for ``sim``'s arm."""
        reach = sum(s.length_m * s.max_extension_ratio for s in sim.spec.segments)
        target = self.target_m if self.target_m is not None else np.array([0.0, 0.0, 0.5 * reach])
        if self.distance_m is not None:
            return self.distance_m, target
        # fit 1.3 x the reach in the vertical field of view and the reach either side
        half_v = np.tan(np.radians(0.5 * self.intrinsics.vfov_deg))
        half_h = np.tan(np.radians(0.5 * self.intrinsics.hfov_deg))
        return float(max(0.65 * reach / half_v, 1.1 * reach / half_h)), target

    def camera_poses(self, sim) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """World-from-camera ``(R, centre)`` of ``"left"`` and ``"right"`` (OpenCV axes)."""
        distance, target = self._layout(sim)
        # looking along +y, image down along +z (the hanging arm), x right = y x z = -x world
        rotation = np.column_stack([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
        centre = target - distance * rotation[:, 2]
        half = 0.5 * self.baseline_m * rotation[:, 0]
        return {"left": (rotation, centre - half), "right": (rotation, centre + half)}

    def projection_matrices(self, sim) -> dict[str, np.ndarray]:
        """``P = K [R^T | -R^T c]`` (3, 4) of each camera, world (base frame) to pixels."""
        K = self.intrinsics.K()
        matrices = {}
        for side, (rotation, centre) in self.camera_poses(sim).items():
            matrices[side] = K @ np.hstack([rotation.T, (-rotation.T @ centre)[:, None]])
        return matrices

    # ------------------------------------------------------------------ set-up
    def _attach(self, fault: VisualFault) -> None:
        fault.attach(self._world, self.intrinsics, baseline_m=self.baseline_m,
                     default_distance_m=self._occluder_distance_m)

    def set_faults(self, faults: Any) -> None:
        """Replace the faults (any ``make_faults`` description); their bodies move along."""
        self.faults = replace_faults(self.faults, faults, self._world, self._attach, self.rng)

    def _setup(self, sim) -> None:
        """Place the backdrop and the faults' bodies once per simulator client."""
        if self._world is sim.world:
            return
        self._world = sim.world
        distance, _ = self._layout(sim)
        self._occluder_distance_m = OCCLUDER_FRACTION * distance
        if self.backdrop:
            self._build_backdrop(sim)
        for fault in self.faults:
            if fault.geometric:
                self._attach(fault)

    def _build_backdrop(self, sim) -> None:
        distance, target = self._layout(sim)
        rotation, _ = self.camera_poses(sim)["left"]
        # a plain board behind the arm, perpendicular to the viewing direction, covering the view
        far_side = distance + self.backdrop_distance_m
        half_w = far_side * np.tan(np.radians(0.5 * self.intrinsics.hfov_deg)) + self.baseline_m
        half_h = far_side * np.tan(np.radians(0.5 * self.intrinsics.vfov_deg))
        if far_side >= self.intrinsics.far_m:
            raise ValueError(f"backdrop_distance_m must put the backdrop before far_m="
                             f"{self.intrinsics.far_m} (camera at {distance:.3f} m), got "
                             f"{self.backdrop_distance_m!r}")
        position = target + (self.backdrop_distance_m + 0.005) * rotation[:, 2]
        self.backdrop_id = sim.world.add_body(
            "box", half_extents_m=[1.2 * half_w, 0.005, 1.2 * half_h], collide=False,
            rgba=self.backdrop_rgba, position_m=position.tolist())

    def reset(self, sim, rng: np.random.Generator) -> None:
        """Start an episode: place the backdrop in ``sim``'s world once and draw the faults'
        episode parameters from ``rng``."""
        super().reset(sim, rng)
        self._setup(sim)
        for fault in self.faults:
            fault.reset(rng)
        self._previous = {}
        self.last_depth = {}

    # ------------------------------------------------------------------ reading
    def rig_context(self, sim) -> FrameContext:
        """The pair's frame context (the geometric faults' reference): the shared rotation, the
        midpoint of the optical centres, ``baseline_m`` the baseline."""
        poses = self.camera_poses(sim)
        rotation = poses["left"][0]
        centre = 0.5 * (poses["left"][1] + poses["right"][1])
        return FrameContext(time_s=sim.time_s, rotation=rotation, position=centre,
                            intrinsics=self.intrinsics, rng=self.rng, baseline_m=self.baseline_m)

    def _context(self, sim, side: str, rotation: np.ndarray, centre: np.ndarray,
                 depth: np.ndarray) -> FrameContext:
        previous = self._previous.get(side)
        return FrameContext(
            time_s=sim.time_s, rotation=rotation, position=centre, intrinsics=self.intrinsics,
            rng=self.rng, previous_rotation=None if previous is None else previous[0],
            previous_position=None if previous is None else previous[1],
            previous_time_s=None if previous is None else previous[2], depth=depth)

    def sample(self, sim) -> dict[str, np.ndarray]:
        """Render both cameras now, faults applied; returns the images and projection
        matrices."""
        self._setup(sim)
        reading: dict[str, np.ndarray] = {}
        self.poses = self.camera_poses(sim)
        geometric = [fault for fault in self.faults if fault.geometric]
        if geometric:
            rig = self.rig_context(sim)
            for fault in geometric:
                fault.place(sim.world, rig)
        image_faults = [fault for fault in self.faults
                        if not fault.geometric and fault.strength_at(sim.time_s) > 0.0]
        for side, (rotation, centre) in self.poses.items():
            rgb, depth = sim.world.render_camera(self.intrinsics, rotation, centre,
                                                 self.light_direction)
            if image_faults:
                context = self._context(sim, side, rotation, centre, depth)
                image = rgb.astype(np.float32)
                for fault in image_faults:
                    image = fault.apply(image, context)
                rgb = np.clip(np.rint(image), 0, 255).astype(np.uint8)
            self._previous[side] = (rotation, centre, sim.time_s)
            self.last_depth[side] = depth
            if self.noise_std_dn > 0:
                noisy = rgb + self.rng.normal(0.0, self.noise_std_dn, rgb.shape)
                rgb = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
            reading[side] = rgb
        for fault in geometric:  # an obstacle of this pair only: out of the other cameras' view
            fault.park(sim.world)
        matrices = self.projection_matrices(sim)
        reading["P_left"], reading["P_right"] = matrices["left"], matrices["right"]
        return reading

    def space(self, sim) -> spaces.Dict:
        shape = (self.intrinsics.height, self.intrinsics.width, 3)
        image = spaces.Box(0, 255, shape, np.uint8)
        matrix = spaces.Box(-np.inf, np.inf, (3, 4), np.float64)
        return spaces.Dict({"left": image, "right": image, "P_left": matrix, "P_right": matrix})


__all__ = ["StereoCamera"]
