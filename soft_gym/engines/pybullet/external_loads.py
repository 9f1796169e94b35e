"""Loads held on the arm between physics substeps: external forces and the tip payload.

A held force (docs/architecture.md, "Held external forces") enters the joint torques through
the semi-implicit update as the generalised force ``tau = Jv^T F + Jw^T (r x F)``, evaluated at
each substep's own configuration. A tip payload (docs/architecture.md, "Tip payloads and the mass
matrix") is a point mass carried at the tip: the tip link's mass and inertia, and a held force
couple for its weight.
"""

from __future__ import annotations

import numpy as np
import pybullet
from pybullet_utils import bullet_client

from soft_gym._quaternion import quaternion_to_matrix
from soft_gym.engines.held_loads import HeldForceTable, carry_tip_payload, update_payload
from soft_gym.engines.pybullet.builder import ArmBody
from soft_gym.engines.pybullet.mass_matrix import LinkInertias


class HeldForces(HeldForceTable):
    """Forces held on the arm's links (:class:`~soft_gym.engines.held_loads.HeldForceTable`),
    turned into joint torques with PyBullet's Jacobians.

    Args:
        client: the arm's ``BulletClient``.
        arm: the built arm.
    """

    def __init__(self, client: bullet_client.BulletClient, arm: ArmBody) -> None:
        super().__init__(arm)
        self.client, self.arm = client, arm
        self.client_id = client._client  # for direct ``pybullet`` calls on the substep path

    def joint_torque(self, q: np.ndarray) -> np.ndarray:
        """Generalised force (N m or N per joint) of the held forces at ``q`` (rad or m).

        ``tau = Jv^T F + Jw^T (r x F)`` per link, with the Jacobians of the link frame's origin and
        ``r`` from that origin to the point of action. The simulator applies it through the
        semi-implicit update as part of the joint torque, evaluated at the substep's own
        configuration: measured after the fact like gravity (one substep late), a force of a few
        newtons on a light link makes the update unstable.
        """
        body, positions = self.arm.body_id, q.tolist()
        zeros = [0.0] * len(positions)
        per_link: dict[int, list] = {}
        for link, force, local_point in self.forces.values():
            per_link.setdefault(link, []).append((force, local_point))
        torque = np.zeros(len(positions))
        for link, held in per_link.items():
            rotation = self._link_rotation(link)
            force = sum(f for f, _ in held)
            moment = sum(cross3(rotation @ point, f) for f, point in held)
            linear, angular = pybullet.calculateJacobian(
                body, link, [0.0, 0.0, 0.0], positions, zeros, zeros,
                physicsClientId=self.client_id)
            torque += np.asarray(linear).T @ force + np.asarray(angular).T @ moment
        return torque

    def _link_rotation(self, link: int) -> np.ndarray:
        """Rotation matrix of ``link``'s frame (base frame) in the current state."""
        state = pybullet.getLinkState(self.arm.body_id, link, computeForwardKinematics=1,
                                      physicsClientId=self.client_id)
        return quaternion_to_matrix(state[5])


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of two 3-vectors, bit for bit (the same products and differences), without
    its general-case overhead (~1 us against ~25 us; called every substep a force is held)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class TipPayload:
    """Point masses (kg) carried at the tip, by key; they add up.

    Args:
        arm: the built arm.
        inertias: the arm's link inertias (the tip link's mass and inertia follow the payload).
        forces: the arm's held forces (the payload's weight acts at the tip through them).

    Attributes:
        masses: key -> mass (kg), each > 0.
    """

    def __init__(self, arm: ArmBody, inertias: LinkInertias, forces: HeldForces) -> None:
        self.arm, self.inertias, self.forces = arm, inertias, forces
        self.masses: dict[str, float] = {}

    def set(self, key: str, mass_kg: float, gravity: np.ndarray) -> None:
        """Carry ``mass_kg`` (kg, >= 0; 0 removes the key) under ``key``, with ``gravity``
        (m/s^2, base frame); nothing changes if the key already carries that mass."""
        if update_payload(self.masses, key, mass_kg):
            self.apply(gravity)

    def apply(self, gravity: np.ndarray) -> None:
        """Put the sum of the payloads on the tip link: mass, inertia and weight at the tip
        (``gravity`` in m/s^2, base frame; :func:`~soft_gym.engines.held_loads.
        carry_tip_payload`)."""
        link = self.arm.tip_link
        payload = sum(self.masses.values())
        nominal_mass, nominal_inertia = self.inertias.nominal[link]
        added = carry_tip_payload(self.forces, self.inertias.centre_of_mass[link],
                                  self.arm.station_rest_length[-1], payload, gravity)
        self.inertias.set_link_inertia(link, nominal_mass + payload, nominal_inertia + added)
