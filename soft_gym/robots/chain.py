"""The arm as a chain of rigid links and joint springs, independent of any physics engine.

Each segment of length ``L`` is cut into ``n`` rigid links of rest length ``ds = L / n``. A link is
reached from its parent through a *station* of joints at its proximal end:

    revolute about local x -> revolute about local y -> [revolute about z (torsion)] -> prismatic z

(every other station bends about y first, then x: see :func:`_station_joint_kinds`).

The first three carry (almost) no mass; the prismatic sub-link carries the link's mass. The
station joints are the discrete elastic beam: bending joint compliance ``ds / (E I)`` (half of that
at a segment's base and end, so the link vertices lie exactly on the constant-curvature arc of a
pure moment), axial compliance ``ds / (E A)``, torsion ``ds / (G J)``, each with the secant
strain stiffening ``k0 (1 + beta strain^2)``, stiffness-proportional damping and end stops
(:mod:`soft_gym.robots.stops`). The pressure moment enters as the rest deflection
``q_rest = sum(M_seg * compliance_part)`` (:func:`pressure_to_rest_matrix`).

Every engine builds its arm from one :class:`Chain` (docs/architecture.md, "The simulator
interface"), so the engines' bodies, masses, inertias and spring constants cannot drift apart:
``tests/soft_gym/engines/test_engine_agreement.py`` reads them back from both engines.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from soft_gym.robots.pneumatics import loads_of_effective_pressure, twist_of_effective_pressure
from soft_gym.robots.spec import ArmSpec, SegmentSpec
from soft_gym.robots.stops import (
    STOP_STIFFNESS_FACTOR,
    THREAD_BAND_FRACTION,
    THREAD_STIFFNESS_FACTOR,
    EndStops,
)

BEND_X, BEND_Y, TORSION, AXIAL = 0, 1, 2, 3
"""Joint kinds inside a station."""

MASSLESS_FRACTION = 0.02
"""Share of a link's mass placed on each of the joint-only sub-links (Featherstone needs > 0)."""

JOINT_AXES = {BEND_X: [1, 0, 0], BEND_Y: [0, 1, 0], TORSION: [0, 0, 1], AXIAL: [0, 0, 1]}
"""Joint axis of each joint kind, in the sub-link's frame."""


@dataclass
class SubLinks:
    """The chain's rigid bodies, one per joint (every sub-link of every station, base to tip).

    Sub-link ``i`` hangs from sub-link ``i - 1`` (the base for the first) through joint ``i``.
    """

    masses: list[float] = field(default_factory=list)                   # kg
    inertias: list[list[float]] = field(default_factory=list)           # kg m^2, principal
    positions: list[list[float]] = field(default_factory=list)          # m, joint in the parent
    inertial_positions: list[list[float]] = field(default_factory=list)  # m, centre of mass
    parents: list[int] = field(default_factory=list)                    # 0: base, i + 1: link i
    kinds: list[int] = field(default_factory=list)                      # joint kind
    segments: list[int] = field(default_factory=list)                   # owning segment

    def add(self, joint_kind: int, mass_kg: float, inertia_kg_m2: list[float],
            centre_of_mass_m: list[float], offset_m: float, segment: int) -> int:
        """Append the sub-link behind a ``joint_kind`` joint, ``offset_m`` (m) along its parent's
        z axis from the parent's joint, as the child of the link added last; its joint index."""
        parent = len(self.masses)  # the link added last (0, the base, for the first)
        self.masses.append(mass_kg)
        self.inertias.append(inertia_kg_m2)
        self.positions.append([0, 0, offset_m])
        self.inertial_positions.append(centre_of_mass_m)
        self.parents.append(parent)
        self.kinds.append(joint_kind)
        self.segments.append(segment)
        return len(self.masses) - 1

    def is_body(self, link: int) -> bool:
        """Whether sub-link ``link`` carries its link's body (mass, shape), not only a joint."""
        return self.kinds[link] == AXIAL


