"""Build a soft arm as one PyBullet multibody (no files written), from its
:class:`~soft_gym.robots.chain.Chain`.

Every sub-link of the chain becomes a multibody link behind its joint (revolute for the bending
and torsion joints, prismatic for the axial one); the body sub-links get the segment's collision
cylinder and visual. The builder sets no springs: :class:`soft_gym.engines.pybullet.simulator.
ArmSimulator` turns the chain's compliances into joint torques every substep with a
semi-implicit (stable-PD) update, with the pressure moment entering as the rest angle
``q_rest = sum(M_seg * compliance_part)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import pybullet

from soft_gym.robots.chain import AXIAL, BEND_X, BEND_Y, JOINT_AXES, TORSION, Chain, build_chain
from soft_gym.robots.spec import ArmSpec, SegmentSpec

__all__ = ["AXIAL", "BEND_X", "BEND_Y", "TORSION", "ArmBody", "build_arm",
           "THREAD_CONSTRAINT_MARGIN"]

THREAD_CONSTRAINT_MARGIN = 50.0
"""PyBullet's limit constraint of a threaded axial joint sits this many thread bands past the
thread's length (0.1 of the link's rest length): the thread's stiff stop holds the joint long
before it, and a constraint acting at the stop itself would fight the stop's spring."""


@dataclass
class ArmBody(Chain):
    """The chain of an arm built in a PyBullet client, with its multibody's id.

    Joint arrays are indexed by the multibody's joint index (0..n_joints-1), which is the
    chain's joint index.
    """

    body_id: int = -1


def _segment_shapes(client: pybullet, segment: SegmentSpec,
                    rgba: tuple[float, float, float, float]) -> tuple[int, int]:
    """Collision and visual cylinder of the segment's links (ids in ``client``).

    The collision cylinder spans the link's rest length ``ds`` (m) from its joint. The axial
    joint slides a link's body away from its joint by up to ``stretch``: the visual reaches back
    by that much, so a stretched arm renders without gaps (at rest the extra length hides inside
    the previous link, or in the base mount for the first one).
    """
    ds = segment.link_length_m
    radius = segment.outer_radius_m
    cyl_col = client.createCollisionShape(pybullet.GEOM_CYLINDER, radius=radius, height=ds,
                                          collisionFramePosition=[0, 0, ds / 2])
    stretch = (segment.max_length_m / segment.length_m - 1.0) * ds
    cyl_vis = client.createVisualShape(pybullet.GEOM_CYLINDER, radius=radius,
                                       length=ds + stretch,
                                       visualFramePosition=[0, 0, (ds - stretch) / 2],
                                       rgbaColor=rgba)
    return cyl_col, cyl_vis


def _base_mount(client: pybullet, first: SegmentSpec) -> int:
    """Visual of the base mount (id in ``client``): a dark cylinder below the base, 1.3 times the
    first segment's radius, 4 mm deep plus the first link's stretch (m) so that the first link's
    visual hides in it at rest."""
    mount_m = 0.004 + (first.max_length_m / first.length_m - 1.0) * first.link_length_m
    return client.createVisualShape(pybullet.GEOM_CYLINDER,
                                    radius=first.outer_radius_m * 1.3,
                                    length=mount_m, visualFramePosition=[0, 0, -mount_m / 2],
                                    rgbaColor=[0.3, 0.3, 0.3, 1])


def _create_multibody(client: pybullet, chain: Chain, shapes: list[tuple[int, int]],
                      base_visual: int) -> int:
    """The arm's multibody (id in ``client``): a massless fixed base at the origin carrying
    ``base_visual``, and the chain's sub-links as a chain in reduced coordinates, the body
    sub-links with their segment's ``shapes`` (collision, visual)."""
    links = chain.sub_links
    n = len(links.masses)
    collision = [shapes[links.segments[i]][0] if links.is_body(i) else -1 for i in range(n)]
    visual = [shapes[links.segments[i]][1] if links.is_body(i) else -1 for i in range(n)]
    joint_types = [pybullet.JOINT_PRISMATIC if kind == AXIAL else pybullet.JOINT_REVOLUTE
                   for kind in links.kinds]
    return client.createMultiBody(
        baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=base_visual,
        basePosition=[0, 0, 0], baseOrientation=[0, 0, 0, 1],
        linkMasses=links.masses, linkCollisionShapeIndices=collision,
        linkVisualShapeIndices=visual, linkPositions=links.positions,
        linkOrientations=[[0, 0, 0, 1]] * n, linkInertialFramePositions=links.inertial_positions,
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=links.parents,
        linkJointTypes=joint_types, linkJointAxis=[JOINT_AXES[kind] for kind in links.kinds],
        useMaximalCoordinates=False)


def _set_joint_dynamics(client: pybullet, body: int, chain: Chain) -> None:
    """Give every link its principal inertia (kg m^2), no PyBullet damping and its joint limits,
    and free the default velocity motors so only the simulator's spring torques act.

    PyBullet's own limit constraint stays behind the end stops; a thread is taut just past its
    limit (EndStops), so its joint gets that constraint further out
    (``THREAD_CONSTRAINT_MARGIN`` thread bands), where it never acts.
    """
    inertias = chain.sub_links.inertias
    n = len(inertias)
    bullet_upper = chain.upper_limit + THREAD_CONSTRAINT_MARGIN * chain.thread_band
    for i in range(n):
        client.changeDynamics(body, i, localInertiaDiagonal=inertias[i], linearDamping=0.0,
                              angularDamping=0.0, jointDamping=0.0,
                              jointLowerLimit=float(chain.lower_limit[i]),
                              jointUpperLimit=float(bullet_upper[i]), lateralFriction=0.8)
    client.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0)
    client.setJointMotorControlArray(body, list(range(n)), pybullet.VELOCITY_CONTROL,
                                     forces=[0.0] * n)


def build_arm(client: pybullet, spec: ArmSpec, rgba: tuple[float, float, float, float]
              = (0.95, 0.55, 0.25, 1.0)) -> ArmBody:
    """Create the multibody for ``spec`` in ``client`` (a BulletClient) with its base at the origin.

    The PyBullet world frame *is* the arm's base frame (docs/architecture.md, "Frames and mounts");
    gravity is set by the simulator from the mount.
    """
    chain = build_chain(spec)
    shapes = [_segment_shapes(client, segment, rgba) for segment in spec.segments]
    base_visual = _base_mount(client, spec.segments[0])
    body = _create_multibody(client, chain, shapes, base_visual)
    _set_joint_dynamics(client, body, chain)
    return ArmBody(**{name: getattr(chain, name) for name in chain.__dataclass_fields__},
                   body_id=body)
