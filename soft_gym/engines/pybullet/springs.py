"""The joint springs of the arm: pressure rest deflections, stiffness and the semi-implicit gains.

Every joint of the discrete beam (:mod:`soft_gym.robots.chain`) is a spring with the
secant stiffness ``K(q) = k0 (1 + beta strain^2)`` (``k0`` the inverse of its compliance), its
end stops (:class:`~soft_gym.robots.stops.EndStops`) and stiffness-proportional damping. The
chamber pressures enter as a rest deflection ``q_rest`` linear in the effective pressures
(:func:`~soft_gym.robots.chain.pressure_to_rest_matrix`). The
simulator (:class:`~soft_gym.engines.pybullet.simulator.ArmSimulator`) turns these into joint
torques every substep with the gains of :class:`SpringGains` (docs/architecture.md,
"Semi-implicit joint springs").
"""

from __future__ import annotations

import numpy as np

from soft_gym.robots.chain import Chain
from soft_gym.robots.stops import EndStops

_IMPLICIT_FRACTION = 0.25
"""``theta`` of the semi-implicit spring update (see :meth:`SpringGains.update`)."""

STIFFNESS_MARGIN = 1.25
"""Factor on the tangent stiffness used in the implicit term, so it stays ahead of stiffening."""


def tangent_stiffness_at(q: np.ndarray, stiffness0: np.ndarray, stiffening: bool,
                         arm: Chain, stops: EndStops) -> np.ndarray:
    """Tangent stiffness of every joint at ``q`` (N m/rad or N/m): ``k0 (1 + 3 beta strain^2)``
    (only ``k0`` unless ``stiffening``) plus the end stops'
    (:class:`~soft_gym.robots.stops.EndStops`), a thread about to go taut counted as taut
    (:meth:`~soft_gym.robots.stops.EndStops.implicit_stiffness_at`)."""
    tangent = stiffness0
    if stiffening:
        strain_squared = (q * arm.strain_scale) ** 2
        tangent = stiffness0 * (1.0 + 3.0 * arm.stiffening * strain_squared)
    return tangent + stops.implicit_stiffness_at(q)


class SpringGains:
    """Gains of the semi-implicit spring update, as the substep loop applies them.

    The joint torque of a substep is ``torque_gain @ state + torque_offset``, where ``state`` is
    ``[K(q) q, v, v_previous, torque_previous]`` (4 n_joints) and the offset
    ``solve @ (k0 q_rest)`` is the simulator's; held external forces add
    ``solve @ tau_external``.

    Args:
        n_joints: joints of the arm.

    Attributes:
        torque_gain: (n_joints, 4 n_joints), written in place by :meth:`update`.
        solve: ``S = (I + h D' M^-1)^-1`` (n_joints, n_joints), replaced by :meth:`update`.
        implicit_stiffness: the stiffness ``K`` (N m/rad or N/m) in the implicit term, per joint.
        gain_configuration: the joint positions (rad or m) the gains were computed at.
    """

    def __init__(self, n_joints: int) -> None:
        self.torque_gain = np.zeros((n_joints, 4 * n_joints))
        self.solve = np.eye(n_joints)
        self.implicit_stiffness = np.zeros(n_joints)
        self.gain_configuration = np.zeros(n_joints)

    def invalidate(self) -> None:
        """Force a refresh at the next actuation update (the stiffness or the masses changed)."""
        self.implicit_stiffness = np.zeros(len(self.implicit_stiffness))

    def update(self, q: np.ndarray, tangent_stiffness: np.ndarray, mass: np.ndarray, h: float,
               damping: np.ndarray, measured: bool) -> None:
        """Semi-implicit spring update (Newmark-like, a stable-PD form).

        The joint torque uses the end-of-substep velocity ``v+``:

            tau = K (q_rest - q - theta h v+) - D v+,   M (v+ - v) = h (tau + tau_other),

        solved for ``tau`` with the joint-space mass matrix ``M`` and the other generalised forces
        ``tau_other`` (gravity, Coriolis, contacts, constraints, external forces) measured from the
        previous substep's acceleration. With ``theta = 1/4`` the stiff link-local modes stay
        bounded at any step (their effective ``omega h`` is at most 2) while the slow modes see
        almost no numerical damping; at rest ``tau = K (q_rest - q)`` exactly, so static shapes do
        not depend on the step. ``D`` is the stiffness-proportional material damping. ``K`` in the
        implicit term is the tangent stiffness (with a margin), refreshed once per control period
        or sooner when stiffening outgrows it.

        Args:
            q: joint positions (rad or m), shape (n_joints,).
            tangent_stiffness: ``K`` of the implicit term (N m/rad or N/m), shape (n_joints,).
            mass: joint-space mass matrix ``M`` at ``q`` (kg, kg m, kg m^2).
            h: the (piece of) substep the gains are for (s).
            damping: ``D`` per joint (N m s/rad or N s/m), shape (n_joints,).
            measured: whether a previous substep measured ``tau_other`` (False just after a
                reset, a shape set by hand or a change of step).
        """
        stiffness = tangent_stiffness
        self.implicit_stiffness = tangent_stiffness
        self.gain_configuration = q.copy()
        velocity_gain = damping + _IMPLICIT_FRACTION * h * stiffness
        response = h * velocity_gain[:, None] * np.linalg.inv(mass)
        solve = np.linalg.inv(np.eye(len(q)) + response)
        other_gain = solve @ response
        other_from_velocity = other_gain @ mass / h
        n = len(q)
        # torque = S (k0 q_rest - K(q) q) - S D' v - G (M (v - v_prev) / h - tau_prev)
        gain = self.torque_gain
        gain[:, :n] = -solve
        gain[:, n:2 * n] = -solve * velocity_gain[None, :]
        if measured:
            gain[:, n:2 * n] -= other_from_velocity
            gain[:, 2 * n:3 * n] = other_from_velocity
            gain[:, 3 * n:] = other_gain
        else:  # just after a reset there is no previous substep to measure the other forces from
            gain[:, 2 * n:] = 0.0
        self.solve = solve
