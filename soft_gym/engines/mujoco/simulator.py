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

from soft_gym._validation import as_finite_array, require_non_negative, require_positive
from soft_gym.engines.chain_readout import ChainReadout, PhysicsDivergedError
from soft_gym.engines.common_arm import CommonArm
from soft_gym.engines.held_loads import HeldForceTable, carry_tip_payload, update_payload
from soft_gym.engines.mujoco.model import ArmModel, build_arm_model
from soft_gym.engines.mujoco.stepping import STOP_LOOKAHEAD_UPDATES, step_arms
from soft_gym.engines.mujoco.world import MujocoWorld
from soft_gym.robots.chain import build_chain, pressure_to_rest_matrix, weightless_equilibrium
from soft_gym.robots.pneumatics import BoreGrowth, effective_pressure_pa, make_supply
from soft_gym.robots.spec import ArmSpec
from soft_gym.simulator import Load

__all__ = ["MujocoArmSimulator", "PhysicsDivergedError"]

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
        supply: the pneumatic supply (pressure lag, or the cylinders' strokes and gas law).
        time_s: simulated time since the last reset (s).
    """

    features: frozenset[str] = frozenset({"batched"})
    """Engine features beyond the arm (see :data:`soft_gym.engines.ENGINE_FEATURES`): arms
    stepped as one batch (:attr:`step_batch`)."""

    step_batch = staticmethod(step_arms)
    """``step_batch(sims, seconds, executor=None, n_threads=1)`` advances arms of this class
    together by ``seconds`` (s) (:func:`~soft_gym.engines.mujoco.stepping.step_arms`)."""

    def __init__(self, spec: ArmSpec, physics_dt_s: float | None = None) -> None:
        self.spec = spec
        default_dt = (spec.physics_dt_s if spec.mujoco_physics_dt_s is None
                      else spec.mujoco_physics_dt_s)
        self.physics_dt_s = default_dt if physics_dt_s is None else require_positive(
            "physics_dt_s", physics_dt_s)
        self.per_actuation = max(1, int(round(spec.actuation_update_s / self.physics_dt_s)))
        self.actuation_interval_s = self.per_actuation * self.physics_dt_s
        # an arm moves onto the model with the stops' tendons this long before it could reach one
        self.stop_lookahead_s = STOP_LOOKAHEAD_UPDATES * self.actuation_interval_s
        self._stops_ahead: tuple[float, bool] | None = None
        self.chain = build_chain(spec)
        self._arm: ArmModel = build_arm_model(spec, self.chain, self.physics_dt_s)
        # the same arm without the end stops' tendons, for while no joint is near a stop
        free = build_arm_model(spec, self.chain, self.physics_dt_s, stops=False).model
        self._models = {True: self._arm.model, False: free}
        self._datas = {True: mujoco.MjData(self._arm.model), False: mujoco.MjData(free)}
        self.with_stops = True
        self.model, self.data = self._models[True], self._datas[True]
        stops = self.chain.end_stops()
        self._free_centre, self._free_half_width = stops.free_centre, stops.free_half_width
        self.world = MujocoWorld()
        self._readout = ChainReadout(spec, self.chain)
        self._bodies = self._arm.body_ids
        self._station_bodies = self._arm.station_body_ids
        self.bore = BoreGrowth(spec)
        self._nominal_stiffness = self.model.jnt_stiffness.copy()
        self._nominal_cubic = self.model.jnt_stiffnesspoly.copy()
        self._nominal_damping = self.model.dof_damping.copy()
        self._nominal_mass = self.model.body_mass.copy()
        self._nominal_inertia = self.model.body_inertia.copy()
        self._pressure_to_rest_nominal = pressure_to_rest_matrix(spec, self.chain)
        self._pressure_to_rest = self._pressure_to_rest_nominal
        # joint force per unit effective pressure, (n_chambers, n_dofs): k0 q_rest, which a
        # stiffness scale leaves unchanged (k0 scales up as q_rest scales down)
        stiffness = 1.0 / self.chain.compliance
        self.moments = (stiffness[:, None] * self._pressure_to_rest_nominal).T.copy()
        # pressure (default) or volume actuation (spec.cylinders, VolumeSupply)
        self.supply = make_supply(spec, self._rest_chamber_lengths)
        # arms with equal keys can share one actuation update (stepping.step_arms)
        self.lockstep_key = (self.physics_dt_s, self.per_actuation, self.moments.tobytes(),
                             self.bore.key(), spec.p_max_pa.tobytes(),
                             spec.cylinders)
        self._held = HeldForceTable(self.chain)
        self.joint_force = self.joint_force_previous = np.zeros(self.model.nv)
        self.wrench: np.ndarray | None = None  # body wrenches of the held forces, (n_bodies, 6)
        self.wrench_previous: np.ndarray | None = None
        self.forces_started = False  # forces applied since the reset (else no midpoint step)
        self._payload: dict[str, float] = {}
        self.gravity = spec.gravity_base.copy()
        for model in self._models.values():
            model.opt.gravity[:] = self.gravity
        self.loads: list[Load] = []
        self.time_s = 0.0
        self.substep = 0
        self._kinematics_substep = self._tip_substep = self._backbone_substep = -1
        self.reset()

    # ------------------------------------------------------------------ commands and stepping
    def step_physics(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` (rounded to whole physics substeps;
        :func:`~soft_gym.engines.mujoco.stepping.step_arms`)."""
        step_arms([self], seconds)

    def reset(self, pressure_pa: np.ndarray | None = None, settle_s: float = 0.0) -> None:
        """Set pressures (Pa; ``None``: the pre-pressure), put the arm at rest (straight without
        ``pressure_pa``, else in the shape those pressures hold against its springs alone), and
        optionally let it settle under gravity and its loads for ``settle_s`` (s)."""
        if self.spec.cylinders is not None:  # the strokes that hold these pressures in this shape
            start = self._volume_start(pressure_pa)
        elif pressure_pa is None:
            self.supply.reset()
            start = np.zeros(self.chain.n_joints)
        else:
            self.supply.reset(pressure_pa)
            effective = effective_pressure_pa(self.spec, self.supply.pressure_pa)
            start = weightless_equilibrium(self._pressure_to_rest @ effective, self.chain)
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = start
        self.choose_model()
        self.forces_started = False
        self.wrench = self.wrench_previous = None
        self._start_episode(settle_s)

    def _restart_substeps(self) -> None:
        self.substep = 0
        self.forget_reads()

    def forget_reads(self) -> None:
        """Drop the read-out caches (the state changed without a substep count, e.g. a batch
        stepped the arm)."""
        self._kinematics_substep = self._tip_substep = self._backbone_substep = -1

    def check_within_stops(self) -> None:
        """Raise :class:`PhysicsDivergedError` if a joint is far past its end stop."""
        self._readout.check_within_stops(self.data.qpos, self.time_s, self.loads)

    def set_joint_positions(self, positions: np.ndarray) -> None:
        """Set every joint's position (rad or m) at rest, e.g. to impose a shape in a test."""
        self.data.qpos[:] = as_finite_array("positions", positions, shape=(self.chain.n_joints,))
        self.data.qvel[:] = 0.0
        self.choose_model()
        self.forget_reads()

    def close(self) -> None:
        """Nothing to release (the model and data are freed with the object)."""

    # ------------------------------------------------------------------ state
    def joint_positions(self) -> np.ndarray:
        """Joint positions (rad or m), in the chain's joint order."""
        return self.data.qpos.copy()

    def tip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and quaternion (x, y, z, w) in the base frame
        (:meth:`ChainReadout.tip_pose <soft_gym.engines.chain_readout.ChainReadout.tip_pose>`)."""
        if self._tip_substep != self.substep:
            positions, quaternions, rotations = self._link_frames()
            self._tip = self._readout.tip_pose(positions, quaternions, rotations, self.data.qpos)
            self._tip_substep = self.substep
        return self._tip[0].copy(), self._tip[1].copy()

    def backbone(self) -> np.ndarray:
        """The base and every link's distal end (m, (n_links + 1, 3))."""
        if self._backbone_substep != self.substep:  # read by the truth sensor and the info
            positions, _, rotations = self._link_frames()
            self._backbone = self._readout.backbone(positions, rotations)
            self._backbone_substep = self.substep
        return self._backbone.copy()

    def chamber_lengths(self) -> np.ndarray:
        """Chamber lengths (m), shape (n_chambers,)."""
        return self._readout.chamber_lengths(self.data.qpos)

    def segment_bend_angles_rad(self) -> np.ndarray:
        """Each segment's bending angle (rad, (n_segments,)), the tangent's turn from its base
        to its end."""
        return self._readout.segment_bend_angles_rad(self.data.qpos)

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
        for model in self._models.values():
            model.opt.gravity[:] = self.gravity
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
        for model in self._models.values():
            model.body_mass[:] = self._nominal_mass
            model.body_inertia[:] = self._nominal_inertia
        self._held.clear()

    def set_stiffness_scale(self, scale: float) -> None:
        """Multiply the arm's bending, torsion and axial stiffness (and with it the
        stiffness-proportional damping) by ``scale`` relative to the spec; the end stops and the
        pressure moments stay. Used by domain randomisation."""
        scale = require_positive("scale", scale)
        self._pressure_to_rest = self._pressure_to_rest_nominal / scale
        for model in self._models.values():
            model.jnt_stiffness[:] = self._nominal_stiffness * scale
            model.jnt_stiffnesspoly[:] = self._nominal_cubic * scale
            model.dof_damping[:] = self._nominal_damping * scale

    @property
    def model_with_stops(self) -> mujoco.MjModel:
        """The arm's full model, with the end stops' tendons (``model`` is the one carrying the
        arm now, which lacks them while every joint is far from its stops)."""
        return self._models[True]

    def stop_proximity(self) -> tuple[bool, bool]:
        """``(now, ahead)``: whether a joint is in the band where a stop acts, and whether one
        is or, moving at its present speed, could reach it within ``stop_lookahead_s``."""
        reach = np.abs(self.data.qpos - self._free_centre)
        now = bool((reach >= self._free_half_width).any())
        if now:
            return True, True
        reach += np.abs(self.data.qvel) * self.stop_lookahead_s
        return False, bool((reach >= self._free_half_width).any())

    def in_stop_band(self, positions: np.ndarray) -> bool:
        """Whether any of ``positions`` (joint positions, (..., n_joints)) puts a joint in the
        band where a stop acts (as :meth:`stop_proximity`'s ``now``)."""
        return bool((np.abs(positions - self._free_centre) >= self._free_half_width).any())

    @property
    def forces_known_ahead(self) -> bool:
        """Whether every applied force until the next change of command is known before the
        substeps run: pressure actuation (no gas law on the chambers' lengths), no loads to
        update, no held forces (their moments depend on the pose) now or at the last update,
        and the arm on the model without the stops' tendons
        (:func:`~soft_gym.engines.mujoco.stepping.step_arms` then runs them open loop)."""
        return (self.spec.cylinders is None and not self.loads and not self.with_stops
                and self.wrench is None and self.wrench_previous is None
                and not self._held.forces)

    def note_stops_ahead(self, ahead: bool) -> None:
        """Remember :meth:`stop_proximity`'s ``ahead`` for the present state, for the next
        :meth:`choose_model` with ``lookahead=True`` (the block of substeps that just ended
        computed it; any change of the state forgets it)."""
        self._stops_ahead = (self.data.time, ahead)

    def save_state(self) -> tuple:
        """The state a block of substeps starts from (time, positions, velocities)."""
        return self.data.time, self.data.qpos.copy(), self.data.qvel.copy()

    def restore_state(self, state: tuple) -> None:
        """Put back a state from :meth:`save_state`."""
        self.data.time, self.data.qpos[:], self.data.qvel[:] = state[0], state[1], state[2]
        self._stops_ahead = None

    def choose_model(self, lookahead: bool = False, force_stops: bool = False) -> None:
        """Carry the arm on the model with the end stops' tendons if it is near a stop (now, or
        with ``lookahead`` within ``stop_lookahead_s``: :meth:`stop_proximity`; or
        ``force_stops``), else on the model without them; the state moves across when the
        choice changes."""
        noted, self._stops_ahead = self._stops_ahead, None
        if force_stops:
            near = True
        elif lookahead and noted is not None and noted[0] == self.data.time:
            near = noted[1]
        else:
            near = self.stop_proximity()[1 if lookahead else 0]
        if near == self.with_stops:
            return
        old, new = self.data, self._datas[near]
        new.time = old.time
        new.qpos[:], new.qvel[:] = old.qpos, old.qvel
        new.qfrc_applied[:], new.xfrc_applied[:] = old.qfrc_applied, old.xfrc_applied
        self.with_stops = near
        self.model, self.data = self._models[near], new
        self.forget_reads()

    def held_wrench(self) -> np.ndarray | None:
        """The held forces as body wrenches at each body's centre of mass (N, N m; (n_bodies,
        6)), the moment taken about it in the current pose; ``None`` without held forces."""
        if not self._held.forces:
            return None
        wrench = np.zeros((self.model.nbody, 6))
        positions, _, rotations = self._link_frames()
        centres = self.data.xipos
        for link, force, point in self._held.resolved():
            index = self._bodies[link]
            station = int(np.flatnonzero(self.chain.station_link == link)[0])
            lever = (positions[station] + rotations[station] @ point) - centres[index]
            wrench[index, :3] += force
            wrench[index, 3:] += np.cross(lever, force)
        return wrench

    def _link_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Frame origin (m), quaternion (x, y, z, w) and rotation matrix of every link, from the
        current state (MuJoCo's kinematics run once per substep read)."""
        if self._kinematics_substep != self.substep:
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_comPos(self.model, self.data)
            bodies = self._station_bodies
            self._frames = (self.data.xpos[bodies], self.data.xquat[bodies][:, [1, 2, 3, 0]],
                            self.data.xmat[bodies].reshape(-1, 3, 3))
            self._kinematics_substep = self.substep
        return self._frames

    def _apply_payload(self) -> None:
        """Put the sum of the payloads on the tip link (as the PyBullet arm:
        :func:`~soft_gym.engines.held_loads.carry_tip_payload`), in both models."""
        body = self._bodies[self.chain.tip_link]
        payload = sum(self._payload.values())
        com = np.asarray(self.chain.sub_links.inertial_positions[self.chain.tip_link], float)
        added = carry_tip_payload(self._held, com, self.chain.station_rest_length[-1], payload,
                                  self.gravity)
        for model in self._models.values():
            model.body_mass[body] = self._nominal_mass[body] + payload
            model.body_inertia[body] = self._nominal_inertia[body] + added
