"""Third-person frames of a soft-arm env: the PyBullet scene framed on the preset's workspace,
with the task and the loads drawn over it.

The arm, its base mount, the swaying ball and the obstacle rod come from PyBullet's
``getCameraImage`` (read only: it never steps or changes the physics). Everything else is a 2-D
overlay drawn with OpenCV at the pixels where the same view and projection matrices put the 3-D
points (:meth:`Camera.project`):

* behind the arm: a floor with a grid for scale (spacing in the bottom-left corner) under the
  lowest point the arm reaches (level with an upright arm's base), and the base plate, at the
  top of the frame for a hanging arm and the bottom for an upright one (image up is always
  against gravity);
* over the arm: the tracking path (:data:`PATH`), the next (:data:`NEXT_TARGET`, ring) and current
  (:data:`TARGET`, dot) targets, the loads (a tip mass as a block, a filling container with its
  fill level, the swaying mass's line, pushes and flicks as arrows while they act), the
  ground-truth tip (:data:`TIP`, ring) and the feedback estimate (:data:`ESTIMATE`, cross), and the
  time and tip error in the top-left corner.

:func:`render_frame` puts sensor panels beside that scene view (``panels=("scene", "camera")``):
the eye-in-hand frame as the sensing pipeline saw it (faults included) with the camera, F-emp and
fused estimates, their errors and ``e_S`` written on it, and the stereo pair with the SOM
centreline that the zou2022 shape estimator found in each image.

Colours are RGB tuples of ``uint8``. Nothing here runs unless a frame is asked for.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any, Sequence

import cv2
import numpy as np

from soft_gym.scenarios.loads import FillingLoad, Flick, Push, SwayingMass, _TipMassBase

BACKGROUND = (236, 240, 245)
FLOOR = (212, 219, 204)
GRID = (160, 170, 156)
PLATE = (92, 96, 104)
PATH = (50, 100, 215)
TARGET = (225, 25, 35)
NEXT_TARGET = (250, 150, 30)
TIP = (15, 150, 55)
ESTIMATE = (185, 0, 185)
PUSH = (235, 110, 0)
FLICK = (130, 50, 215)
MASS = (55, 55, 60)
FLUID = (60, 140, 230)
TEXT = (30, 30, 35)

FOV_Y_DEG = 30.0
"""Vertical field of view of the scene camera (deg)."""


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """OpenGL view matrix (4 x 4) of a camera at ``eye`` looking at ``target`` (m)."""
    forward = np.asarray(target, float) - np.asarray(eye, float)
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, up)
    side /= np.linalg.norm(side)
    true_up = np.cross(side, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = side, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ np.asarray(eye, float)
    return view


def perspective(fov_y_deg: float, aspect: float, near_m: float, far_m: float) -> np.ndarray:
    """OpenGL projection matrix (4 x 4): vertical field of view (deg), width / height, clip
    distances (m)."""
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2.0)
    return np.array([[f / aspect, 0.0, 0.0, 0.0],
                     [0.0, f, 0.0, 0.0],
                     [0.0, 0.0, (far_m + near_m) / (near_m - far_m),
                      2.0 * far_m * near_m / (near_m - far_m)],
                     [0.0, 0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: frame size (px) and OpenGL view and projection matrices (4 x 4)."""

    width: int
    height: int
    view: np.ndarray
    projection: np.ndarray

    def project(self, points_m: np.ndarray) -> np.ndarray:
        """Pixel coordinates (x right, y down; integer values at pixel centres) of points (m),
        shape (..., 3) -> (..., 2), as PyBullet's renderer places them."""
        points = np.asarray(points_m, dtype=float)
        homogeneous = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
        clip = homogeneous @ (self.projection @ self.view).T
        ndc = clip[..., :2] / clip[..., 3:4]
        x = (ndc[..., 0] + 1.0) * 0.5 * self.width - 0.5
        y = (1.0 - ndc[..., 1]) * 0.5 * self.height - 0.5
        return np.stack([x, y], axis=-1)

    def bullet_matrices(self) -> tuple[list[float], list[float]]:
        """View and projection matrices as PyBullet takes them (column-major lists of 16)."""
        return (self.view.flatten(order="F").tolist(),
                self.projection.flatten(order="F").tolist())