@dataclass
class Chain:
    """The per-joint and per-station constants of an arm (engine-independent).

    Joint arrays are indexed by joint (= sub-link) index 0..n_joints-1, stations by link.
    """

    sub_links: SubLinks
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
    station_link: np.ndarray        # (n_stations,) sub-link index carrying each link's mass
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

    def end_stops(self) -> EndStops:
        """The joints' end stops: material stops at ``STOP_STIFFNESS_FACTOR`` and threads at
        ``THREAD_STIFFNESS_FACTOR`` times each joint's small-strain stiffness."""
        threaded = self.thread_band > 0
        return EndStops(
            self.lower_limit, self.upper_limit,
            stiffness=np.where(threaded, THREAD_STIFFNESS_FACTOR, STOP_STIFFNESS_FACTOR)
            / self.compliance, thread_band=self.thread_band)


class _JointSpring(NamedTuple):
    """The spring constants of one joint (see :func:`_joint_spring`)."""

    compliance_parts: np.ndarray  # (n_segments,) rad/(N m) or m/N owed to each segment's load
    local_inertia: float          # kg m^2 or kg
    strain_scale: float           # strain per unit q: R / ds (1/rad), axial 1 / ds (1/m)
    lower: float                  # rad or m
    upper: float                  # rad or m
    stiffening: float             # beta of the secant stiffening


@dataclass
class _JointTable:
    """Per-joint constants of :class:`Chain`, collected joint by joint."""

    kind: list[int] = field(default_factory=list)
    station: list[int] = field(default_factory=list)
    parts: list[np.ndarray] = field(default_factory=list)
    local_inertia: list[float] = field(default_factory=list)
    stiffening: list[float] = field(default_factory=list)
    strain_scale: list[float] = field(default_factory=list)
    damping_time_s: list[float] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)
    thread_band: list[float] = field(default_factory=list)

    def add(self, spec: ArmSpec, k: int, j: int, station: int, joint_kind: int) -> None:
        """Append the ``joint_kind`` joint of link ``j`` of segment ``k`` (global ``station``)."""
        segment = spec.segments[k]
        ds = segment.link_length_m
        spring = _joint_spring(spec, k, j, joint_kind)
        threaded = joint_kind == AXIAL and segment.thread_length_m is not None
        self.thread_band.append(THREAD_BAND_FRACTION * ds if threaded else 0.0)
        self.kind.append(joint_kind)
        self.station.append(station)
        self.parts.append(spring.compliance_parts)
        self.local_inertia.append(spring.local_inertia)
        self.stiffening.append(spring.stiffening)
        self.strain_scale.append(spring.strain_scale)
        self.damping_time_s.append(spec.damping_time_s(segment))
        self.lower.append(spring.lower)
        self.upper.append(spring.upper)


@dataclass
class _StationTable:
    """Per-station (per-link) constants of :class:`Chain`, collected station by station."""

    link: list[int] = field(default_factory=list)
    segment: list[int] = field(default_factory=list)
    rest_length: list[float] = field(default_factory=list)
    bend_joints: list[list[int]] = field(default_factory=list)
    y_first: list[bool] = field(default_factory=list)
    axial_joint: list[int] = field(default_factory=list)
    torsion_joint: list[int] = field(default_factory=list)

    def add(self, k: int, ds: float, kinds: list[int], sub_joints: dict[int, int]) -> None:
        """Append a link of segment ``k`` with rest length ``ds`` (m), whose station has the joint
        ``kinds`` in order and ``sub_joints`` (kind -> joint index)."""
        self.link.append(sub_joints[AXIAL])
        self.segment.append(k)
        self.rest_length.append(ds)
        self.bend_joints.append([sub_joints[BEND_X], sub_joints[BEND_Y]])
        self.y_first.append(kinds[0] == BEND_Y)
        self.axial_joint.append(sub_joints[AXIAL])
        self.torsion_joint.append(sub_joints.get(TORSION, -1))


