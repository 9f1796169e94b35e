"""The arm simulator in PyBullet: one client, one arm, its pneumatics and the loads acting on it.

This is ``env.unwrapped.sim``, the PyBullet implementation of
:class:`soft_gym.simulator.Simulator` (docs/architecture.md, "The simulator interface"). Everything
is in the arm's base frame, which is PyBullet's world frame here; the mount only decides the
gravity vector.
"""

from __future__ import annotations

import numpy as np
import pybullet
from pybullet_utils import bullet_client

from soft_gym.engines.pybullet.quiet_import import c_stdout_silenced
from soft_gym._quaternion import quaternion_to_matrix
from soft_gym._validation import as_finite_array, require_non_negative, require_positive
from soft_gym.engines.chain_readout import ChainReadout, PhysicsDivergedError
from soft_gym.engines.common_arm import CommonArm
from soft_gym.engines.pybullet.builder import AXIAL, ArmBody, build_arm
from soft_gym.engines.pybullet.contacts import ContactSwitch
from soft_gym.engines.pybullet.external_loads import HeldForces, TipPayload
from soft_gym.engines.pybullet.mass_matrix import LinkInertias
from soft_gym.engines.pybullet.springs import STIFFNESS_MARGIN, SpringGains, tangent_stiffness_at
from soft_gym.engines.pybullet.world import PyBulletWorld
from soft_gym.robots.pneumatics import BoreGrowth, effective_pressure_pa, make_supply
from soft_gym.robots.chain import pressure_to_rest_matrix, weightless_equilibrium
from soft_gym.robots.spec import ArmSpec
from soft_gym.simulator import Load


_FAST_MOTION_PER_SUBSTEP = 0.2
"""A joint moving faster than this fraction of its mass-matrix refresh tolerance (0.05 rad or 5 %
strain) per substep has its substeps split (``ArmSimulator._refinement_for``)."""

_MAX_REFINEMENT = 4
"""The most pieces a substep is split into while the arm whips."""

__all__ = ["ArmSimulator", "PhysicsDivergedError"]