def up_direction(gravity_m_s2: np.ndarray) -> np.ndarray:
    """Unit vector against gravity (``+z`` without gravity)."""
    gravity = np.asarray(gravity_m_s2, dtype=float)
    norm = np.linalg.norm(gravity)
    return np.array([0.0, 0.0, 1.0]) if norm < 1e-12 else -gravity / norm


def horizontal_basis(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane normal to ``up`` (the first near the base x axis)."""
    reference = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    first = reference - (reference @ up) * up
    first /= np.linalg.norm(first)
    return first, np.cross(up, first)


def frame_points(points_m: np.ndarray, up: np.ndarray, width: int, height: int,
                 azimuth_deg: float = -55.0, elevation_deg: float = 18.0,
                 margin: float = 0.06, fov_y_deg: float = FOV_Y_DEG) -> Camera:
    """A camera whose frame just holds ``points_m`` (m, shape (n, 3)), with ``margin`` of the
    frame's half size to spare on the tighter side.

    The camera looks at the points from ``azimuth_deg`` about ``up`` (from the first axis of
    :func:`horizontal_basis`) and ``elevation_deg`` above the horizontal plane; ``up`` is image
    up.
    """
    points = np.asarray(points_m, dtype=float).reshape(-1, 3)
    first, second = horizontal_basis(up)
    azimuth, elevation = math.radians(azimuth_deg), math.radians(elevation_deg)
    toward_eye = (math.cos(elevation) * (math.cos(azimuth) * first + math.sin(azimuth) * second)
                  + math.sin(elevation) * up)
    side = np.cross(-toward_eye, up)
    side /= np.linalg.norm(side)
    image_up = np.cross(side, -toward_eye)
    tan_y = math.tan(math.radians(fov_y_deg) / 2.0) * (1.0 - margin)
    tan_x = tan_y * width / height
    center = 0.5 * (points.min(axis=0) + points.max(axis=0))
    distance = 0.0
    for _ in range(3):  # fit the distance, then centre the projected extent, and again
        relative = points - center
        x, y, z = relative @ side, relative @ image_up, relative @ toward_eye
        distance = float(max(np.max(z + np.abs(x) / tan_x), np.max(z + np.abs(y) / tan_y)))
        depth = distance - z
        sx, sy = x / depth, y / depth
        center = center + (0.5 * (sx.max() + sx.min()) * side
                           + 0.5 * (sy.max() + sy.min()) * image_up) * float(np.mean(depth))
    relative = points - center
    x, y, z = relative @ side, relative @ image_up, relative @ toward_eye
    distance = float(max(np.max(z + np.abs(x) / tan_x), np.max(z + np.abs(y) / tan_y)))
    extent = float(np.ptp(points, axis=0).max()) + 1e-3
    eye = center + distance * toward_eye
    return Camera(width, height, look_at(eye, center, up),
                  perspective(fov_y_deg, width / height, 0.02 * distance, distance + 4.0 * extent))


def grid_spacing_m(extent_m: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten, m) near a fifth of ``extent_m``."""
    raw = max(extent_m, 1e-6) / 5.0
    power = 10.0 ** math.floor(math.log10(raw))
    return min((step * power for step in (1.0, 2.0, 5.0, 10.0)), key=lambda s: abs(s - raw))


def _pixel(point: np.ndarray) -> tuple[int, int]:
    return int(round(float(point[0]))), int(round(float(point[1])))


MAX_RENDER_PX = 4096
"""Largest frame side (px) a renderer draws."""


def check_render_size(size: Any, name: str = "render_size") -> tuple[int, int]:
    """``size`` as ``(width, height)``: two integers (not bools or floats) in
    ``[1, MAX_RENDER_PX]`` pixels, else a ``ValueError`` naming ``name``."""
    if (not isinstance(size, (tuple, list)) or len(size) != 2
            or not all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
                       and 1 <= v <= MAX_RENDER_PX for v in size)):
        raise ValueError(f"{name} must be (width, height) in pixels, each an integer in "
                         f"[1, {MAX_RENDER_PX}], got {size!r}")
    return int(size[0]), int(size[1])


