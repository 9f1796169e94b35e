"""What every engine reads off the arm's chain the same way: tip pose, backbone, chamber lengths,
curvature, strains and twists from the joint positions and the link frames, and the divergence
guard.

An engine supplies the joint positions ``q`` (in the chain's joint order) and each link's frame
(origin, quaternion (x, y, z, w), rotation matrix, in the base frame); :class:`ChainReadout` does
the rest, so two engines in the same state report the same readings bit for bit
(docs/architecture.md, "The simulator interface").
"""

from __future__ import annotations

import numpy as np

from soft_gym._quaternion import axis_rotation, quaternion_multiply
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.robots.chain import BEND_X, BEND_Y, Chain
from soft_gym.robots.spec import ArmSpec

DIVERGED_PAST_LIMIT = 1.5
"""A joint this many times past its limit means the integration diverged (the end stops hold
every load the arm accepts within 1.1 times, ``tests/soft_gym/engines/test_runaway.py``)."""


class PhysicsDivergedError(RuntimeError):
    """The simulation left the physical range (a joint far past its end stop)."""


class ChainReadout:
    """Readings of the arm's chain from its joint positions and link frames.

    Args:
        spec: the arm.
        chain: its chain (:func:`soft_gym.robots.chain.build_chain`).
    """

    def __init__(self, spec: ArmSpec, chain: Chain) -> None:
        self.spec, self.chain = spec, chain
        self._kind = chain.joint_kind
        self._is_bend_x, self._is_bend_y = self._kind == BEND_X, self._kind == BEND_Y
        self._offsets = spec.chamber_offset_m[:, None]
        self._sin_sigma, self._cos_sigma = np.sin(CHAMBER_ANGLES_RAD), np.cos(CHAMBER_ANGLES_RAD)
        self._chamber_weights = self._segment_bend_weights()
        threaded = chain.thread_band > 0
        # a thread may stop a link at or near its rest length (upper limit 0 or tiny): judge
        # divergence of such a joint against its shortening range where that is larger
        self._inverse_upper = 1.0 / np.where(
            threaded, np.maximum(chain.upper_limit, -chain.lower_limit), chain.upper_limit)
        self._inverse_lower = 1.0 / chain.lower_limit
        rigidity = np.array([s.bending_rigidity_nm2 for s in spec.segments])
        self._bend_element = chain.compliance_parts[chain.station_bend_joints[:, 0]] @ rigidity

    def tip_pose(self, positions: np.ndarray, quaternions: np.ndarray, rotations: np.ndarray,
                 q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and orientation quaternion (x, y, z, w) in the base frame.

        The orientation is the last link's, continued by half of its proximal bending joint so
        that it approximates the tangent of the arc at the tip rather than at the link's middle.
        """
        chain = self.chain
        bx, by = chain.station_bend_joints[-1]
        half_x, half_y = axis_rotation(0, 0.5 * q[bx]), axis_rotation(1, 0.5 * q[by])
        half = (quaternion_multiply(half_y, half_x) if chain.station_y_first[-1]
                else quaternion_multiply(half_x, half_y))
        tip_quaternion = np.array(quaternion_multiply(tuple(quaternions[-1]), half))
        tip = positions[-1] + rotations[-1][:, 2] * chain.station_rest_length[-1]
        return tip, tip_quaternion / np.linalg.norm(tip_quaternion)

    def backbone(self, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """Backbone points (m, base frame): the base and every link's distal end, (n_links+1, 3)."""
        ends = positions + rotations[:, :, 2] * self.chain.station_rest_length[:, None]
        return np.vstack([np.zeros(3), ends])

    def chamber_lengths(self, q: np.ndarray) -> np.ndarray:
        """Chamber lengths (m), shape (n_chambers,), from each segment's arc length and bending.

        ``l_i = s + d (theta_x sin(sigma_i) - theta_y cos(sigma_i))`` with ``theta`` the segment's
        total bending rotation (consistent with :mod:`soft_gym.kinematics`).
        """
        arc, theta_x, theta_y = self._segment_arc_and_bend(q)
        lengths = arc[:, None] + self._offsets * (theta_x[:, None] * self._sin_sigma
                                                  - theta_y[:, None] * self._cos_sigma)
        return lengths.reshape(-1)

    def segment_bend_angles_rad(self, q: np.ndarray) -> np.ndarray:
        """Each segment's bending angle (rad, shape (n_segments,)): how far the backbone's
        tangent turns from the segment's base to its end, ``|(theta_x, theta_y)|`` of its bend
        joints (a joint at a segment boundary shared in proportion to the compliance each side
        owes it, the last segment with the half tip joint, as :meth:`chamber_lengths` reads
        them). For a constant-curvature segment this is the CC angle ``theta = kappa L``; it is
        how a paper's "bending angle per segment" is read here. Where neighbouring segments bend
        in different planes, the joint they share holds both bends and its split mixes them, so
        each angle is then approximate (9 % low for two 0.19 rad bends 120 deg apart)."""
        _, theta_x, theta_y = self._segment_arc_and_bend(q)
        return np.hypot(theta_x, theta_y)

    def curvature_profile(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Backbone curvature at every vertex, for sensors that integrate strain along the arm.

        Returns:
            ``(arc_m, curvature)``: arc position of each backbone vertex from the base (m, current
            lengths), shape (n_links + 1,), and the curvature vector ``(kx, ky)`` there (1/m),
            shape (n_links + 1, 2). Each joint's bend ``theta`` is spread over the rest length
            it stands for (half a link at a segment's ends, a link inside), so a pure moment
            gives ``kappa = M / (E I)`` at every vertex. The tip vertex repeats the last joint's
            curvature (the half joint that continues the arc, see :meth:`tip_pose`). Between
            vertices, linear interpolation is the natural reading.
        """
        chain = self.chain
        bend = q[chain.station_bend_joints]                     # (n_links, 2): theta_x, theta_y
        curvature = np.stack([bend[:, 1], -bend[:, 0]], axis=1) / self._bend_element[:, None]
        link_lengths = chain.station_rest_length + q[chain.station_axial_joint]
        arc = np.r_[0.0, np.cumsum(link_lengths)]
        return arc, np.vstack([curvature, curvature[-1:]])

    def link_axial_strains(self, q: np.ndarray) -> np.ndarray:
        """Axial strain of every link (extension over rest length), shape (n_links,)."""
        return q[self.chain.station_axial_joint] / self.chain.station_rest_length

    def link_twists(self, q: np.ndarray) -> np.ndarray:
        """Twist angle of each link's torsion joint (rad), zeros without torsion joints."""
        idx = self.chain.station_torsion_joint
        return np.where(idx >= 0, q[np.maximum(idx, 0)], 0.0)

    def check_within_stops(self, q: np.ndarray, time_s: float, loads: list) -> None:
        """Raise :class:`PhysicsDivergedError` if a joint has gone far past its end stop: the
        simulation has diverged, and its states must not reach an observation or a training
        batch."""
        past = np.maximum(q * self._inverse_upper, q * self._inverse_lower)
        worst = int(np.argmax(past))
        if past[worst] > DIVERGED_PAST_LIMIT:
            raise PhysicsDivergedError(
                f"joint {worst} of the {self.spec.name} arm is at {past[worst]:.1f} times its "
                f"limit at t = {time_s:.3f} s with loads {loads!r}: the simulation diverged")

    def _segment_bend_weights(self) -> np.ndarray:
        """Weights (n_segments, n_joints) turning joint angles into each segment's total bending.

        A joint at a segment boundary is shared in proportion to the compliance each side owes it;
        the last segment also gets the half tip joint (see :meth:`tip_pose`).
        """
        parts = self.chain.compliance_parts
        weights = (parts / parts.sum(axis=1, keepdims=True)).T.copy()
        bend = np.isin(self._kind, (BEND_X, BEND_Y))
        weights[:, ~bend] = 0.0
        weights[-1, self.chain.station_bend_joints[-1]] += 0.5
        return weights

    def _segment_arc_and_bend(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        chain = self.chain
        # bincount adds each station's length into its segment in order, as np.add.at does
        arc = np.bincount(chain.station_segment,
                          chain.station_rest_length + q[chain.station_axial_joint],
                          minlength=self.spec.n_segments)
        qx = np.where(self._is_bend_x, q, 0.0)
        qy = np.where(self._is_bend_y, q, 0.0)
        return arc, self._chamber_weights @ qx, self._chamber_weights @ qy
