"""The arm simulator: one PyBullet client, one arm, its pneumatics and the loads acting on it.

This is ``env.unwrapped.sim`` (DESIGN.md section 8). Everything is in the arm's base frame, which is
PyBullet's world frame here; the mount only decides the gravity vector.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import pybullet
from pybullet_utils import bullet_client
from scipy.spatial.transform import Rotation

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.robots.builder import AXIAL, BEND_X, BEND_Y, TORSION, ArmBody, build_arm
from soft_gym.robots.pneumatics import PneumaticSupply, chamber_loads
from soft_gym.robots.spec import ArmSpec


class Load(Protocol):
    """What the simulator expects of a scenario element (see :mod:`soft_gym.scenarios`)."""

    def attach(self, sim: "ArmSimulator") -> None: ...

    def update(self, sim: "ArmSimulator", time_s: float) -> None: ...

    def reset(self, sim: "ArmSimulator") -> None: ...

    def detach(self, sim: "ArmSimulator") -> None: ...


class ArmSimulator:
    """A soft arm in its own PyBullet physics client.

    Args:
        spec: the arm to build.
        physics_dt_s: override of ``spec.physics_dt_s`` (e.g. for accuracy references).

    Attributes:
        spec: the :class:`~soft_gym.robots.spec.ArmSpec`.
        client: the ``BulletClient`` (DIRECT mode).
        arm: the built :class:`~soft_gym.robots.builder.ArmBody`.
        time_s: simulated time since the last reset (s).
    """

    def __init__(self, spec: ArmSpec, physics_dt_s: float | None = None) -> None:
        self.spec = spec
        self.physics_dt_s = spec.physics_dt_s if physics_dt_s is None else require_positive(
            "physics_dt_s", physics_dt_s)
        self._substeps_per_actuation = max(1, int(round(spec.actuation_update_s / self.physics_dt_s)))
        self.client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
        self.client.setPhysicsEngineParameter(fixedTimeStep=self.physics_dt_s, numSubSteps=1,
                                              deterministicOverlappingPairs=1)
        self.client.setTimeStep(self.physics_dt_s)
        self.client.setPhysicsEngineParameter(numSolverIterations=10)
        self.arm: ArmBody = build_arm(self.client, spec)
        self.supply = PneumaticSupply(spec)
        self._joints = list(range(self.arm.n_joints))
        self._kind = self.arm.joint_kind
        self._stiffening = bool(np.any(self.arm.stiffening > 0))
        self._chamber_weights = self._segment_bend_weights()
        self._spring_joints = list(range(self.arm.n_joints))
        spring = slice(None)
        self._stiffness0 = 1.0 / self.arm.compliance[spring]
        self._damping = 2.0 * self.arm.damping_ratio[spring] * np.sqrt(
            self._stiffness0 * self.arm.local_inertia[spring])
        self._spring_beta = self.arm.stiffening[spring]
        self._spring_scale = self.arm.strain_scale[spring]
        self._rest = np.zeros(len(self._spring_joints))

        self.gravity = spec.gravity_base.copy()
        self.client.setGravity(*self.gravity)
        self.loads: list[Load] = []
        self.time_s = 0.0
        self._substep = 0
        self._forces: dict[str, tuple[int, np.ndarray, np.ndarray]] = {}
        self._tip_force = np.zeros(3)
        self.reset()

    # ------------------------------------------------------------------ public face (DESIGN 8)
    def set_pressures(self, pressures_pa: np.ndarray) -> None:
        """Command chamber pressures (Pa, gauge), shape (n_chambers,), each in [0, p_max]."""
        self.supply.command(pressures_pa)

    def step_physics(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` (rounded to whole physics substeps)."""
        seconds = float(seconds)
        if not np.isfinite(seconds) or seconds < 0:
            raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
        n = int(round(seconds / self.physics_dt_s))
        client = self.client
        body, joints, count = self.arm.body_id, self._spring_joints, len(self._spring_joints)
        for _ in range(n):
            if self._substep % self._substeps_per_actuation == 0:
                self._update_actuation()
            states = client.getJointStates(body, joints)
            q = np.fromiter((s[0] for s in states), dtype=float, count=count)
            v = np.fromiter((s[1] for s in states), dtype=float, count=count)
            torque = self._spring_torque(q, v)
            client.setJointMotorControlArray(body, joints, pybullet.TORQUE_CONTROL,
                                             forces=torque.tolist())
            if self._forces:
                self._apply_forces()
            client.stepSimulation()
            self._substep += 1
        self.time_s = self._substep * self.physics_dt_s

    def set_gravity(self, vector_m_s2: np.ndarray) -> None:
        """Set gravity in the base frame (m/s^2)."""
        self.gravity = as_finite_array("vector_m_s2", vector_m_s2, shape=(3,))
        self.client.setGravity(*self.gravity)

    def apply_tip_force(self, force_n: np.ndarray) -> None:
        """Apply a force (N, base frame) at the tip, held until changed (zeros removes it)."""
        force = as_finite_array("force_n", force_n, shape=(3,))
        self.set_external_force("tip", self.arm.tip_link, force, at_link_end=True)

    def backbone(self) -> np.ndarray:
        """Backbone points (m, base frame): the base and every link's distal end, (n_links+1, 3)."""
        positions, rotations = self._link_frames()
        ends = positions + rotations[:, :, 2] * self.arm.station_rest_length[:, None]
        return np.vstack([np.zeros(3), ends])

    def tip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and orientation quaternion (x, y, z, w) in the base frame.

        The orientation is the last link's, continued by half of its proximal bending joint so
        that it approximates the tangent of the arc at the tip rather than at the link's middle.
        """
        positions, rotations = self._link_frames(last_only=True)
        q = self.joint_positions()
        bx, by = self.arm.station_bend_joints[-1]
        half = Rotation.from_euler("XY", [0.5 * q[bx], 0.5 * q[by]])
        tip_rotation = Rotation.from_matrix(rotations[-1]) * half
        tip = positions[-1] + rotations[-1][:, 2] * self.arm.station_rest_length[-1]
        return tip, tip_rotation.as_quat()

    def chamber_lengths(self) -> np.ndarray:
        """Chamber lengths (m), shape (n_chambers,), from each segment's arc length and bending.

        ``l_i = s + d (theta_x sin(sigma_i) - theta_y cos(sigma_i))`` with ``theta`` the segment's
        total bending rotation (consistent with :mod:`soft_gym.kinematics`).
        """
        q = self.joint_positions()
        arc, theta_x, theta_y = self._segment_arc_and_bend(q)
        sigma = 2.0 * np.pi * np.arange(3) / 3.0
        d = self.spec.chamber_offset_m[:, None]
        lengths = arc[:, None] + d * (theta_x[:, None] * np.sin(sigma) - theta_y[:, None] * np.cos(sigma))
        return lengths.reshape(-1)

    def link_curvatures(self) -> np.ndarray:
        """Curvature vector (kx, ky) of every link (1/m), shape (n_links, 2).

        The joint at a link's proximal end bends by ``theta``; over the link's current length the
        curvature is ``(theta_y, -theta_x) / ds`` (convention of :mod:`soft_gym.kinematics`).
        """
        q = self.joint_positions()
        bend = q[self.arm.station_bend_joints]
        length = self.arm.station_rest_length + q[self.arm.station_axial_joint]
        return np.stack([bend[:, 1], -bend[:, 0]], axis=1) / length[:, None]

    def link_twists(self) -> np.ndarray:
        """Twist angle of each link's torsion joint (rad), zeros without torsion joints."""
        q = self.joint_positions()
        idx = self.arm.station_torsion_joint
        return np.where(idx >= 0, q[np.maximum(idx, 0)], 0.0)

    @property
    def pressures_pa(self) -> np.ndarray:
        """Current chamber pressures (Pa)."""
        return self.supply.pressure_pa.copy()

    # ------------------------------------------------------------------ state
    def joint_positions(self) -> np.ndarray:
        states = self.client.getJointStates(self.arm.body_id, self._joints)
        return np.fromiter((s[0] for s in states), dtype=float, count=len(states))

    def joint_velocities(self) -> np.ndarray:
        states = self.client.getJointStates(self.arm.body_id, self._joints)
        return np.fromiter((s[1] for s in states), dtype=float, count=len(states))

    def reset(self, pressure_pa: np.ndarray | None = None, settle_s: float = 0.0) -> None:
        """Straighten the arm at rest, set pressures, and optionally let it settle for ``settle_s``."""
        for joint in self._joints:
            self.client.resetJointState(self.arm.body_id, joint, 0.0, 0.0)
        self.supply.reset(pressure_pa)
        self.time_s = 0.0
        self._substep = 0
        for load in self.loads:
            load.reset(self)
            load.update(self, 0.0)
        if settle_s > 0:
            self.step_physics(settle_s)
            self.time_s = 0.0
            self._substep = 0

    def add_load(self, load: Load) -> None:
        """Attach a scenario element; it is updated at the actuation rate."""
        load.attach(self)
        self.loads.append(load)

    def clear_loads(self) -> None:
        for load in self.loads:
            load.detach(self)
        self.loads.clear()
        self._forces.clear()

    def set_external_force(self, key: str, link: int, force_n: np.ndarray,
                           at_link_end: bool = False) -> None:
        """Hold a force (N, base frame) on ``link`` (at its centre of mass or distal end).

        Applied every physics substep until replaced; a zero force removes it.
        """
        force = np.asarray(force_n, dtype=float)
        if not np.any(force):
            self._forces.pop(key, None)
            return
        self._forces[key] = (int(link), force, np.array([1.0 if at_link_end else 0.5]))
        self._refresh_force_points()

    def link_mass(self, link: int) -> float:
        return float(self.client.getDynamicsInfo(self.arm.body_id, link)[0])

    def close(self) -> None:
        try:
            self.client.disconnect()
        except pybullet.error:
            pass

    # ------------------------------------------------------------------ internals
    def _segment_bend_weights(self) -> np.ndarray:
        """Weights (n_segments, n_joints) turning joint angles into each segment's total bending.

        A joint at a segment boundary is shared in proportion to the compliance each side owes it;
        the last segment also gets the half tip joint (see :meth:`tip_pose`).
        """
        parts = self.arm.compliance_parts
        weights = (parts / parts.sum(axis=1, keepdims=True)).T.copy()
        bend = np.isin(self._kind, (BEND_X, BEND_Y))
        weights[:, ~bend] = 0.0
        weights[-1, self.arm.station_bend_joints[-1]] += 0.5
        return weights

    def _segment_arc_and_bend(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n_seg = self.spec.n_segments
        arc = np.zeros(n_seg)
        np.add.at(arc, self.arm.station_segment,
                  self.arm.station_rest_length + q[self.arm.station_axial_joint])
        qx = np.where(self._kind == BEND_X, q, 0.0)
        qy = np.where(self._kind == BEND_Y, q, 0.0)
        return arc, self._chamber_weights @ qx, self._chamber_weights @ qy

    def _link_frames(self, last_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
        links = self.arm.station_link[-1:] if last_only else self.arm.station_link
        states = self.client.getLinkStates(self.arm.body_id, links.tolist(),
                                           computeForwardKinematics=1)
        positions = np.array([s[4] for s in states])
        rotations = Rotation.from_quat([s[5] for s in states]).as_matrix()
        return positions, rotations

    def _update_actuation(self) -> None:
        """Refresh pressures, loads and the spring motors (every ``actuation_update_s``)."""
        dt = self._substeps_per_actuation * self.physics_dt_s
        now_s = self._substep * self.physics_dt_s
        for load in self.loads:
            load.update(self, now_s)
        pressure = self.supply.advance(dt)
        axial, moment = chamber_loads(self.spec, pressure)
        per_kind = np.stack([moment[:, 0], moment[:, 1], np.zeros_like(axial), axial], axis=1)
        # rest deflection of each joint under the pressure loads with the small-strain compliance
        rest = (self.arm.compliance_parts * per_kind[:, self._kind].T).sum(axis=1)
        self._rest = rest[self._spring_joints]
        if self._forces:
            self._refresh_force_points()

    def _spring_torque(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint spring-damper torque (N m or N) with strain stiffening (secant form).

        ``tau = k0 f(q) (q_rest / f(q) - q) - c v`` with ``f = 1 + beta (strain)^2``: the pressure
        load is unchanged and the restoring stiffness grows with strain.
        """
        if self._stiffening:
            strain = q * self._spring_scale
            return self._rest * self._stiffness0 - (
                self._stiffness0 * (1.0 + self._spring_beta * strain * strain)) * q - self._damping * v
        return self._stiffness0 * (self._rest - q) - self._damping * v

    def _refresh_force_points(self) -> None:
        """Recompute where held forces act (world points move with the arm)."""
        self._force_points = {}
        for key, (link, _, where) in self._forces.items():
            state = self.client.getLinkState(self.arm.body_id, link, computeForwardKinematics=1)
            rotation = np.array(self.client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            length = self._link_length(link)
            self._force_points[key] = np.asarray(state[4]) + rotation[:, 2] * length * where[0]

    def _link_length(self, link: int) -> float:
        matches = np.nonzero(self.arm.station_link == link)[0]
        return float(self.arm.station_rest_length[matches[0]]) if len(matches) else 0.0

    def _apply_forces(self) -> None:
        apply = self.client.applyExternalForce
        for key, (link, force, _) in self._forces.items():
            apply(self.arm.body_id, link, force.tolist(), self._force_points[key].tolist(),
                  pybullet.WORLD_FRAME)