class SceneRenderer:
    """Frames of one arm's scene at ``size`` = (width, height) px.

    Args:
        spec: the arm (:class:`~soft_gym.robots.spec.ArmSpec`): mount, gravity, radius.
        size: frame (width, height) in pixels.
        workspace_m: points the frame must hold (m, base frame, shape (n, 3)), e.g. the reachable
            tips and the task's paths; the base is always added.
        overlays: draw the task, loads and markers (``False``: the scene, floor and grid only).
    """

    def __init__(self, spec, size: tuple[int, int], workspace_m: np.ndarray,
                 overlays: bool = True) -> None:
        self.width, self.height = check_render_size(size, "size")
        self.overlays = overlays
        self.up = up_direction(spec.gravity_base)
        radius = max(segment.outer_radius_m for segment in spec.segments)
        workspace = np.vstack([np.zeros((1, 3)), np.asarray(workspace_m, float).reshape(-1, 3)])
        first, second = horizontal_basis(self.up)
        heights = workspace @ self.up
        lateral = float(np.max(np.abs(workspace @ np.stack([first, second], axis=1)))) + radius
        self.extent_m = max(float(np.ptp(heights)), 2.0 * lateral)
        # the base plate: the far face of the base mount (soft_gym.engines.pybullet.builder), a
        # disc normal to the arm's rest axis (base z) behind the base
        first_segment = spec.segments[0]
        mount_m = 0.004 + (first_segment.max_extension_ratio - 1.0) * first_segment.link_length_m
        angles = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
        self.plate_m = np.stack([3.0 * radius * np.cos(angles), 3.0 * radius * np.sin(angles),
                                 np.full_like(angles, -mount_m)], axis=1)
        # the floor: level with an upright arm's plate, a little under a lower point reached
        plate_height = float(np.min(self.plate_m @ self.up))
        lowest = float(np.min(heights))
        floor_height = (plate_height if lowest >= plate_height
                        else lowest - 0.08 * self.extent_m)
        self.floor_height_m = floor_height
        self.spacing_m = grid_spacing_m(self.extent_m)
        framed = np.vstack([workspace, self.plate_m])
        self.camera = frame_points(framed, self.up, self.width, self.height)
        # floor square: as far as the camera allows (it must stay in front of it)
        eye = np.linalg.inv(self.camera.view)[:3, 3]
        eye_lateral = eye - (eye @ self.up) * self.up
        half = 0.9 * float(np.linalg.norm(eye_lateral))
        n = max(1, int(half / self.spacing_m))
        half = n * self.spacing_m
        ticks = np.arange(-n, n + 1) * self.spacing_m
        base = floor_height * self.up
        self.floor_corners_m = np.array([base + sx * half * first + sy * half * second
                                         for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
        lines = []
        for t in ticks:
            lines.append((base + t * first - half * second, base + t * first + half * second))
            lines.append((base + t * second - half * first, base + t * second + half * first))
        self.grid_m = np.array(lines)
        self._light = (self.up + 0.4 * first + 0.3 * second).tolist()
        self._background = self._static_background()

    def _static_background(self) -> np.ndarray:
        """Background colour, floor, grid and base plate (never move for one arm)."""
        image = np.empty((self.height, self.width, 3), np.uint8)
        image[:] = BACKGROUND
        camera = self.camera
        corners = np.round(camera.project(self.floor_corners_m) * 16).astype(np.int32)
        cv2.fillConvexPoly(image, corners, FLOOR, cv2.LINE_AA, shift=4)
        grid = np.round(camera.project(self.grid_m) * 16).astype(np.int32)
        for start, end in grid:
            cv2.line(image, tuple(start), tuple(end), GRID, 1, cv2.LINE_AA, shift=4)
        plate = np.round(camera.project(self.plate_m) * 16).astype(np.int32)
        cv2.fillConvexPoly(image, plate, PLATE, cv2.LINE_AA, shift=4)
        return image

    def scene(self, sim) -> tuple[np.ndarray, np.ndarray]:
        """PyBullet's colour image (H, W, 3) of ``sim`` and the mask of pixels (H, W) showing the
        arm or a load's body (every other body, e.g. the eye-in-hand camera's scenery, is left
        out of the image).

        The frame keeps only the arm's and the loads' pixels, so the eye-in-hand camera's
        textured scenery, the stereo backdrop and the faults' bodies would be drawn for nothing:
        hidden (made transparent for this one frame, their colours then put back exactly), a
        wang2023 frame with the camera's scenery costs ~3 ms instead of ~18 ms.
        """
        view, projection = self.camera.bullet_matrices()
        bodies = [sim.world.arm_body] + [body for body in (getattr(load, "_body", -1)
                                                           for load in sim.loads) if body >= 0]
        hidden = sim.world.hide_all_but(bodies)
        try:
            rgb, _, segmentation = sim.world.render(self.width, self.height, view, projection,
                                                    self._light, segmentation=True)
        finally:
            sim.world.unhide(hidden)
        return rgb, np.isin(segmentation, bodies)

    def render(self, sim, target_m: np.ndarray | None = None,
               next_target_m: np.ndarray | None = None, path_m: np.ndarray | None = None,
               estimate_m: np.ndarray | None = None) -> np.ndarray:
        """One frame (H, W, 3) ``uint8`` of ``sim`` (a :class:`~soft_gym.simulator.Simulator`) with
        the current and next target, the path polyline and the feedback estimate (m, base
        frame; ``None`` leaves one out)."""
        image = self._background.copy()
        rgb, mask = self.scene(sim)
        image[mask] = rgb[mask]
        if not self.overlays:
            return image
        camera = self.camera
        tip = sim.tip_pose()[0]
        size = max(3, int(round(min(self.width, self.height) / 60)))
        if path_m is not None and len(path_m) > 1:
            points = np.round(camera.project(np.asarray(path_m)) * 16).astype(np.int32)
            cv2.polylines(image, [points], False, PATH, 1, cv2.LINE_AA, shift=4)
        self._draw_loads(image, sim, tip, size)
        if next_target_m is not None and target_m is not None \
                and not np.allclose(next_target_m, target_m):
            cv2.circle(image, _pixel(camera.project(next_target_m)), size + 2, NEXT_TARGET, 1,
                       cv2.LINE_AA)
        if target_m is not None:
            cv2.circle(image, _pixel(camera.project(target_m)), size, TARGET, -1, cv2.LINE_AA)
        cv2.circle(image, _pixel(camera.project(tip)), size + 3, TIP, 2, cv2.LINE_AA)
        if estimate_m is not None:
            cv2.drawMarker(image, _pixel(camera.project(estimate_m)), ESTIMATE,
                           cv2.MARKER_TILTED_CROSS, 2 * size + 2, 2, cv2.LINE_AA)
        scale = max(0.3, min(self.width, self.height) / 600)
        text = f"t {sim.time_s:5.2f} s"
        if target_m is not None:
            text += f"  err {np.linalg.norm(tip - target_m) * 1e3:5.1f} mm"
        self._text(image, text, (4, int(14 * scale / 0.4)), scale)
        self._text(image, f"grid {self.spacing_m * 1e3:g} mm", (4, self.height - 5), scale)
        self._legend(image, size, scale)
        return image

    def _legend(self, image: np.ndarray, size: int, scale: float) -> None:
        """Target, tip and estimate glyphs with their names, top right."""
        row = int(14 * scale / 0.4)
        names = ("target", "tip", "estimate")
        width = max(cv2.getTextSize(name, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0]
                    for name in names)
        x = self.width - width - 3 * size - 8
        for i, name in enumerate(names):
            y = row * (i + 1)
            centre = (x + size, y - row // 3)
            if name == "target":
                cv2.circle(image, centre, size, TARGET, -1, cv2.LINE_AA)
            elif name == "tip":
                cv2.circle(image, centre, size, TIP, 2, cv2.LINE_AA)
            else:
                cv2.drawMarker(image, centre, ESTIMATE, cv2.MARKER_TILTED_CROSS, 2 * size, 2,
                               cv2.LINE_AA)
            self._text(image, name, (x + 2 * size + 4, y), scale)

    @staticmethod
    def _text(image: np.ndarray, text: str, origin: tuple[int, int], scale: float) -> None:
        cv2.putText(image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, TEXT, 1, cv2.LINE_AA)

    def _arrow_length_m(self) -> float:
        return 0.3 * self.extent_m

    def _draw_loads(self, image: np.ndarray, sim, tip: np.ndarray, size: int) -> None:
        """Tip masses, filling containers, swaying masses' lines and acting forces' arrows."""
        camera, time_s = self.camera, sim.time_s
        tip_px = _pixel(camera.project(tip))
        hang = 0  # pixels already taken under (or over) the tip
        below = float(tip @ self.up) < 0.0
        backbone = None
        scale = max(0.3, min(self.width, self.height) / 600)
        for load in sim.loads:
            if isinstance(load, SwayingMass) and load._body >= 0:
                ball = sim.world.body_position(load._body)
                cv2.line(image, tip_px, _pixel(camera.project(ball)), MASS, 1, cv2.LINE_AA)
            elif isinstance(load, _TipMassBase) and load.active(time_s):
                mass = load.extra_mass_kg(time_s)
                w, h = 3 * size, 2 * size
                # under a hanging tip, on top of an upright one
                x0 = tip_px[0] - w // 2
                y0 = tip_px[1] + hang + 2 if below else tip_px[1] - hang - 2 - h
                cv2.line(image, tip_px, (tip_px[0], y0 if below else y0 + h), MASS, 1,
                         cv2.LINE_AA)
                if isinstance(load, FillingLoad):
                    level = (mass - load.initial_mass_kg) / max(load.added_mass_kg, 1e-12)
                    top = y0 + int(round((1.0 - min(max(level, 0.0), 1.0)) * h))
                    if top < y0 + h:
                        cv2.rectangle(image, (x0, top), (x0 + w, y0 + h), FLUID, -1)
                    cv2.rectangle(image, (x0, y0), (x0 + w, y0 + h), MASS, 1)
                else:
                    cv2.rectangle(image, (x0, y0), (x0 + w, y0 + h), MASS, -1)
                self._text(image, f"{mass * 1e3:.0f} g", (x0 + w + 2, y0 + h), scale)
                hang += h + 3
            elif isinstance(load, Push):
                force = np.asarray(load.force_n, float) * load.scale(time_s)
                magnitude = float(np.linalg.norm(force))
                if magnitude <= 0.0:
                    continue
                if backbone is None:
                    backbone = sim.backbone()
                if load.on_tip_cap:
                    point = tip
                else:
                    i = int(load.link) % (len(backbone) - 1)
                    point = 0.5 * (backbone[i] + backbone[i + 1])
                start = point - force / magnitude * self._arrow_length_m()
                end_px, start_px = _pixel(camera.project(point)), _pixel(camera.project(start))
                colour = FLICK if isinstance(load, Flick) else PUSH
                cv2.arrowedLine(image, start_px, end_px, colour, 2, cv2.LINE_AA, tipLength=0.25)
                self._text(image, f"{magnitude:.2f} N", (start_px[0] + 2, start_px[1] - 3), scale)


# ---------------------------------------------------------------------- sensor panels
PANELS = ("scene", "camera")
"""Panel names of :func:`render_frame`: ``scene`` (the third-person view of
:class:`SceneRenderer`) and ``camera`` (every camera sensor the env simulates: the eye-in-hand
frame, the stereo pair)."""

PANEL_TEXT = (255, 255, 255)
LOST = (255, 70, 60)
ESTIMATORS = (("camera", "camera"), ("femp", "F-emp"), ("fused", "fused"), ("em", "EM"))
"""``info["estimates"]`` keys written on the eye-in-hand panel, with their labels."""

_SCENE_RENDERERS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def camera_sensors(env) -> tuple[str, ...]:
    """Names of the camera sensors ``env`` simulates (``image``, ``stereo``), in that order."""
    sensors = env.unwrapped.sensors
    return tuple(name for name in ("image", "stereo") if name in sensors)


def default_panels(env) -> tuple[str, ...]:
    """``("scene", "camera")`` when ``env`` simulates a camera sensor, else ``("scene",)``."""
    return ("scene", "camera") if camera_sensors(env) else ("scene",)


def check_panels(env, panels: Sequence[str]) -> tuple[str, ...]:
    """``panels`` as a tuple, or ``ValueError`` for unknown names, repeats, none, or ``camera``
    on an env without a camera sensor."""
    if isinstance(panels, str) or not isinstance(panels, (list, tuple)) or not panels:
        raise ValueError(f"panels must be a non-empty list of names from {list(PANELS)}, "
                         f"got {panels!r}")
    unknown = [name for name in panels if name not in PANELS]
    if unknown or len(set(panels)) != len(panels):
        raise ValueError(f"panels must be distinct names from {list(PANELS)}, got {panels!r}")
    if "camera" in panels and not camera_sensors(env):
        raise ValueError("the 'camera' panel shows the eye-in-hand ('image') or 'stereo' sensor, "
                         f"which this env does not simulate (sensors {list(env.unwrapped.sensors)}"
                         "): leave it out, or make the env with feedback 'fused'/'camera'/'fbg'/"
                         "'stereo' or sensors=('image',)")
    return tuple(panels)


def scene_view(env) -> np.ndarray:
    """The env's third-person frame (as ``env.render()`` draws it), whatever its
    ``render_mode``: an env made without ``"rgb_array"`` gets a renderer of its own, kept as long
    as the env lives."""
    unwrapped = env.unwrapped
    if unwrapped.render_mode == "rgb_array":
        return unwrapped.render()
    renderer = _SCENE_RENDERERS.get(unwrapped)
    if renderer is None:
        renderer = _SCENE_RENDERERS[unwrapped] = unwrapped.make_renderer()
    target, upcoming = unwrapped.task.target(unwrapped.step_count)
    return renderer.render(
        unwrapped.sim, target_m=target, next_target_m=upcoming,
        path_m=unwrapped.task.path_m,
        estimate_m=None if unwrapped.estimate is None else unwrapped.feedback_pose()[0])


def render_frame(env, panels: Sequence[str] = PANELS) -> np.ndarray:
    """One frame (H, W, 3) ``uint8`` of ``env`` (a :class:`~soft_gym.envs.SoftArmEnv`, wrapped
    or not) with ``panels`` side by side, left to right, all ``render_size[1]`` high.

    * ``"scene"``: :func:`scene_view` (``render_size``).
    * ``"camera"``: the eye-in-hand frame of the last measurement, faults included, scaled to the
      height, with ``e_S``, F-emp's fusion weight and the camera / F-emp / fused (and EM)
      estimates (mm, base frame) and their distances to the true tip written on it; the stereo
      pair (left, right) with the SOM centreline of each image and the shape estimate's state.
      The panel is as wide as the sensor frames at that height, so every frame of one env has
      the same size.

    Reads the env's state only: the physics and the sensors' random streams are untouched.
    """
    panels = check_panels(env, panels)
    unwrapped = env.unwrapped
    height = int(unwrapped.render_size[1])
    images = []
    for name in panels:
        if name == "scene":
            images.append(scene_view(env))
            continue
        for sensor in camera_sensors(env):
            images.extend(_image_panel(unwrapped, height) if sensor == "image"
                          else _stereo_panels(unwrapped, height))
    return images[0] if len(images) == 1 else np.concatenate(images, axis=1)


def _text_scale(height: int) -> float:
    return max(0.3, height / 600)


def _band(image: np.ndarray, rows: list[list[tuple[str, int, tuple[int, int, int]]]],
          top: bool, scale: float) -> None:
    """Lines of text on a darkened band along the top or bottom edge; each line is a list of
    (text, x in px, colour) cells, so columns line up whatever the glyphs' widths."""
    if not rows:
        return
    step = int(14 * scale / 0.4)
    height = step * len(rows) + 6
    band = slice(0, height) if top else slice(image.shape[0] - height, image.shape[0])
    image[band] = (image[band].astype(np.uint16) * 2 // 7).astype(np.uint8)
    first = height - 4 - step * (len(rows) - 1) if top else image.shape[0] - 4 - step * (
        len(rows) - 1)
    for i, cells in enumerate(rows):
        for text, x, colour in cells:
            cv2.putText(image, text, (x, first + i * step), cv2.FONT_HERSHEY_SIMPLEX, scale,
                        colour, 1, cv2.LINE_AA)


def _line(text: str, colour: tuple[int, int, int] = PANEL_TEXT) -> list:
    return [(text, 4, colour)]


def _scaled(frame: np.ndarray, height: int) -> tuple[np.ndarray, float]:
    """``frame`` resized to ``height`` rows (aspect kept) and the scale factor."""
    factor = height / frame.shape[0]
    width = max(1, int(round(frame.shape[1] * factor)))
    if frame.shape[:2] == (height, width):
        return np.array(frame, dtype=np.uint8), 1.0
    whole = abs(factor - round(factor)) < 1e-9 and factor >= 1.0
    resized = cv2.resize(np.ascontiguousarray(frame, dtype=np.uint8), (width, height),
                         interpolation=cv2.INTER_NEAREST if whole else cv2.INTER_AREA)
    return resized, factor


def _sensor_shape(unwrapped, name: str) -> tuple[int, int]:
    """(height, width) of the sensor's frames."""
    intrinsics = unwrapped.sensors[name].intrinsics
    return int(intrinsics.height), int(intrinsics.width)


def _blank(unwrapped, name: str, height: int) -> np.ndarray:
    rows, cols = _sensor_shape(unwrapped, name)
    return np.zeros((height, max(1, int(round(cols * height / rows))), 3), np.uint8)


def _image_panel(unwrapped, height: int) -> list[np.ndarray]:
    """The eye-in-hand frame with the estimates written on it."""
    measurement = unwrapped.measurement
    if measurement is None or "image" not in measurement.readings:
        panel = _blank(unwrapped, "image", height)
        _band(panel, [_line("eye-in-hand: no frame yet")], top=True, scale=_text_scale(height))
        return [panel]
    panel, _ = _scaled(measurement["image"], height)
    scale = _text_scale(height)
    estimates = (unwrapped.estimate.details if unwrapped.estimate is not None else {}) or {}
    header = [_line(f"eye-in-hand  t {measurement.time_s:5.2f} s")]
    if "reprojection_error_px" in estimates:
        error_px = float(estimates["reprojection_error_px"])
        lost = bool(estimates.get("lost", False))
        text = "e_S lost" if lost or not np.isfinite(error_px) else f"e_S {error_px:.2f} px"
        if "femp_weight" in estimates:
            text += f"   F-emp weight {float(estimates['femp_weight']):.2f}"
        header.append(_line(text, LOST if lost else PANEL_TEXT))
    _band(panel, header, top=True, scale=scale)
    if "em" in measurement.readings:
        estimates = {**estimates, "em": np.asarray(measurement["em"][:3], float)}
    tip = unwrapped.sim.tip_pose()[0]
    em = int(round(9 * scale / 0.4))  # about one glyph
    columns = (4, 4 + 7 * em, 4 + 13 * em)
    rows = []
    for key, label in ESTIMATORS:
        if key not in estimates:
            continue
        position = np.asarray(estimates[key], dtype=float)
        error_mm = float(np.linalg.norm(position - tip)) * 1e3
        x, y, z = position * 1e3
        rows.append([(label, columns[0], PANEL_TEXT), (f"{error_mm:.1f}", columns[1], PANEL_TEXT),
                     (f"{x:.1f}, {y:.1f}, {z:.1f}", columns[2], PANEL_TEXT)])
    if rows:
        rows.insert(0, [("mm", columns[0], PANEL_TEXT), ("error", columns[1], PANEL_TEXT),
                        ("x, y, z", columns[2], PANEL_TEXT)])
        _band(panel, rows, top=False, scale=scale)
    return [panel]


def _stereo_panels(unwrapped, height: int) -> list[np.ndarray]:
    """The stereo pair, each image at ``height`` with the SOM centreline found in it."""
    measurement = unwrapped.measurement
    scale = _text_scale(height)
    if measurement is None or "stereo" not in measurement.readings:
        panels = [_blank(unwrapped, "stereo", height), _blank(unwrapped, "stereo", height)]
        _band(panels[0], [_line("stereo: no frame yet")], top=True, scale=scale)
        return panels
    reading = measurement["stereo"]
    details = (unwrapped.estimate.details if unwrapped.estimate is not None else {}) or {}
    som = details.get("som_px", {})
    panels = []
    for side in ("left", "right"):
        panel, factor = _scaled(reading[side], height)
        nodes = som.get(side)
        if nodes is not None and len(nodes) > 1:
            points = np.round((np.asarray(nodes, float) + 0.5) * factor * 16 - 8).astype(np.int32)
            cv2.polylines(panel, [points], False, ESTIMATE, 2, cv2.LINE_AA, shift=4)
            for point in points:
                cv2.circle(panel, tuple(point), 3 * 16, ESTIMATE, -1, cv2.LINE_AA, shift=4)
        _band(panel, [_line(f"stereo {side}  t {measurement.time_s:5.2f} s")], top=True,
              scale=scale)
        panels.append(panel)
    if "lost" in details:
        if details["lost"]:
            text = f"lost ({details.get('reason', '')})"
            if details.get("held_steps"):
                text += f", held {details['held_steps']} steps"
            _band(panels[0], [_line(text, LOST)], top=False, scale=scale)
        else:
            tip = unwrapped.sim.tip_pose()[0]
            error_mm = float(np.linalg.norm(unwrapped.feedback_pose()[0] - tip)) * 1e3
            _band(panels[0], [_line(f"shape estimate: tip error {error_mm:.1f} mm")], top=False,
                  scale=scale)
    return panels
