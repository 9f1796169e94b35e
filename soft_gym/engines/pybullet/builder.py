"""Build a soft arm as one PyBullet multibody (no files written).

Each segment of length ``L`` is cut into ``n`` rigid links of rest length ``ds = L / n``. A link is
reached from its parent through a *station* of joints at its proximal end:

    revolute about local x -> revolute about local y -> [revolute about z (torsion)] -> prismatic z

(every other station bends about y first, then x: see the comment in :func:`build_arm`).

The first three carry (almost) no mass; the prismatic sub-link carries the link's mass, collision
cylinder and visual. The station joints are the discrete elastic beam: bending joint compliance
``ds / (E I)`` (half of that at a segment's base and end, so the link vertices lie exactly on the
constant-curvature arc of a pure moment), axial compliance ``ds / (E A)``, torsion ``ds / (G J)``.

The builder only records each joint's compliance, its share of each segment's pressure load,
stiffening, damping and limits; :class:`soft_gym.engines.pybullet.simulator.ArmSimulator` turns them into joint torques
every substep with a semi-implicit (stable-PD) update, with the pressure moment entering as the
rest angle ``q_rest = sum(M_seg * compliance_part)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet

from soft_gym.robots.spec import ArmSpec
from soft_gym.robots.stops import THREAD_BAND_FRACTION

BEND_X, BEND_Y, TORSION, AXIAL = 0, 1, 2, 3
"""Joint kinds inside a station."""

THREAD_CONSTRAINT_MARGIN = 50.0
"""PyBullet's limit constraint of a threaded axial joint sits this many thread bands past the
thread's length (0.1 of the link's rest length): the thread's stiff stop holds the joint long
before it, and a constraint acting at the stop itself would fight the stop's spring."""

_MASSLESS_FRACTION = 0.02
"""Share of a link's mass placed on each of the joint-only sub-links (Featherstone needs > 0)."""


@dataclass
class ArmBody:
    """Handles and per-joint constants of an arm built in a PyBullet client.

    Joint arrays are indexed by the multibody's joint index (0..n_joints-1).
    """

    body_id: int
    joint_kind: np.ndarray          # (n_joints,) BEND_X / BEND_Y / TORSION / AXIAL
    joint_station: np.ndarray       # (n_joints,) global station (link) index
    compliance_parts: np.ndarray    # (n_joints, n_segments) compliance owed to each segment's load
    compliance: np.ndarray          # (n_joints,) total compliance (rad/(N m) or m/N)
    local_inertia: np.ndarray       # (n_joints,) inertia seen locally (kg m^2 or kg)
    stiffening: np.ndarray          # (n_joints,) beta of the secant stiffening
    strain_scale: np.ndarray        # (n_joints,) q * strain_scale = strain measure for stiffening
    damping_time_s: np.ndarray      # (n_joints,) stiffness-proportional damping c / k (s)
    lower_limit: np.ndarray
    upper_limit: np.ndarray         # (n_joints,) >= 0 for a threaded axial joint, else > 0
    thread_band: np.ndarray         # (n_joints,) > 0 where the upper stop is a thread (m)
    station_link: np.ndarray        # (n_stations,) multibody link index carrying each link's mass
    station_segment: np.ndarray     # (n_stations,) segment owning each link
    station_rest_length: np.ndarray  # (n_stations,) ds of each link (m)
    station_bend_joints: np.ndarray  # (n_stations, 2) joint indices of (bend x, bend y)
    station_y_first: np.ndarray     # (n_stations,) True where the station bends about y first
    station_axial_joint: np.ndarray  # (n_stations,)
    station_torsion_joint: np.ndarray  # (n_stations,) -1 where no torsion joint

    @property
    def n_joints(self) -> int:
        return len(self.joint_kind)

    @property
    def tip_link(self) -> int:
        return int(self.station_link[-1])


def _cylinder_inertia(mass: float, radius: float, length: float) -> list[float]:
    """Principal inertia of a solid cylinder along z about its centre (kg m^2)."""
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    return [transverse, transverse, 0.5 * mass * radius**2]