def cylinder_inertia(mass: float, radius: float, length: float) -> list[float]:
    """Principal inertia of a solid cylinder along z about its centre (kg m^2)."""
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    return [transverse, transverse, 0.5 * mass * radius**2]


def _station_joint_kinds(station: int, torsion: bool) -> list[int]:
    """Joint kinds of a station, proximal first: two bends, a torsion joint if ``torsion``, the
    axial joint.

    The order of the two bending joints alternates from link to link: Rx(a) Ry(b) twists the link
    by about +ab/2 about its axis and Ry(b) Rx(a) by -ab/2, so alternating cancels the
    parametrisation's twist instead of letting it accumulate along the arm.
    """
    bend_pair = [BEND_X, BEND_Y] if station % 2 == 0 else [BEND_Y, BEND_X]
    return bend_pair + ([TORSION] if torsion else []) + [AXIAL]


def _sub_link_inertial(segment: SegmentSpec, joint_kind: int, n_sub_links: int,
                       is_last_link: bool) -> tuple[float, list[float], list[float]]:
    """Mass (kg), principal inertia (kg m^2) and centre of mass (m, link frame) of the sub-link
    behind a ``joint_kind`` joint, in a station of ``n_sub_links`` sub-links.

    The axial (body) sub-link carries the link's mass as a solid cylinder, less
    ``MASSLESS_FRACTION`` of it for each joint-only sub-link; on the segment's last link it also
    carries the segment's ``extra_tip_mass_kg`` as a point mass at its distal end (a tip cap).
    """
    ds = segment.link_length_m
    radius = segment.outer_radius_m
    link_mass = segment.mass_kg / segment.n_links
    is_body = joint_kind == AXIAL
    mass = link_mass * (1 - MASSLESS_FRACTION * (n_sub_links - 1)) if is_body else (
        link_mass * MASSLESS_FRACTION)
    com = [0, 0, ds / 2] if is_body else [0, 0, 0]
    inertia = cylinder_inertia(mass, radius, ds) if is_body else [mass * radius**2 / 4] * 3
    extra = segment.extra_tip_mass_kg if (is_body and is_last_link) else 0.0
    if extra > 0:
        # tip cap: a point mass at the link's distal end, lumped with the link
        total = mass + extra
        com_z = (mass * ds / 2 + extra * ds) / total
        shift = mass * (ds / 2 - com_z) ** 2 + extra * (ds - com_z) ** 2
        inertia = [inertia[0] + shift, inertia[1] + shift, inertia[2]]
        mass, com = total, [0, 0, com_z]
    return mass, inertia, com


def _joint_spring(spec: ArmSpec, k: int, j: int, joint_kind: int) -> _JointSpring:
    """Spring constants of the ``joint_kind`` joint at link ``j`` of segment ``k``.

    Compliance: bending ``ds / (E I)`` (rad/(N m); half of it at a segment's first joint, whose
    other half is owed to the previous segment's load), torsion ``ds / (G J)``, axial
    ``ds / (E A)`` (m/N). Limits: bending ``max_bend_per_m_rad * ds`` (rad), torsion 0.5 rad,
    axial from ``-0.4 ds`` (m) to the segment's longest link.
    """
    segment = spec.segments[k]
    ds = segment.link_length_m
    radius = segment.outer_radius_m
    ei, ea, gj = (segment.bending_rigidity_nm2, segment.axial_rigidity_n,
                  segment.torsional_rigidity_nm2)
    link_mass = segment.mass_kg / segment.n_links
    part = np.zeros(spec.n_segments)
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
    return _JointSpring(part, local, scale, lo, hi, b)


