"""The arm simulator in MuJoCo: the same chain as the PyBullet arm, its springs integrated in C.

:class:`MujocoArmSimulator` implements :class:`soft_gym.simulator.Simulator` on a model from
:mod:`soft_gym.engines.mujoco.model`. Between two actuation updates (``spec.actuation_update_s``,
10 ms) MuJoCo runs its substeps alone (``mj_step`` with ``nstep``): the joint springs, their
stiffening and the end stops are native, the damping implicit. At each update, as in the PyBullet
arm, the pneumatic lag advances, the loads are updated, and the chamber pressures' moments and the
held forces (pushes, flicks, tip forces, the tip payload's weight) are set as applied forces for
the next interval. docs/architecture.md, "The MuJoCo engine".

What it does not do (refused with a ``ValueError`` by the env before any work, see
:data:`MujocoArmSimulator.features`): bodies beside the arm (the swaying mass, the obstacle rod)
and cameras (the eye-in-hand camera, the stereo pair, ``render()``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from soft_gym._quaternion import quaternion_to_matrix
from soft_gym._validation import as_finite_array, require_non_negative, require_positive
from soft_gym.engines.chain_readout import ChainReadout, PhysicsDivergedError
from soft_gym.engines.common_arm import CommonArm
from soft_gym.engines.held_loads import HeldForceTable, update_payload
from soft_gym.engines.mujoco.model import ArmModel, build_arm_model
from soft_gym.engines.mujoco.world import MujocoWorld
from soft_gym.robots.chain import build_chain, pressure_to_rest_matrix, weightless_equilibrium
from soft_gym.robots.pneumatics import PneumaticSupply, chamber_area_growth, effective_pressure_pa
from soft_gym.robots.spec import ArmSpec
from soft_gym.simulator import Load

__all__ = ["MujocoArmSimulator", "PhysicsDivergedError"]

class _AppliedForces:
    """The joint forces (pressure moments) and body wrenches (held forces) applied between two
    actuation updates, and the mean of the previous and the new ones for the update's first
    substep.

    Why the mean: MuJoCo's semi-implicit Euler step is the leapfrog scheme with the velocities
    at half steps, so the velocity kick of the substep that starts at an update spans half a
    substep of the old forces and half of the new. Kicking with the new forces alone makes every
    10 ms change of the pressure moments a first-order error: with the mean, the tip's deviation
    from a 4x finer step halves (wang2023 0.29 -> 0.16 mm, zou2022 0.45 -> 0.09 mm).
    """

    def __init__(self, n_dofs: int, n_bodies: int) -> None:
        self.joint = np.zeros(n_dofs)
        self.body = np.zeros((n_bodies, 6))
        self._previous_joint = self.joint
        self._previous_body = self.body
        self.has_previous = False

    def set(self, joint: np.ndarray, body: np.ndarray) -> None:
        """The forces from this update on (N m or N per dof; body wrenches (force, torque) at
        each body's centre of mass, N and N m)."""
        self._previous_joint, self._previous_body = self.joint, self.body
        self.joint, self.body = joint, body

    def forget(self) -> None:
        """After a reset: the next forces start from rest, not from a jump."""
        self.has_previous = False

    def write(self, data: mujoco.MjData) -> None:
        data.qfrc_applied[:] = self.joint
        data.xfrc_applied[:] = self.body
        self.has_previous = True

    def write_midpoint(self, data: mujoco.MjData) -> None:
        data.qfrc_applied[:] = 0.5 * (self._previous_joint + self.joint)
        data.xfrc_applied[:] = 0.5 * (self._previous_body + self.body)


class MujocoArmSimulator(CommonArm):
    """A soft arm in its own MuJoCo model.

    Args:
        spec: the arm to build.
        physics_dt_s: the physics step (s); default ``spec.mujoco_physics_dt_s`` (else
            ``spec.physics_dt_s``).

    Attributes:
        spec: the :class:`~soft_gym.robots.spec.ArmSpec`.
        chain: the arm's :class:`~soft_gym.robots.chain.Chain`.
        model, data: MuJoCo's ``MjModel`` and ``MjData``.
        world: :class:`MujocoWorld` (no bodies beside the arm, no cameras).
        supply: the pneumatic supply (lag).
        time_s: simulated time since the last reset (s).
    """

    features: frozenset[str] = frozenset()
    """Engine features beyond the arm (see :data:`soft_gym.engines.ENGINE_FEATURES`): none."""

    def __init__(self, spec: ArmSpec, physics_dt_s: float | None = None) -> None:
        self.spec = spec
        default_dt = (spec.physics_dt_s if spec.mujoco_physics_dt_s is None
                      else spec.mujoco_physics_dt_s)
        self.physics_dt_s = default_dt if physics_dt_s is None else require_positive(
            "physics_dt_s", physics_dt_s)
        self._per_actuation = max(1, int(round(spec.actuation_update_s / self.physics_dt_s)))
        self.chain = build_chain(spec)
        self._arm: ArmModel = build_arm_model(spec, self.chain, self.physics_dt_s)
        self.model = self._arm.model
        self.data = mujoco.MjData(self.model)
        self.world = MujocoWorld()
        self._readout = ChainReadout(spec, self.chain)
        self._bodies = self._arm.body_ids[0]
        self._station_bodies = self._arm.station_body_ids[0]
        self.supply = PneumaticSupply(spec)
        self._area_growth = chamber_area_growth(spec)
        self._area_grows = bool(np.any(self._area_growth))
        self._nominal_stiffness = self.model.jnt_stiffness.copy()
        self._nominal_cubic = self.model.jnt_stiffnesspoly.copy()
        self._nominal_damping = self.model.dof_damping.copy()
        self._nominal_mass = self.model.body_mass.copy()
        self._nominal_inertia = self.model.body_inertia.copy()
        self._stiffness0 = 1.0 / self.chain.compliance
        self._pressure_to_rest_nominal = pressure_to_rest_matrix(spec, self.chain)
        self._pressure_to_rest = self._pressure_to_rest_nominal
        self._held = HeldForceTable(self.chain)
        self._forces = _AppliedForces(self.model.nv, self.model.nbody)
        self._no_wrench = np.zeros((self.model.nbody, 6))
        self._no_wrench.flags.writeable = False
        self._payload: dict[str, float] = {}
        self.gravity = spec.gravity_base.copy()
        self.model.opt.gravity[:] = self.gravity
        self.loads: list[Load] = []
        self.time_s = 0.0
        self._substep = 0
        self._kinematics_substep = self._tip_substep = -1
        self.reset()

    # ------------------------------------------------------------------ commands and stepping
    def step_physics(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` (rounded to whole physics substeps)."""
        seconds = float(seconds)
        if not np.isfinite(seconds) or seconds < 0:
            raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
        end = self._substep + int(round(seconds / self.physics_dt_s))
        model, data, step = self.model, self.data, mujoco.mj_step
        while self._substep < end:
            at_update = self._substep % self._per_actuation == 0
            if at_update:
                self._update_actuation()
            block = min(end - self._substep,
                        self._per_actuation - self._substep % self._per_actuation)
            pieces = block
            if at_update and self._forces.has_previous:
                # the applied forces jump at the update: its first substep gets the mean of the
                # old and the new ones (see _AppliedForces)
                self._forces.write_midpoint(data)
                step(model, data)
                pieces -= 1
            if at_update:
                self._forces.write(data)
            if pieces:
                step(model, data, pieces)
            self._substep += block
        self.time_s = self._substep * self.physics_dt_s
        self._readout.check_within_stops(self.data.qpos, self.time_s, self.loads)

    def reset(self, pressure_pa: np.ndarray | None = None, settle_s: float = 0.0) -> None:
        """Set pressures (Pa; ``None``: the pre-pressure), put the arm at rest (straight without
        ``pressure_pa``, else in the shape those pressures hold against its springs alone), and
        optionally let it settle under gravity and its loads for ``settle_s`` (s)."""
        self.supply.reset(pressure_pa)
        if pressure_pa is None:
            start = np.zeros(self.chain.n_joints)
        else:
            effective = effective_pressure_pa(self.spec, self.supply.pressure_pa)
            start = weightless_equilibrium(self._pressure_to_rest @ effective, self.chain)
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = start
        self._forces.forget()
        self.time_s = 0.0
        self._substep = 0
        self._kinematics_substep = self._tip_substep = -1
        self.restart_loads()
        if settle_s > 0:
            self.step_physics(settle_s)
            self.restart_clock()

    def _forget_reads(self) -> None:
        self._kinematics_substep = self._tip_substep = -1

    def set_joint_positions(self, positions: np.ndarray) -> None:
        """Set every joint's position (rad or m) at rest, e.g. to impose a shape in a test."""
        self.data.qpos[:] = as_finite_array("positions", positions, shape=(self.chain.n_joints,))
        self.data.qvel[:] = 0.0
        self._kinematics_substep = self._tip_substep = -1

    def close(self) -> None:
        """Nothing to release (the model and data are freed with the object)."""

    # ------------------------------------------------------------------ state
    def joint_positions(self) -> np.ndarray:
        """Joint positions (rad or m), in the chain's joint order."""
        return self.data.qpos.copy()

    def tip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and quaternion (x, y, z, w) in the base frame
        (:meth:`ChainReadout.tip_pose <soft_gym.engines.chain_readout.ChainReadout.tip_pose>`)."""
        if self._tip_substep != self._substep:
            positions, quaternions, rotations = self._link_frames()
            self._tip = self._readout.tip_pose(positions, quaternions, rotations, self.data.qpos)
            self._tip_substep = self._substep
        return self._tip[0].copy(), self._tip[1].copy()

    def backbone(self) -> np.ndarray:
        """The base and every link's distal end (m, (n_links + 1, 3))."""
        positions, _, rotations = self._link_frames()
        return self._readout.backbone(positions, rotations)

    def chamber_lengths(self) -> np.ndarray:
        """Chamber lengths (m), shape (n_chambers,)."""
        return self._readout.chamber_lengths(self.data.qpos)

    def curvature_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """Arc position (m) and curvature vector (1/m) at every backbone vertex."""
        return self._readout.curvature_profile(self.data.qpos)

    def link_axial_strains(self) -> np.ndarray:
        """Axial strain of every link, shape (n_links,)."""
        return self._readout.link_axial_strains(self.data.qpos)

    def link_twists(self) -> np.ndarray:
        """Twist angle of each link's torsion joint (rad), zeros without torsion joints."""
        return self._readout.link_twists(self.data.qpos)

    def link_twist_rates(self) -> np.ndarray:
        """Twist rate of every link (rad/m)."""
        return self.link_twists() / self.chain.station_rest_length

    def link_rotations(self, links: np.ndarray) -> np.ndarray:
        """World-from-link rotation matrices of the arm's ``links`` (0 at the base),
        shape (len(links), 3, 3)."""
        return self._link_frames()[2][np.asarray(links, dtype=int)]

    def link_contact_forces(self) -> np.ndarray:
        """Force pressing on every link from outside (N, base frame), shape (n_links, 3): the held
        forces on the body's surface (pushes); this engine has no contacts."""
        return self._held.body_forces_per_link(self.n_links)

    # ------------------------------------------------------------------ loads and parameters
    def set_gravity(self, vector_m_s2: np.ndarray) -> None:
        """Set gravity in the base frame (m/s^2)."""
        self.gravity = as_finite_array("vector_m_s2", vector_m_s2, shape=(3,))
        self.model.opt.gravity[:] = self.gravity
        if self._payload:
            self._apply_payload()

    def set_external_force(self, key: str, link: int, force_n: np.ndarray,
                           local_point_m: tuple[float, float, float] | None = None,
                           on_body: bool = True) -> None:
        """Hold a force (N, base frame) on the arm's ``link`` (0 at the base, negative counts
        from the tip) at ``local_point_m`` (m, link frame; default the middle of the link), from
        the next actuation update until replaced or set to zero. ``on_body=False`` marks a force
        on the tip cap rather than on the body's surface."""
        self._held.set(key, link, force_n, local_point_m, on_body)

    def set_tip_payload(self, key: str, mass_kg: float) -> None:
        """Carry a point mass (kg) at the tip under ``key``; payloads of several keys add up and
        ``0`` removes one (as the PyBullet arm: the tip link's mass and inertia, and a force
        couple that moves the weight to the tip)."""
        if update_payload(self._payload, key, require_non_negative("mass_kg", mass_kg)):
            self._apply_payload()

    @property
    def tip_payload_kg(self) -> float:
        """Total point mass carried at the tip (kg)."""
        return float(sum(self._payload.values()))

    def link_mass(self, link: int) -> float:
        """Mass (kg) of sub-link ``link`` (the chain's joint index)."""
        return float(self.model.body_mass[self._bodies[link]])

    def clear_loads(self) -> None:
        """Detach every load and restore all they changed (the arm is then as built)."""
        for load in self.loads:
            load.detach(self)
        self.loads.clear()
        self._payload.clear()
        self.model.body_mass[:] = self._nominal_mass
        self.model.body_inertia[:] = self._nominal_inertia
        self._held.clear()

    def set_stiffness_scale(self, scale: float) -> None:
        """Multiply the arm's bending, torsion and axial stiffness (and with it the
        stiffness-proportional damping) by ``scale`` relative to the spec; the end stops and the
        pressure moments stay. Used by domain randomisation."""
        scale = require_positive("scale", scale)
        self._pressure_to_rest = self._pressure_to_rest_nominal / scale
        self._stiffness0 = scale / self.chain.compliance
        self.model.jnt_stiffness[:] = self._nominal_stiffness * scale
        self.model.jnt_stiffnesspoly[:] = self._nominal_cubic * scale
        self.model.dof_damping[:] = self._nominal_damping * scale

    def _update_actuation(self) -> None:
        """Every ``actuation_update_s``: the loads, the lag, the pressure moments and the held
        forces for the next interval."""
        now_s = self._substep * self.physics_dt_s
        for load in self.loads:
            load.update(self, now_s)
        pressure = self.supply.advance(self._per_actuation * self.physics_dt_s)
        if self._area_grows:
            pressure = pressure * (1.0 + self._area_growth * pressure / self.spec.p_max_pa)
        joint = self._stiffness0 * (self._pressure_to_rest @ pressure)
        body = self._no_wrench
        if self._held.forces:
            body = np.zeros_like(self._no_wrench)
            positions, _, rotations = self._link_frames()
            centres = self.data.xipos
            for link, force, point in self._held.resolved():
                index = self._bodies[link]
                station = int(np.flatnonzero(self.chain.station_link == link)[0])
                lever = (positions[station] + rotations[station] @ point) - centres[index]
                body[index, :3] += force
                body[index, 3:] += np.cross(lever, force)
        self._forces.set(joint, body)

    def _link_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Frame origin (m), quaternion (x, y, z, w) and rotation matrix of every link, from the
        current state (MuJoCo's kinematics run once per substep read)."""
        if self._kinematics_substep != self._substep:
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_comPos(self.model, self.data)
            bodies = self._station_bodies
            self._frames = (self.data.xpos[bodies], self.data.xquat[bodies][:, [1, 2, 3, 0]],
                            self.data.xmat[bodies].reshape(-1, 3, 3))
            self._kinematics_substep = self._substep
        return self._frames

    def _apply_payload(self) -> None:
        """Put the sum of the payloads on the tip link: its mass at the link's centre of mass,
        the inertia ``m r^2`` about the transverse axes (``r`` from there to the tip), and the
        weight couple that moves its line of action to the tip."""
        body = self._bodies[self.chain.tip_link]
        payload = sum(self._payload.values())
        com = np.asarray(self.chain.sub_links.inertial_positions[self.chain.tip_link], float)
        tip_point = np.array([0.0, 0.0, self.chain.station_rest_length[-1]])
        lever_m = np.linalg.norm(tip_point - com)
        self.model.body_mass[body] = self._nominal_mass[body] + payload
        self.model.body_inertia[body] = (self._nominal_inertia[body]
                                         + payload * lever_m**2 * np.array([1.0, 1.0, 0.0]))
        weight = payload * self.gravity
        self._held.set("payload_tip", -1, weight, tuple(tip_point), on_body=False)
        self._held.set("payload_com", -1, -weight, tuple(com), on_body=False)