class ArmSimulator(CommonArm):
    """A soft arm in its own PyBullet physics client.

    Args:
        spec: the arm to build.
        physics_dt_s: override of ``spec.physics_dt_s`` (e.g. for accuracy references).

    Attributes:
        spec: the :class:`~soft_gym.robots.spec.ArmSpec`.
        client: the ``BulletClient`` (DIRECT mode).
        arm: the built :class:`~soft_gym.engines.pybullet.builder.ArmBody`.
        world: the bodies and cameras around the arm (:class:`PyBulletWorld`).
        time_s: simulated time since the last reset (s).
    """

    features: frozenset[str] = frozenset({"bodies", "rendering"})
    """Engine features beyond the arm (:data:`soft_gym.engines.ENGINE_FEATURES`): bodies beside
    it and cameras (its arms are not stepped as one batch)."""

    def __init__(self, spec: ArmSpec, physics_dt_s: float | None = None) -> None:
        self.spec = spec
        self.physics_dt_s = spec.physics_dt_s if physics_dt_s is None else require_positive(
            "physics_dt_s", physics_dt_s)
        self._substeps_per_actuation = max(1, int(round(spec.actuation_update_s / self.physics_dt_s)))
        with c_stdout_silenced():  # PyBullet prints "argv[0]=" on connect
            self.client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
        self.client.setPhysicsEngineParameter(fixedTimeStep=self.physics_dt_s, numSubSteps=1,
                                              deterministicOverlappingPairs=1)
        self.client.setTimeStep(self.physics_dt_s)
        self.client.setPhysicsEngineParameter(numSolverIterations=10)
        self._client_id = self.client._client  # for direct ``pybullet`` calls on the hot path
        self._step_simulation = pybullet.stepSimulation  # bench/env_speed.py times it here
        self.arm: ArmBody = build_arm(self.client, spec)
        self.chain = self.arm  # the arm's chain (an ArmBody is one, with its multibody id)
        self.world = PyBulletWorld(self.client, self.arm.body_id, self.arm.tip_link,
                                   np.array([0.0, 0.0, self.arm.station_rest_length[-1]]))
        # the arm's contact detection, off while nothing can touch it
        self._contacts = ContactSwitch(self.client, self.arm.body_id, self.arm.n_joints)
        # the semi-implicit gains; a change of a link's mass or inertia refreshes them
        self._gains = SpringGains(self.arm.n_joints)
        # PyBullet builds its inverse-dynamics tree (behind calculateMassMatrix) on the first call
        # and never updates it when a link's mass changes later; build it now, from the nominal
        # masses, and add every change on top (:meth:`mass_matrix`)
        self._inertias = LinkInertias(self.client, self.arm.body_id, self.arm.n_joints,
                                      on_change=self._gains.invalidate)
        self._held = HeldForces(self.client, self.arm)
        self._payload = TipPayload(self.arm, self._inertias, self._held)
        self._bore = BoreGrowth(spec)
        self._joints = list(range(self.arm.n_joints))
        self._kind = self.arm.joint_kind
        self._stiffening = bool(np.any(self.arm.stiffening > 0))
        self._readout = ChainReadout(spec, self.arm)
        self._stiffness0 = 1.0 / self.arm.compliance
        self._damping = self.arm.damping_time_s * self._stiffness0
        self._stops = self.arm.end_stops()
        self._station_links = self.arm.station_link.tolist()
        # read-out caches, per substep
        self._frames_substep = self._positions_substep = self._tip_substep = -1
        self._state = np.zeros(4 * self.arm.n_joints)
        self._torque = np.zeros(self.arm.n_joints)  # the substep's joint torques (buffer)
        self._previous_velocity_valid = False
        self._torque_offset = np.zeros(self.arm.n_joints)
        self._load_torque = np.zeros(self.arm.n_joints)
        # joint motion after which the mass matrix is refreshed early: 0.05 rad or 5 % strain
        self._configuration_tolerance = np.where(
            self._kind == AXIAL, 0.05 * self.arm.station_rest_length[self.arm.joint_station], 0.05)
        # joint speeds (rad/s or m/s) above which a substep is split in two, in four
        self._fast_speed = _FAST_MOTION_PER_SUBSTEP * self._configuration_tolerance / self.physics_dt_s
        self._refinement = 1  # pieces per substep (see _refinement_for)
        self._pressure_to_rest_nominal = pressure_to_rest_matrix(spec, self.arm)
        self._pressure_to_rest = self._pressure_to_rest_nominal
        # pressure (default) or volume actuation (spec.cylinders, VolumeSupply)
        self.supply = make_supply(spec, self._rest_chamber_lengths)
        self._volume = spec.cylinders is not None
        self._substeps_per_gain_update = self._substeps_per_actuation * max(
            1, int(round(spec.control_period_s / spec.actuation_update_s)))
        self.gravity = spec.gravity_base.copy()
        self.client.setGravity(*self.gravity)
        self.loads: list[Load] = []
        self.time_s = 0.0
        self._substep = 0
        self.reset()

    # ----------------------------------------------------------- public face (docs/architecture.md)
    def step_physics(self, seconds: float) -> None:
        """Advance the simulation by ``seconds`` (rounded to whole physics substeps)."""
        seconds = float(seconds)
        if not np.isfinite(seconds) or seconds < 0:
            raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
        n = int(round(seconds / self.physics_dt_s))
        if not n:
            self.time_s = self._substep * self.physics_dt_s
            return
        # the substep loop is the simulator's hot path: every name it uses is bound locally, the
        # joint states are read with one call, the arrays it writes are preallocated, and the
        # end stops are skipped with one test while every joint is in its free range
        self._contacts.sync()
        body, joints, client_id = self.arm.body_id, self._joints, self._client_id
        # pybullet's functions called directly: BulletClient's per-call keyword merging costs
        # about 1 us a call, three calls a substep
        get_states, set_motors = pybullet.getJointStates, pybullet.setJointMotorControlArray
        simulate = self._step_simulation
        torque_mode = pybullet.TORQUE_CONTROL
        count = len(joints)
        state = self._state  # [spring force K(q) q, v, v_previous, torque_previous]
        spring, velocity = state[:count], state[count:2 * count]
        previous_velocity, previous_torque = state[2 * count:3 * count], state[3 * count:]
        k0, beta, scale = self._stiffness0, self.arm.stiffening, self.arm.strain_scale
        stiffening = bool(np.any(beta != 0.0))
        stops = self._stops
        stop_force = stops.force
        free_centre, free_half_width = stops.free_centre, stops.free_half_width
        per_actuation = self._substeps_per_actuation
        torque = self._torque
        gains = self._gains
        torque_gain = gains.torque_gain  # written in place, never replaced
        held = self._held
        held_forces = held.forces  # changed in place by the loads, never replaced
        dot, absolute, add, multiply = np.dot, np.abs, np.add, np.multiply
        end = self._substep + n
        pieces = 0  # pieces of the current substep done (several while the arm whips)
        while self._substep < end:
            states = get_states(body, joints, physicsClientId=client_id)
            q = np.array([s[0] for s in states])
            velocity[:] = [s[1] for s in states]
            if pieces == 0 and self._substep % per_actuation == 0:
                refinement = self._refinement_for(velocity)
                if refinement != self._refinement:
                    self._set_refinement(refinement, q)
                self._update_actuation(q)
            # secant spring force with strain stiffening, k0 (1 + beta strain^2) q, every substep,
            # plus the end stops' force as a joint nears its limits
            if stiffening:
                strain = q * scale
                multiply(k0 * q, 1.0 + beta * strain * strain, out=spring)
            else:
                multiply(k0, q, out=spring)
            if (absolute(q - free_centre) > free_half_width).any():
                add(spring, stop_force(q), out=spring)
            dot(torque_gain, state, out=torque)
            add(self._torque_offset, torque, out=torque)
            if held_forces:
                torque += gains.solve @ held.joint_torque(q)
            set_motors(body, joints, torque_mode, forces=torque.tolist(), physicsClientId=client_id)
            simulate(physicsClientId=client_id)
            previous_velocity[:] = velocity
            previous_torque[:] = torque
            pieces += 1
            if pieces == self._refinement:
                pieces = 0
                self._substep += 1
            if not self._previous_velocity_valid:
                # a substep has been measured: bring in the other-forces term from now on
                self._previous_velocity_valid = True
                self._update_implicit_gains(q, gains.implicit_stiffness)
        self.time_s = self._substep * self.physics_dt_s
        self._check_within_stops()

    def set_gravity(self, vector_m_s2: np.ndarray) -> None:
        """Set gravity in the base frame (m/s^2)."""
        self.gravity = as_finite_array("vector_m_s2", vector_m_s2, shape=(3,))
        self.client.setGravity(*self.gravity)
        if self._payload.masses:
            self._payload.apply(self.gravity)

    def backbone(self) -> np.ndarray:
        """Backbone points (m, base frame): the base and every link's distal end, (n_links+1, 3)."""
        positions, _, rotations = self._link_frames()
        return self._readout.backbone(positions, rotations)

    def tip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and orientation quaternion (x, y, z, w) in the base frame.

        The orientation is the last link's, continued by half of its proximal bending joint so
        that it approximates the tangent of the arc at the tip rather than at the link's middle.
        """
        if self._tip_substep == self._substep:
            tip, quaternion = self._tip
            return tip.copy(), quaternion.copy()
        positions, quaternions, rotations = self._link_frames()
        self._tip = self._readout.tip_pose(positions, quaternions, rotations,
                                           self.joint_positions())
        self._tip_substep = self._substep
        return self._tip[0].copy(), self._tip[1].copy()

    def chamber_lengths(self) -> np.ndarray:
        """Chamber lengths (m), shape (n_chambers,), from each segment's arc length and bending
        (:meth:`ChainReadout.chamber_lengths <soft_gym.engines.chain_readout.ChainReadout.chamber_lengths>`)."""
        return self._readout.chamber_lengths(self.joint_positions())

    def segment_bend_angles_rad(self) -> np.ndarray:
        """Each segment's bending angle (rad, (n_segments,)), the tangent's turn from its base
        to its end (:meth:`ChainReadout.segment_bend_angles_rad
        <soft_gym.engines.chain_readout.ChainReadout.segment_bend_angles_rad>`)."""
        return self._readout.segment_bend_angles_rad(self.joint_positions())

    def curvature_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """Arc position (m) and curvature vector (1/m) at every backbone vertex
        (:meth:`ChainReadout.curvature_profile <soft_gym.engines.chain_readout.ChainReadout.curvature_profile>`)."""
        return self._readout.curvature_profile(self.joint_positions())

    def link_axial_strains(self) -> np.ndarray:
        """Axial strain of every link (extension over rest length), shape (n_links,)."""
        return self._readout.link_axial_strains(self.joint_positions())

    def link_twist_rates(self) -> np.ndarray:
        """Twist rate of every link (rad/m): its torsion joint angle over the link's rest length."""
        return self.link_twists() / self.arm.station_rest_length

    def link_contact_forces(self) -> np.ndarray:
        """Force pressing on every link from outside (N, base frame), shape (n_links, 3).

        The sum of PyBullet contact normal forces (obstacles, other bodies) and of the held
        external forces that press on the body's surface (pushes); forces on the tip cap
        (:meth:`apply_tip_force`, tip masses, pushes with ``on_body=False``) are left out, since
        they do not touch a fiber or gauge on the body.
        """
        forces = np.zeros((len(self.arm.station_link), 3))
        index_of_link = {int(link): i for i, link in enumerate(self.arm.station_link)}
        for contact in self.client.getContactPoints(bodyA=self.arm.body_id):
            i = index_of_link.get(contact[3])
            if i is not None:
                # contact[7] is the normal on B pointing to A; contact[9] the normal force (N)
                forces[i] += np.asarray(contact[7]) * contact[9]
        for link, force in self._held.body_forces():
            i = index_of_link.get(link)
            if i is not None:
                forces[i] += force
        return forces

    def link_twists(self) -> np.ndarray:
        """Twist angle of each link's torsion joint (rad), zeros without torsion joints."""
        return self._readout.link_twists(self.joint_positions())

    def link_rotations(self, links: np.ndarray) -> np.ndarray:
        """World-from-link rotation matrices of the arm's ``links`` (indices, 0 at the base),
        shape (len(links), 3, 3)."""
        states = self.client.getLinkStates(self.arm.body_id,
                                           [int(self.arm.station_link[i]) for i in links],
                                           computeForwardKinematics=1)
        return quaternion_to_matrix(np.array([state[5] for state in states]))

    # ------------------------------------------------------------------ state
    def joint_positions(self) -> np.ndarray:
        """Joint positions (rad or m), in the multibody's joint order."""
        if self._positions_substep != self._substep:
            states = self.client.getJointStates(self.arm.body_id, self._joints)
            self._positions = np.fromiter((s[0] for s in states), dtype=float, count=len(states))
            self._positions_substep = self._substep
        return self._positions.copy()

    def reset(self, pressure_pa: np.ndarray | None = None, settle_s: float = 0.0) -> None:
        """Set pressures (Pa; ``None``: the pre-pressure), put the arm at rest (straight without
        ``pressure_pa``, else in the shape those pressures hold against its springs alone), and
        optionally let it settle under gravity and its loads for ``settle_s`` (s).

        Starting pressurised arms in their weightless equilibrium, not straight, spares them the
        jolt of the whole pressure load at once (an extensible arm such as zou2022's, stepped from
        straight to 2-3 bar, can tear its joints apart in the first milliseconds).
        """
        if self._volume:  # the strokes that hold these pressures in this shape
            start = self._volume_start(pressure_pa)
        elif pressure_pa is None:
            self.supply.reset()
            start = np.zeros(len(self._joints))
        else:  # where the springs balance the pressure load alone
            self.supply.reset(pressure_pa)
            effective = effective_pressure_pa(self.spec, self.supply.pressure_pa)
            start = weightless_equilibrium(self._pressure_to_rest @ effective, self.arm)
        for joint, position in zip(self._joints, start):
            self.client.resetJointState(self.arm.body_id, joint, float(position), 0.0)
        self._state[:] = 0.0
        self._previous_velocity_valid = False
        if self._refinement != 1:  # an episode that ended whipping leaves no finer step behind
            self._refinement = 1
            self.client.setPhysicsEngineParameter(fixedTimeStep=self.physics_dt_s)
        self._start_episode(settle_s)

    def _restart_substeps(self) -> None:
        self._substep = 0
        self._frames_substep = self._positions_substep = self._tip_substep = -1

    def set_joint_positions(self, positions: np.ndarray) -> None:
        """Set every joint's position (rad or m) at rest, e.g. to impose a shape in a test."""
        positions = as_finite_array("positions", positions, shape=(self.arm.n_joints,))
        for joint, value in zip(self._joints, positions):
            self.client.resetJointState(self.arm.body_id, joint, float(value), 0.0)
        self._frames_substep = self._positions_substep = self._tip_substep = -1
        self._previous_velocity_valid = False

    def set_stiffness_scale(self, scale: float) -> None:
        """Multiply the arm's bending, torsion and axial stiffness (and with it the
        stiffness-proportional damping) by ``scale`` relative to the spec; takes effect at the
        next actuation update. Used by domain randomisation."""
        scale = require_positive("scale", scale)
        # the pressure moments stay; their rest angles shrink as the arm stiffens
        self._pressure_to_rest = self._pressure_to_rest_nominal / scale
        self._stiffness0 = scale / self.arm.compliance
        self._damping = self.arm.damping_time_s * self._stiffness0
        self._gains.invalidate()

    def clear_loads(self) -> None:
        """Detach every load and restore all they changed: link masses and inertias, held
        forces (the arm is then as built, whatever loads it carried)."""
        for load in self.loads:
            load.detach(self)
        self.loads.clear()
        self._payload.masses.clear()
        self._inertias.restore_nominal()
        self._held.clear()

    def set_external_force(self, key: str, link: int, force_n: np.ndarray,
                           local_point_m: tuple[float, float, float] | None = None,
                           on_body: bool = True) -> None:
        """Hold a force (N, base frame) on the arm's ``link`` (0 at the base, negative counts
        from the tip: -1 is the last link) at ``local_point_m`` (m, link frame; default the
        middle of the link), applied every physics substep until replaced or set to zero.
        ``on_body=False`` marks a force on the tip cap rather than on the body's surface (see
        :meth:`link_contact_forces`).
        """
        self._held.set(key, link, force_n, local_point_m, on_body)

    def set_tip_payload(self, key: str, mass_kg: float) -> None:
        """Carry a point mass (kg) at the tip under ``key`` (tip masses, a filling container).

        Payloads of several keys add up; ``0`` removes one. The tip link's mass and inertia and
        the weight at the tip follow at once; :meth:`clear_loads` removes them all.
        """
        self._payload.set(key, require_non_negative("mass_kg", mass_kg), self.gravity)

    @property
    def tip_payload_kg(self) -> float:
        """Total point mass carried at the tip (kg)."""
        return float(sum(self._payload.masses.values()))

    def link_mass(self, link: int) -> float:
        return float(self.client.getDynamicsInfo(self.arm.body_id, link)[0])

    def close(self) -> None:
        try:
            self.client.disconnect()
        except pybullet.error:
            pass

    # ------------------------------------------------------------------ internals
    def _link_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Frame origin (m), quaternion and rotation matrix of every link, cached per substep."""
        if self._frames_substep != self._substep:
            states = self.client.getLinkStates(self.arm.body_id, self._station_links,
                                               computeForwardKinematics=1)
            positions = np.array([s[4] for s in states])
            quaternions = np.array([s[5] for s in states])
            self._frames = (positions, quaternions, quaternion_to_matrix(quaternions))
            self._frames_substep = self._substep
        return self._frames

    def _update_actuation(self, q: np.ndarray) -> None:
        """Refresh pressures, loads and spring stiffness (every ``actuation_update_s``).

        ``K`` is the secant stiffness ``k0 (1 + beta strain^2)`` at the current strain; the
        pressure load enters as ``k0 q_rest`` with ``q_rest`` linear in the chamber pressures.
        The implicit gains (:meth:`_update_implicit_gains`) are refreshed once per control period.
        """
        now_s = self._substep * self.physics_dt_s
        for load in self.loads:
            load.update(self, now_s)
        if self.loads and pybullet.getNumBodies(
                physicsClientId=self._client_id) != self._contacts.body_count:
            self._contacts.sync()  # a load added or removed a body
        if self._volume:  # the gas law at the chambers' present lengths
            pressure = self.supply.advance(self._substeps_per_actuation * self.physics_dt_s,
                                           self._readout.chamber_lengths(q))
        else:
            pressure = self.supply.advance(self._substeps_per_actuation * self.physics_dt_s)
        if self._bore.grows:  # effective_pressure_pa, with the growth looked up once
            pressure = self._bore.effective(pressure)
        self._load_torque = self._stiffness0 * (self._pressure_to_rest @ pressure)
        tangent = tangent_stiffness_at(q, self._stiffness0, self._stiffening, self.arm, self._stops)
        gains = self._gains
        if (self._substep % self._substeps_per_gain_update == 0
                or (tangent > gains.implicit_stiffness).any()
                or (np.abs(q - gains.gain_configuration) > self._configuration_tolerance).any()):
            # stiffening outgrew the implicit gains, or the arm moved enough to change M
            self._update_implicit_gains(q, STIFFNESS_MARGIN * tangent)
        self._torque_offset = gains.solve @ self._load_torque

    def _refinement_for(self, velocity: np.ndarray) -> int:
        """Pieces to split each substep into, judged at every actuation update from the joint
        speeds: 1 while every joint moves less than ``_FAST_MOTION_PER_SUBSTEP`` of its refresh
        tolerance per substep, else the power of two (at most ``_MAX_REFINEMENT``) that brings
        the fastest back under it.

        Why: the semi-implicit springs are stable at any step, but the velocity-product forces
        (Coriolis, centrifugal) and the joints' inertial coupling stay explicit. When a whole
        segment is slammed between pre-pressure and ``p_max`` under a tip mass (ho2018 with its
        14.2 g tip, bang-bang actions) the links whip at 10-30 rad/s, 0.03-0.08 rad per 2.5 ms
        substep, and that explicit part diverged within a few control steps. Splitting only
        those substeps keeps ordinary motion on the preset's step (bit for bit)."""
        speed = np.abs(velocity)
        if not (speed > self._fast_speed).any():  # the common case, decided in one test
            return 1
        fastest = float(np.max(speed / self._fast_speed))
        refinement = 1
        while fastest > refinement and refinement < _MAX_REFINEMENT:
            refinement *= 2
        return refinement

    def _set_refinement(self, refinement: int, q: np.ndarray) -> None:
        """Split every substep into ``refinement`` pieces from now on: PyBullet's step and the
        implicit gains follow; the other-forces term restarts (its last measurement was taken
        over a piece of the old length)."""
        self._refinement = refinement
        self.client.setPhysicsEngineParameter(fixedTimeStep=self.physics_dt_s / refinement)
        self._previous_velocity_valid = False
        self._update_implicit_gains(q, self._gains.implicit_stiffness)

    def _check_within_stops(self) -> None:
        """Raise if a joint has gone far past its end stop: the simulation has diverged, and
        its states must not reach an observation or a training batch."""
        states = self.client.getJointStates(self.arm.body_id, self._joints)
        q = np.fromiter((state[0] for state in states), dtype=float, count=len(states))
        self._readout.check_within_stops(q, self.time_s, self.loads)

    def _update_implicit_gains(self, q: np.ndarray, tangent_stiffness: np.ndarray) -> None:
        """Refresh the semi-implicit spring update's gains at ``q`` with ``tangent_stiffness``
        (N m/rad or N/m) in the implicit term (:meth:`SpringGains.update
        <soft_gym.engines.pybullet.springs.SpringGains.update>`): the mass matrix at ``q``, the
        current (piece of) substep and damping; the other-forces term only once a substep has
        measured it."""
        self._gains.update(q, tangent_stiffness, self.mass_matrix(q),
                           self.physics_dt_s / self._refinement, self._damping,
                           self._previous_velocity_valid)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix (kg, kg m, kg m^2) at joint positions ``q``, with the links'
        current masses and inertias (tip payloads included).

        PyBullet's ``calculateMassMatrix`` keeps the masses its tree was built with (the nominal
        ones, see ``__init__``); each changed link adds ``dm Jv^T Jv + Jw^T R dI R^T Jw`` with its
        centre-of-mass Jacobians ``Jv``, ``Jw`` and orientation ``R``.
        """
        return self._inertias.mass_matrix(q)