def build_arm(client: pybullet, spec: ArmSpec, rgba: tuple[float, float, float, float]
              = (0.95, 0.55, 0.25, 1.0)) -> ArmBody:
    """Create the multibody for ``spec`` in ``client`` (a BulletClient) with its base at the origin.

    The PyBullet world frame *is* the arm's base frame (docs/architecture.md, "Frames and mounts");
    gravity is set by the
    simulator from the mount.
    """
    link_masses, collision, visual, positions, inertial_positions, parents, joint_types, axes = (
        [], [], [], [], [], [], [], [])
    inertias = []
    kind, station_of_joint, parts, local_inertia, beta, strain_scale, zeta = [], [], [], [], [], [], []
    lower, upper, thread_band = [], [], []
    station_link, station_segment, station_length = [], [], []
    bend_joints, axial_joints, torsion_joints, y_first = [], [], [], []

    n_seg = spec.n_segments
    station = 0
    parent = 0  # multibody parent index: 0 is the base, link i is i + 1
    for k, segment in enumerate(spec.segments):
        ds = segment.link_length_m
        radius = segment.outer_radius_m
        ei, ea, gj = (segment.bending_rigidity_nm2, segment.axial_rigidity_n,
                      segment.torsional_rigidity_nm2)
        link_mass = segment.mass_kg / segment.n_links
        cyl_col = client.createCollisionShape(pybullet.GEOM_CYLINDER, radius=radius, height=ds,
                                              collisionFramePosition=[0, 0, ds / 2])
        # The axial joint slides a link's body away from its joint by up to ``stretch``: the
        # visual reaches back by that much, so a stretched arm renders without gaps (at rest the
        # extra length hides inside the previous link, or in the base mount for the first one)
        stretch = (segment.max_length_m / segment.length_m - 1.0) * ds
        cyl_vis = client.createVisualShape(pybullet.GEOM_CYLINDER, radius=radius,
                                           length=ds + stretch,
                                           visualFramePosition=[0, 0, (ds - stretch) / 2],
                                           rgbaColor=rgba)
        for j in range(segment.n_links):
            # Alternate the order of the two bending joints from link to link: Rx(a) Ry(b) twists
            # the link by about +ab/2 about its axis and Ry(b) Rx(a) by -ab/2, so alternating
            # cancels the parametrisation's twist instead of letting it accumulate along the arm.
            bend_pair = [BEND_X, BEND_Y] if station % 2 == 0 else [BEND_Y, BEND_X]
            kinds = bend_pair + ([TORSION] if segment.torsion else []) + [AXIAL]
            sub_joints = {}
            for sub, joint_kind in enumerate(kinds):
                is_body = joint_kind == AXIAL
                offset = 0.0
                if sub == 0 and station > 0:
                    offset = station_length[-1]  # previous link's rest length
                mass = link_mass * (1 - _MASSLESS_FRACTION * (len(kinds) - 1)) if is_body else (
                    link_mass * _MASSLESS_FRACTION)
                com = [0, 0, ds / 2] if is_body else [0, 0, 0]
                inertia = _cylinder_inertia(mass, radius, ds) if is_body else [
                    mass * radius**2 / 4] * 3
                extra = segment.extra_tip_mass_kg if (is_body and j == segment.n_links - 1) else 0.0
                if extra > 0:
                    # tip cap: a point mass at the link's distal end, lumped with the link
                    total = mass + extra
                    com_z = (mass * ds / 2 + extra * ds) / total
                    shift = mass * (ds / 2 - com_z) ** 2 + extra * (ds - com_z) ** 2
                    inertia = [inertia[0] + shift, inertia[1] + shift, inertia[2]]
                    mass, com = total, [0, 0, com_z]
                link_masses.append(mass)
                inertias.append(inertia)
                collision.append(cyl_col if is_body else -1)
                visual.append(cyl_vis if is_body else -1)
                positions.append([0, 0, offset])
                inertial_positions.append(com)
                parents.append(parent)
                joint_types.append(pybullet.JOINT_PRISMATIC if is_body else pybullet.JOINT_REVOLUTE)
                axes.append({BEND_X: [1, 0, 0], BEND_Y: [0, 1, 0], TORSION: [0, 0, 1],
                             AXIAL: [0, 0, 1]}[joint_kind])
                joint_index = len(link_masses) - 1
                parent = joint_index + 1
                sub_joints[joint_kind] = joint_index

                # --- spring constants of this joint ---------------------------------------------
                part = np.zeros(n_seg)
                if joint_kind in (BEND_X, BEND_Y):
                    if j == 0:
                        part[k] += ds / (2 * ei)
                        if k > 0:
                            prev = spec.segments[k - 1]
                            part[k - 1] += prev.link_length_m / (2 * prev.bending_rigidity_nm2)
                    else:
                        part[k] += ds / ei
                    local = link_mass * (ds**2 / 3 + radius**2 / 4)
                    scale = radius / ds  # q / ds = curvature; times R = surface strain
                    limit = segment.max_bend_per_m_rad * ds
                    lo, hi, b = -limit, limit, segment.bending_stiffening
                elif joint_kind == TORSION:
                    part[k] += ds / gj
                    local = link_mass * radius**2 / 2
                    scale, lo, hi, b = radius / ds, -0.5, 0.5, 0.0
                else:
                    part[k] += ds / ea
                    local = link_mass
                    scale = 1.0 / ds
                    # a thread (SegmentSpec.thread_length_m) stops lengthening at its length;
                    # shortening keeps the material's range
                    lo, hi = -0.4 * ds, segment.max_length_m / segment.n_links - ds
                    b = segment.axial_stiffening
                threaded = joint_kind == AXIAL and segment.thread_length_m is not None
                thread_band.append(THREAD_BAND_FRACTION * ds if threaded else 0.0)
                kind.append(joint_kind)
                station_of_joint.append(station)
                parts.append(part)
                local_inertia.append(local)
                beta.append(b)
                strain_scale.append(scale)
                zeta.append(spec.damping_time_s(segment))
                lower.append(lo)
                upper.append(hi)
            station_link.append(sub_joints[AXIAL])
            station_segment.append(k)
            station_length.append(ds)
            bend_joints.append([sub_joints[BEND_X], sub_joints[BEND_Y]])
            y_first.append(bend_pair[0] == BEND_Y)
            axial_joints.append(sub_joints[AXIAL])
            torsion_joints.append(sub_joints.get(TORSION, -1))
            station += 1

    first = spec.segments[0]
    mount_m = 0.004 + (first.max_length_m / first.length_m - 1.0) * first.link_length_m
    base_visual = client.createVisualShape(pybullet.GEOM_CYLINDER,
                                           radius=first.outer_radius_m * 1.3,
                                           length=mount_m, visualFramePosition=[0, 0, -mount_m / 2],
                                           rgbaColor=[0.3, 0.3, 0.3, 1])
    n = len(link_masses)
    body = client.createMultiBody(
        baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=base_visual,
        basePosition=[0, 0, 0], baseOrientation=[0, 0, 0, 1],
        linkMasses=link_masses, linkCollisionShapeIndices=collision,
        linkVisualShapeIndices=visual, linkPositions=positions,
        linkOrientations=[[0, 0, 0, 1]] * n, linkInertialFramePositions=inertial_positions,
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=parents,
        linkJointTypes=joint_types, linkJointAxis=axes, useMaximalCoordinates=False)
    # PyBullet's own limit constraint stays behind the end stops; a thread is taut just past its
    # limit (EndStops), so its joint gets that constraint further out, where it never acts
    bullet_upper = np.array(upper) + THREAD_CONSTRAINT_MARGIN * np.array(thread_band)
    for i in range(n):
        client.changeDynamics(body, i, localInertiaDiagonal=inertias[i], linearDamping=0.0,
                              angularDamping=0.0, jointDamping=0.0, jointLowerLimit=lower[i],
                              jointUpperLimit=float(bullet_upper[i]), lateralFriction=0.8)
    client.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0)
    # free the default velocity motors so only the spring motors act
    client.setJointMotorControlArray(body, list(range(n)), pybullet.VELOCITY_CONTROL,
                                     forces=[0.0] * n)
    compliance_parts = np.array(parts)
    return ArmBody(
        body_id=body, joint_kind=np.array(kind), joint_station=np.array(station_of_joint),
        compliance_parts=compliance_parts, compliance=compliance_parts.sum(axis=1),
        local_inertia=np.array(local_inertia), stiffening=np.array(beta),
        strain_scale=np.array(strain_scale), damping_time_s=np.array(zeta),
        lower_limit=np.array(lower), upper_limit=np.array(upper),
        thread_band=np.array(thread_band),
        station_link=np.array(station_link), station_segment=np.array(station_segment),
        station_rest_length=np.array(station_length), station_bend_joints=np.array(bend_joints),
        station_y_first=np.array(y_first),
        station_axial_joint=np.array(axial_joints), station_torsion_joint=np.array(torsion_joints))
