"""The arm's link masses and inertias, and its joint-space mass matrix with their changes.

PyBullet builds the inverse-dynamics tree behind ``calculateMassMatrix`` on the first call and
never updates it when a link's mass changes later (docs/architecture.md, "Tip payloads and the
mass matrix"): :class:`LinkInertias` builds it from the nominal masses and adds every change on
top.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from pybullet_utils import bullet_client

from soft_gym._quaternion import quaternion_to_matrix


def read_link_inertia(client: bullet_client.BulletClient, body_id: int,
                      n_links: int) -> dict[int, tuple[float, np.ndarray]]:
    """Mass (kg) and principal inertia (kg m^2) of every link, as PyBullet holds them."""
    info = {link: client.getDynamicsInfo(body_id, link) for link in range(n_links)}
    return {link: (float(i[0]), np.array(i[2], dtype=float)) for link, i in info.items()}


class LinkInertias:
    """Masses and inertias of the arm's links, as built (nominal) and as changed since.

    Builds PyBullet's inverse-dynamics tree at once, from the nominal masses.

    Args:
        client: the arm's ``BulletClient``.
        body_id: the arm's multibody.
        n_links: links of the multibody (one per joint).
        on_change: called after every change of a link's mass or inertia (the simulator then
            refreshes its implicit gains, which hold the mass matrix).

    Attributes:
        nominal: link -> (mass (kg), principal inertia (kg m^2)) as built.
        changes: link -> (added mass (kg), added principal inertia (kg m^2)), for changed links.
        centre_of_mass: link -> its centre of mass in its own frame (m); PyBullet never moves it.
    """

    def __init__(self, client: bullet_client.BulletClient, body_id: int, n_links: int,
                 on_change: Callable[[], None]) -> None:
        self.client, self.body_id = client, body_id
        self.nominal = read_link_inertia(client, body_id, n_links)
        client.calculateMassMatrix(body_id, [0.0] * n_links)
        self.changes: dict[int, tuple[float, np.ndarray]] = {}
        self.centre_of_mass = {
            link: np.asarray(client.getDynamicsInfo(body_id, link)[3])
            for link in range(n_links)}
        self._on_change = on_change

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix (kg, kg m, kg m^2) at joint positions ``q`` (rad or m), with
        the links' current masses and inertias.

        PyBullet's ``calculateMassMatrix`` keeps the nominal masses; each changed link adds
        ``dm Jv^T Jv + Jw^T R dI R^T Jw`` with its centre-of-mass Jacobians ``Jv``, ``Jw`` and
        orientation ``R``.
        """
        body, positions = self.body_id, q.tolist()
        mass = np.array(self.client.calculateMassMatrix(body, positions))
        if self.changes:
            zeros = [0.0] * len(positions)
            for link, (added_mass, added_inertia) in self.changes.items():
                # the point is given in the link frame (not about the centre of mass)
                linear, angular = self.client.calculateJacobian(
                    body, link, self.centre_of_mass[link].tolist(), positions, zeros, zeros)
                jv, jw = np.asarray(linear), np.asarray(angular)
                rotation = quaternion_to_matrix(np.asarray(
                    self.client.getLinkState(body, link, computeForwardKinematics=1)[1]))
                world_inertia = (rotation * added_inertia) @ rotation.T
                mass += added_mass * jv.T @ jv + jw.T @ world_inertia @ jw
        return mass

    def set_link_inertia(self, link: int, mass_kg: float, inertia_kg_m2: np.ndarray) -> None:
        """Give ``link`` a mass (kg) and principal inertia (kg m^2); its centre of mass stays
        where it is."""
        nominal_mass, nominal_inertia = self.nominal[link]
        self.client.changeDynamics(self.body_id, link, mass=float(mass_kg),
                                   localInertiaDiagonal=np.asarray(inertia_kg_m2).tolist())
        added = (mass_kg - nominal_mass, np.asarray(inertia_kg_m2) - nominal_inertia)
        if added[0] == 0.0 and not np.any(added[1]):
            self.changes.pop(link, None)
        else:
            self.changes[link] = added
        self._on_change()

    def restore_nominal(self) -> None:
        """Give every changed link its nominal mass and inertia back."""
        for link in list(self.changes):
            self.set_link_inertia(link, *self.nominal[link])
