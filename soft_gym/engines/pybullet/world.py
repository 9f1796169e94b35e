"""The bodies around the arm and the cameras that look at them, in PyBullet.

:class:`PyBulletWorld` is ``sim.world`` of :class:`~soft_gym.engines.pybullet.simulator.ArmSimulator`:
the :class:`~soft_gym.simulator.World` half of the simulator interface. Loads (a swaying ball,
an obstacle rod), the visual faults' occluder plates, the stereo pair's backdrop and the eye-in-hand
camera's scenery are bodies made through it, and every camera frame (the eye-in-hand camera, the
stereo pair, ``env.render()``) is drawn by it, with PyBullet's TinyRenderer. Nothing outside the
engine package calls PyBullet (docs/architecture.md, "Layers and packages").
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import pybullet

from soft_gym.engines.pybullet.scene import build_scene

_GEOMETRY = {"sphere": pybullet.GEOM_SPHERE, "box": pybullet.GEOM_BOX,
             "cylinder": pybullet.GEOM_CYLINDER}
"""The shapes :meth:`PyBulletWorld.add_body` makes."""


def _shape_sizes(shape: str, size: dict[str, Any]) -> tuple[dict, dict]:
    """PyBullet's keyword arguments of one shape's collision and visual geometry."""
    if shape == "sphere":
        return {"radius": size["radius_m"]}, {"radius": size["radius_m"]}
    if shape == "box":
        extents = [float(value) for value in size["half_extents_m"]]
        return {"halfExtents": extents}, {"halfExtents": extents}
    # PyBullet names a cylinder's length "height" for collision and "length" for visual shapes
    return ({"radius": size["radius_m"], "height": size["length_m"]},
            {"radius": size["radius_m"], "length": size["length_m"]})


def view_matrix(rotation: np.ndarray, position: np.ndarray) -> list[float]:
    """OpenGL view matrix (16 floats, column-major) of a camera with world-from-camera pose
    ``(rotation, position)`` in OpenCV axes (x right, y down, z forward)."""
    gl_rotation = rotation * np.array([1.0, -1.0, -1.0])  # OpenGL: y up, looking along -z
    matrix = np.eye(4)
    matrix[:3, :3] = gl_rotation.T
    matrix[:3, 3] = -gl_rotation.T @ position
    return matrix.T.reshape(-1).tolist()


def render_rgbd(client, width: int, height: int, view: list[float], projection: list[float],
                light_direction, *, segmentation: bool = False
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """One TinyRenderer frame of ``client``'s world (see :meth:`PyBulletWorld.render`)."""
    flags = {} if segmentation else {"flags": pybullet.ER_NO_SEGMENTATION_MASK}
    image = client.getCameraImage(width, height, view, projection,
                                  lightDirection=list(light_direction), shadow=0,
                                  renderer=pybullet.ER_TINY_RENDERER, **flags)
    rgb = np.asarray(image[2], dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    depth = np.asarray(image[3]).reshape(height, width)
    mask = np.asarray(image[4]).reshape(height, width) if segmentation else None
    return rgb, depth, mask


def render_camera(client, intrinsics, rotation: np.ndarray, position: np.ndarray,
                  light_direction) -> tuple[np.ndarray, np.ndarray]:
    """A pinhole camera's frame in ``client``'s world (see :meth:`PyBulletWorld.render_camera`)."""
    rgb, buffer, _ = render_rgbd(client, intrinsics.width, intrinsics.height,
                                 view_matrix(rotation, position), intrinsics.projection_matrix(),
                                 light_direction)
    return np.ascontiguousarray(rgb), intrinsics.depth_from_buffer(buffer)


class PyBulletWorld:
    """Bodies and cameras in one simulator's PyBullet client.

    Args:
        client: the simulator's ``BulletClient``.
        arm_body: the arm's body id (bodies may be made blind to it, tethered to its tip).
        tip_link: the arm's last link (PyBullet link index).
        tip_offset_m: the tip in the last link's frame (m).
    """

    def __init__(self, client, arm_body: int, tip_link: int, tip_offset_m: np.ndarray) -> None:
        self.client = client
        self._arm = arm_body
        self._tip_link = tip_link
        self._tip_offset = np.asarray(tip_offset_m, dtype=float)
        self._n_arm_links = client.getNumJoints(arm_body)

    # ------------------------------------------------------------------ bodies
    def add_body(self, shape: str, *, position_m: Sequence[float],
                 quaternion: Sequence[float] | None = None,
                 axis_angle: tuple[Sequence[float], float] | None = None, mass_kg: float = 0.0,
                 rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0), collide: bool = True,
                 **size: Any) -> int:
        """A new rigid body; returns its id.

        Args:
            shape: ``"sphere"`` (``radius_m=``), ``"box"`` (``half_extents_m=``) or
                ``"cylinder"`` (``radius_m=``, ``length_m=`` along its z axis).
            position_m: its centre (m, base frame).
            quaternion: its orientation (x, y, z, w); ``None`` the identity.
            axis_angle: its orientation as a rotation axis and an angle (rad), instead of
                ``quaternion``.
            mass_kg: its mass (kg); 0 makes it static.
            rgba: its colour.
            collide: whether it has a collision shape (``False``: visible only).
        """
        collision_size, visual_size = _shape_sizes(shape, size)
        geometry = _GEOMETRY[shape]
        collision = (self.client.createCollisionShape(geometry, **collision_size) if collide
                     else -1)
        visual = self.client.createVisualShape(geometry, **visual_size, rgbaColor=list(rgba))
        if axis_angle is not None:
            quaternion = pybullet.getQuaternionFromAxisAngle(list(axis_angle[0]), axis_angle[1])
        pose = [list(position_m)] + ([] if quaternion is None else [quaternion])
        return self.client.createMultiBody(float(mass_kg), collision, visual, *pose)

    def remove_body(self, body: int) -> None:
        """Remove a body made by :meth:`add_body` (a body already gone is left alone)."""
        try:
            self.client.removeBody(body)
        except pybullet.error:
            pass

    def set_body_pose(self, body: int, position_m: Sequence[float],
                      quaternion: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> None:
        """Move a body to a pose (m, base frame; quaternion x, y, z, w)."""
        self.client.resetBasePositionAndOrientation(body, list(position_m), list(quaternion))

    def stop_body(self, body: int) -> None:
        """Set a body's linear and angular velocity to zero."""
        self.client.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0])

    def body_position(self, body: int) -> np.ndarray:
        """A body's centre (m, base frame)."""
        return np.asarray(self.client.getBasePositionAndOrientation(body)[0])

    def ignore_arm_collisions(self, body: int) -> None:
        """Let ``body`` pass through the arm (a ball hanging from its tip)."""
        for link in range(-1, self._n_arm_links):
            self.client.setCollisionFilterPair(body, self._arm, -1, link, 0)

    def tether_to_tip(self, body: int, offset_m: np.ndarray) -> int:
        """Pin ``body``'s centre at ``offset_m`` (m, base-frame axes) from the tip; returns the
        tether's id (a point-to-point constraint holding up to 1 kN)."""
        # constraint pivots are given in the link's centre-of-mass frame
        com = np.asarray(self.client.getDynamicsInfo(self._arm, self._tip_link)[3])
        pivot = self._tip_offset - com
        tether = self.client.createConstraint(
            self._arm, self._tip_link, body, -1, pybullet.JOINT_POINT2POINT, [0, 0, 0],
            pivot.tolist(), list(offset_m))
        self.set_tether_force(tether, 1e3)
        return tether

    def set_tether_force(self, tether: int, max_force_n: float) -> None:
        """The most force (N) a tether may pass; 0 releases the body."""
        self.client.changeConstraint(tether, maxForce=max_force_n)

    def remove_tether(self, tether: int) -> None:
        self.client.removeConstraint(tether)

    def build_scene(self, arm_length_m: float, **options: Any) -> list[int]:
        """The eye-in-hand camera's feature-rich surroundings
        (:func:`~soft_gym.engines.pybullet.scene.build_scene`); returns their body ids."""
        return build_scene(self.client, arm_length_m, **options)

    # ------------------------------------------------------------------ cameras
    def render(self, width: int, height: int, view: list[float], projection: list[float],
               light_direction: Sequence[float], *,
               segmentation: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """One TinyRenderer frame: RGB (uint8, (H, W, 3)), the raw depth buffer (H, W) and, with
        ``segmentation``, the body id of every pixel (H, W).

        Args:
            view, projection: OpenGL matrices (16 floats each, column-major).
            light_direction: towards the light (base frame).
        """
        return render_rgbd(self.client, width, height, view, projection, light_direction,
                           segmentation=segmentation)

    def render_camera(self, intrinsics, rotation: np.ndarray, position: np.ndarray,
                      light_direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A pinhole camera's RGB frame (uint8 (H, W, 3)) and metric depth (m, (H, W)).

        Args:
            intrinsics: a :class:`~soft_gym.sensors.intrinsics.CameraIntrinsics`.
            rotation, position: world-from-camera pose (OpenCV axes; m).
            light_direction: towards the light (base frame).
        """
        return render_camera(self.client, intrinsics, rotation, position, light_direction)

    def hide_all_but(self, keep: list[int]) -> list[tuple[int, int, list[float]]]:
        """Make every visual shape of the bodies not in ``keep`` transparent (TinyRenderer then
        skips it); returns what :meth:`unhide` needs to put the colours back exactly."""
        client, hidden = self.client, []
        for index in range(client.getNumBodies()):
            body = client.getBodyUniqueId(index)
            if body in keep:
                continue
            for shape in client.getVisualShapeData(body):
                colour = list(shape[7])
                if colour[3] > 0.0:
                    client.changeVisualShape(body, shape[1], rgbaColor=[0.0, 0.0, 0.0, 0.0])
                    hidden.append((body, shape[1], colour))
        return hidden

    def unhide(self, hidden: list[tuple[int, int, list[float]]]) -> None:
        """Undo :meth:`hide_all_but`."""
        for body, link, colour in hidden:
            self.client.changeVisualShape(body, link, rgbaColor=colour)

    @property
    def arm_body(self) -> int:
        """The arm's body id (the pixels :meth:`render` labels with it are the arm's)."""
        return self._arm