def _add_station(links: SubLinks, joints: _JointTable, stations: _StationTable,
                 spec: ArmSpec, k: int, j: int) -> None:
    """Add link ``j`` of segment ``k`` with its station of joints: the sub-links, their joints'
    spring constants, and the station's record. The first joint sits at the previous link's rest
    length along its axis (at the base for the first link)."""
    segment = spec.segments[k]
    station = len(stations.link)
    kinds = _station_joint_kinds(station, segment.torsion)
    sub_joints = {}
    for sub, joint_kind in enumerate(kinds):
        offset = 0.0
        if sub == 0 and station > 0:
            offset = stations.rest_length[-1]  # previous link's rest length
        mass, inertia, com = _sub_link_inertial(segment, joint_kind, len(kinds),
                                                j == segment.n_links - 1)
        sub_joints[joint_kind] = links.add(joint_kind, mass, inertia, com, offset, k)
        joints.add(spec, k, j, station, joint_kind)
    stations.add(k, segment.link_length_m, kinds, sub_joints)


def build_chain(spec: ArmSpec) -> Chain:
    """The chain of the arm ``spec``: its sub-links and every joint's and station's constants."""
    links, joints, stations = SubLinks(), _JointTable(), _StationTable()
    for k, segment in enumerate(spec.segments):
        for j in range(segment.n_links):
            _add_station(links, joints, stations, spec, k, j)
    compliance_parts = np.array(joints.parts)
    return Chain(
        sub_links=links, joint_kind=np.array(joints.kind),
        joint_station=np.array(joints.station),
        compliance_parts=compliance_parts, compliance=compliance_parts.sum(axis=1),
        local_inertia=np.array(joints.local_inertia), stiffening=np.array(joints.stiffening),
        strain_scale=np.array(joints.strain_scale),
        damping_time_s=np.array(joints.damping_time_s),
        lower_limit=np.array(joints.lower), upper_limit=np.array(joints.upper),
        thread_band=np.array(joints.thread_band),
        station_link=np.array(stations.link), station_segment=np.array(stations.segment),
        station_rest_length=np.array(stations.rest_length),
        station_bend_joints=np.array(stations.bend_joints),
        station_y_first=np.array(stations.y_first),
        station_axial_joint=np.array(stations.axial_joint),
        station_torsion_joint=np.array(stations.torsion_joint))


def pressure_to_rest_matrix(spec: ArmSpec, chain: Chain) -> np.ndarray:
    """Matrix (n_joints, n_chambers) from effective chamber pressures (Pa,
    :func:`~soft_gym.robots.pneumatics.effective_pressure_pa`) to each joint's rest
    deflection (rad or m) under the small-strain compliance (the effective pressure -> load map
    is linear): ``q_rest = sum(M_seg * compliance_part)``."""
    columns = []
    for chamber in range(spec.n_chambers):
        unit = np.zeros(spec.n_chambers)
        unit[chamber] = 1.0
        axial, moment = loads_of_effective_pressure(spec, unit)
        twist = twist_of_effective_pressure(spec, unit)
        per_kind = np.stack([moment[:, 0], moment[:, 1], twist, axial], axis=1)
        columns.append((chain.compliance_parts * per_kind[:, chain.joint_kind].T).sum(axis=1))
    return np.stack(columns, axis=1)


def weightless_equilibrium(rest: np.ndarray, chain: Chain) -> np.ndarray:
    """Joint positions (rad or m) where the springs balance the pressure load alone: per joint
    the real root of ``q (1 + beta (s q)^2) = q_rest`` (the secant stiffening, ``s`` the strain
    scale), kept inside 98 % of the joint's limits.

    Args:
        rest: the rest deflection ``q_rest`` of every joint (rad or m), shape (n_joints,).
        chain: the arm's chain (stiffening, strain scales, limits).
    """
    a = chain.stiffening * chain.strain_scale ** 2
    q = rest.copy()
    stiff = a > 0
    if np.any(stiff):
        # Cardano for q^3 + q / a - rest / a = 0, which has one real root (increasing)
        p3 = 1.0 / (3.0 * a[stiff])
        half = 0.5 * rest[stiff] / a[stiff]
        root = np.sqrt(half ** 2 + p3 ** 3)
        q[stiff] = np.cbrt(half + root) + np.cbrt(half - root)
    return np.clip(q, 0.98 * chain.lower_limit, 0.98 * chain.upper_limit)
