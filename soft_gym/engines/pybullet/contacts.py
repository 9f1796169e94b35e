"""Switching the arm's PyBullet contact detection off while nothing can touch it.

The arm never collides with itself, so while it is alone (no other body with a collision shape:
no obstacle, and the camera's scene, which is visual only unless built with ``collide=True``)
PyBullet's broadphase and narrowphase find nothing, yet cost 2.5-10 % of a ground-truth step
(docs/architecture.md, "Where a step's time goes").
"""

from __future__ import annotations

import pybullet
from pybullet_utils import bullet_client


class ContactSwitch:
    """The arm's contact detection, on while another body can touch it.

    Args:
        client: the arm's ``BulletClient``.
        body_id: the arm's multibody.
        n_links: links of the multibody.

    Attributes:
        collider_links: the arm's links with a collision shape.
        on: whether their contact detection is on.
        body_count: bodies in the world at the last look (:meth:`sync`).
    """

    def __init__(self, client: bullet_client.BulletClient, body_id: int, n_links: int) -> None:
        self.client, self.body_id = client, body_id
        self.client_id = client._client  # for direct ``pybullet`` calls
        self.collider_links = [
            link for link in range(n_links) if client.getCollisionShapeData(body_id, link)]
        self.on = True
        self.body_count = 0

    def sync(self) -> None:
        """Switch the arm's contact detection off while nothing else in the world can touch it,
        and back on as soon as something can.

        Alone, the arm's links get an empty collision filter; otherwise they keep PyBullet's own
        for a dynamic link (group 1, every mask bit), and setting it again puts them back in the
        broadphase, which then meets every body added meanwhile
        (tests/soft_gym/engines/test_physics.py checks trajectories against detection kept on all
        along). The simulator looks at the world whole
        at every ``step_physics`` call (PyBullet reuses a removed body's id, so no cheaper key
        tells a visual body from a collidable one that took its place; 1-2 us a body, 48 us in a
        camera env's 34-body world), and again at an actuation update when a load changed the
        number of bodies (:attr:`body_count`).
        """
        client_id = self.client_id
        count = self.body_count = pybullet.getNumBodies(physicsClientId=client_id)
        bodies = (pybullet.getBodyUniqueId(index, physicsClientId=client_id)
                  for index in range(count))
        touchable = any(
            pybullet.getCollisionShapeData(uid, link, physicsClientId=client_id)
            for uid in bodies if uid != self.body_id
            for link in range(-1, pybullet.getNumJoints(uid, physicsClientId=client_id)))
        if touchable != self.on:
            group, mask = (1, -1) if touchable else (0, 0)
            for link in self.collider_links:
                self.client.setCollisionFilterGroupMask(self.body_id, link, group, mask)
            self.on = touchable
