"""Static equilibrium of the arm's chain without a physics engine.

The chain (:mod:`soft_gym.robots.chain`) at rest balances, joint by joint,

    k0 q_rest(p) - K(q) q - f_stop(q) + tau_g(q) = 0,

the spring with its secant stiffening ``K(q) = k0 (1 + beta (s q)^2)``, the pressure load as the
rest deflection ``q_rest`` (linear in the effective pressures), the end stops
(:class:`~soft_gym.robots.stops.EndStops`) and the generalised force ``tau_g`` of gravity on
every sub-link and of a weight hung at the tip. That is what both engines settle to, since their
semi-implicit springs give ``tau = k0 q_rest - K(q) q`` exactly at rest (docs/architecture.md,
"Semi-implicit joint springs"); :class:`StaticArm` finds it directly, by Newton's method on the
potential energy, in milliseconds instead of seconds of simulated settling. The arm's
calibration to a paper's poses and reach (:mod:`soft_gym.papers.zhao2021.arm_fit`) runs on
it; ``tests/soft_gym/robots/test_statics.py`` checks it against the settled PyBullet arm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soft_gym._validation import as_finite_array, require_non_negative
from soft_gym.robots.chain import AXIAL, BEND_X, BEND_Y, TORSION, build_chain, pressure_to_rest_matrix
from soft_gym.robots.pneumatics import check_pressures, effective_pressure_pa
from soft_gym.robots.spec import ArmSpec

_AXIS_INDEX = {BEND_X: 0, BEND_Y: 1, TORSION: 2}
_MAX_NEWTON_STEPS = 200


@dataclass(frozen=True)
class StaticState:
    """The arm at rest.

    Attributes:
        q: joint positions (rad or m), shape (n_joints,).
        tip_m: tip position (m, base frame), the last link's distal end.
        backbone_m: the base and every link's distal end (m, base frame), (n_links + 1, 3), as
            the simulators' ``backbone()``.
        residual_n: largest joint force or torque left unbalanced (N or N m).
    """

    q: np.ndarray
    tip_m: np.ndarray
    backbone_m: np.ndarray
    residual_n: float


class StaticArm:
    """Rest shapes of an arm under held pressures, gravity and a tip weight.

    Args:
        spec: the arm (its mount sets gravity, ``spec.gravity_base``).
    """

    def __init__(self, spec: ArmSpec) -> None:
        self.spec = spec
        self.chain = chain = build_chain(spec)
        self.stiffness0 = 1.0 / chain.compliance
        self.stops = chain.end_stops()
        self.rest_matrix = pressure_to_rest_matrix(spec, chain)
        self.gravity = spec.gravity_base.copy()
        links = chain.sub_links
        self._offsets = np.array(links.positions, dtype=float)
        self._centres = np.array(links.inertial_positions, dtype=float)
        self._masses = np.array(links.masses, dtype=float)
        self._kinds = chain.joint_kind
        self._stiffening = chain.stiffening * chain.strain_scale ** 2
        start_low, band_low, start_high, band_high = self.stops.bands()
        self._stop_bands = (start_low, band_low, start_high, band_high)
        self._tip_length = float(chain.station_rest_length[-1])
        self._last_hessian: np.ndarray | None = None

    # ---------------------------------------------------------------- kinematics
    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Joint origins and axes (m, base frame; (n_joints, 3) each), and every sub-link's frame
        origin (m) and rotation after its joint ((n_joints, 3), (n_joints, 3, 3))."""
        n = len(q)
        origins, axes = np.empty((n, 3)), np.empty((n, 3))
        body, rotations = np.empty((n, 3)), np.empty((n, 3, 3))
        rotation, point = np.eye(3), np.zeros(3)
        for i in range(n):
            point = point + rotation @ self._offsets[i]
            origins[i] = point
            kind = self._kinds[i]
            if kind == AXIAL:
                axes[i] = rotation[:, 2]
                point = point + rotation[:, 2] * q[i]
            else:
                index = _AXIS_INDEX[kind]
                axes[i] = rotation[:, index]
                rotation = rotation @ _rotation(index, q[i])
            body[i], rotations[i] = point, rotation
        return origins, axes, body, rotations

    def backbone(self, q: np.ndarray) -> np.ndarray:
        """The base and every link's distal end (m, base frame), (n_links + 1, 3)."""
        _, _, body, rotations = self.frames(q)
        links = self.chain.station_link
        ends = body[links] + rotations[links][:, :, 2] * self.chain.station_rest_length[:, None]
        return np.vstack([np.zeros(3), ends])

    # ---------------------------------------------------------------- forces and energy
    def _external(self, q: np.ndarray, tip_force: np.ndarray) -> tuple[np.ndarray, float]:
        """Generalised force of gravity and the tip force on every joint, and their potential
        energy (J)."""
        origins, axes, body, rotations = self.frames(q)
        centres = body + np.einsum("nij,nj->ni", rotations, self._centres)
        forces = self._masses[:, None] * self.gravity[None, :]
        tip = body[-1] + rotations[-1][:, 2] * self._tip_length
        force_below = np.cumsum(forces[::-1], axis=0)[::-1] + tip_force
        moment_below = (np.cumsum(np.cross(centres, forces)[::-1], axis=0)[::-1]
                        + np.cross(tip, tip_force))
        revolute = np.einsum("ni,ni->n", axes, moment_below - np.cross(origins, force_below))
        prismatic = np.einsum("ni,ni->n", axes, force_below)
        torque = np.where(self._kinds == AXIAL, prismatic, revolute)
        energy = -float(np.einsum("ni,ni->", centres, forces)) - float(tip @ tip_force)
        return torque, energy

    def _stop_energy(self, q: np.ndarray) -> float:
        start_low, band_low, start_high, band_high = self._stop_bands
        return float(self.stops.stiffness @ (_locking_integral(q - start_high, band_high)
                                             + _locking_integral(start_low - q, band_low)))

    def energy(self, q: np.ndarray, load_torque: np.ndarray, tip_force: np.ndarray) -> float:
        """Potential energy (J) at ``q``: springs, stops, the pressure load, gravity, tip force."""
        k0 = self.stiffness0
        spring = float(np.sum(k0 * (0.5 * q ** 2 + 0.25 * self._stiffening * q ** 4)))
        return (spring - float(load_torque @ q) + self._stop_energy(q)
                + self._external(q, tip_force)[1])

    def residual(self, q: np.ndarray, load_torque: np.ndarray, tip_force: np.ndarray
                 ) -> np.ndarray:
        """Unbalanced generalised force on every joint (N m or N), minus the energy's gradient."""
        spring = self.stiffness0 * q * (1.0 + self._stiffening * q ** 2)
        return load_torque - spring - self.stops.force(q) + self._external(q, tip_force)[0]

    # ---------------------------------------------------------------- the solve
    def equilibrium(self, pressures_pa: np.ndarray, tip_mass_kg: float = 0.0,
                    tip_force_n: np.ndarray | None = None, q_start: np.ndarray | None = None,
                    tolerance: float = 1e-9) -> StaticState:
        """The stable rest shape under held ``pressures_pa``.

        Args:
            pressures_pa: chamber gauge pressures (Pa), shape (n_chambers,), within
                ``[0, p_max]``.
            tip_mass_kg: a mass hung at the tip (kg); its weight acts at the tip point.
            tip_force_n: a further force at the tip (N, base frame), shape (3,).
            q_start: joint positions to start the search from (a nearby rest shape).
            tolerance: stop when every joint's unbalanced force is below ``tolerance`` times its
                small-strain stiffness (rad or m).

        Raises:
            ValueError: pressures out of range, a negative mass, a bad force.
            RuntimeError: the search did not converge.
        """
        pressure = check_pressures(self.spec, pressures_pa)
        mass = require_non_negative("tip_mass_kg", tip_mass_kg)
        force = mass * self.gravity
        if tip_force_n is not None:
            force = force + as_finite_array("tip_force_n", tip_force_n, shape=(3,))
        rest = self.rest_matrix @ effective_pressure_pa(self.spec, pressure)
        load_torque = self.stiffness0 * rest
        q = np.zeros(self.chain.n_joints) if q_start is None else np.array(q_start, dtype=float)
        energy = self.energy(q, load_torque, force)
        k0 = self.stiffness0
        # from a nearby shape, the last solve's Hessian serves until it stops converging fast
        hessian = None if q_start is None else self._last_hessian
        previous = np.inf
        for _ in range(_MAX_NEWTON_STEPS):
            residual = self.residual(q, load_torque, force)
            size = float(np.max(np.abs(residual) / k0))
            if size < tolerance:
                return self._state(q, residual)
            if hessian is None or size > 0.1 * previous:
                hessian = self._hessian(q, force)
                self._last_hessian = hessian
            previous = size
            step = _positive_solve(hessian, residual)
            scale = 1.0
            while True:  # backtrack on the energy: every accepted step lowers it
                trial = q + scale * step
                trial_energy = self.energy(trial, load_torque, force)
                if trial_energy <= energy + 1e-4 * scale * float(step @ -residual) or scale < 1e-6:
                    break
                scale *= 0.5
            q, energy = trial, trial_energy
        residual = self.residual(q, load_torque, force)
        if np.max(np.abs(residual) / k0) < 1e3 * tolerance:
            return self._state(q, residual)
        raise RuntimeError(f"the {self.spec.name} arm's rest shape under pressures "
                           f"{pressure.tolist()} Pa and a {mass} kg tip did not converge")

    def _hessian(self, q: np.ndarray, force: np.ndarray) -> np.ndarray:
        """The energy's Hessian: springs and stops on the diagonal, and the Jacobian of gravity's
        and the tip force's generalised force (:meth:`external_jacobian`)."""
        diagonal = (self.stiffness0 * (1.0 + 3.0 * self._stiffening * q ** 2)
                    + self.stops.stiffness_at(q))
        jacobian = self.external_jacobian(q, force)
        return np.diag(diagonal) - 0.5 * (jacobian + jacobian.T)

    def external_jacobian(self, q: np.ndarray, tip_force: np.ndarray) -> np.ndarray:
        """``d tau / d q`` of the generalised force of gravity and the tip force (N m / rad,
        N / m), in closed form from one pass of the kinematics.

        The forces ``f_k`` on the points ``p_k`` (sub-link centres, the tip) keep their
        directions as the chain moves. Moving joint ``j`` turns (revolute, axis ``a_j`` through
        ``o_j``) or shifts (prismatic, along ``a_j``) every point and axis past it. With the
        sums over the points past joint ``m`` -- the force ``F_m``, the moment about ``o_m``,
        ``R_m``, and ``S_m = sum p_k f_k^T`` -- a revolute joint ``i`` (``tau_i = a_i . R_i``)
        and a revolute joint ``j``, ``m = max(i, j)``, give

            d tau_i / d q_j = a_i^T S_m a_j - (a_i . o_m)(a_j . F_m)
                              - (a_i . a_j)(tr S_m - o_m . F_m) + [j < i] (a_j x a_i) . R_i,

        a prismatic ``j`` past ``i`` gives ``a_i . (a_j x F_j)`` (before it, or at it, none: the
        points and ``o_i`` shift together); a prismatic joint ``i`` (``tau_i = a_i . F_i``) gets
        ``(a_j x a_i) . F_i`` from a revolute ``j`` before it, none otherwise. Conservative
        forces make it symmetric; ``tests/soft_gym/robots/test_statics.py`` checks it against
        finite differences of :meth:`_external`.
        """
        origins, axes, body, rotations = self.frames(q)
        centres = body + np.einsum("nij,nj->ni", rotations, self._centres)
        forces = self._masses[:, None] * self.gravity[None, :]
        tip = body[-1] + rotations[-1][:, 2] * self._tip_length
        # sums over the points past each joint (the tip is past every one)
        force_past = np.cumsum(forces[::-1], axis=0)[::-1] + tip_force
        outer_past = (np.cumsum(np.einsum("ni,nj->nij", centres, forces)[::-1], axis=0)[::-1]
                      + np.outer(tip, tip_force))
        moment_past = (np.cumsum(np.cross(centres, forces)[::-1], axis=0)[::-1]
                       + np.cross(tip, tip_force) - np.cross(origins, force_past))
        n = len(q)
        index = np.arange(n)
        pivot = np.maximum(index[:, None], index[None, :])                 # m = max(i, j)
        trace = np.trace(outer_past, axis1=1, axis2=2) - np.einsum("ni,ni->n", origins,
                                                                   force_past)
        revolute_pair = (np.einsum("ik,ijkl,jl->ij", axes, outer_past[pivot], axes)
                         - np.einsum("ik,ijk->ij", axes, origins[pivot])
                         * np.einsum("jk,ijk->ij", axes, force_past[pivot])
                         - (axes @ axes.T) * trace[pivot])
        # (a_j x a_i) . R_i for j < i: the axis of i turning with j
        turned_axis = np.einsum("jk,ik->ij", axes, np.cross(axes, moment_past))
        revolute_pair += np.tril(turned_axis, -1)
        # a prismatic j past i shifts the points past it: a_i . (a_j x F_j)
        shifted = np.einsum("ik,jk->ij", axes, np.cross(axes, force_past))
        prismatic = self._kinds == AXIAL
        jacobian = np.where(prismatic[None, :], np.triu(shifted, 1), revolute_pair)
        # a prismatic i: tau_i = a_i . F_i, turned by a revolute j before it: (a_j x a_i) . F_i,
        # which is shifted[j, i]
        prismatic_row = np.where(prismatic[None, :], 0.0, np.tril(shifted.T, -1))
        return np.where(prismatic[:, None], prismatic_row, jacobian)

    def _state(self, q: np.ndarray, residual: np.ndarray) -> StaticState:
        backbone = self.backbone(q)
        return StaticState(q=q.copy(), tip_m=backbone[-1].copy(), backbone_m=backbone,
                           residual_n=float(np.max(np.abs(residual))))


def _rotation(index: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if index == 0:
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    if index == 1:
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _locking_integral(depth: np.ndarray, band: np.ndarray) -> np.ndarray:
    """Energy of a unit locking stop (:meth:`EndStops._locking` integrated over the depth)."""
    depth = np.maximum(depth, 0.0)
    inside = np.minimum(depth, band)
    beyond = depth - inside
    return inside ** 3 / (6.0 * band) + 0.5 * band * beyond + 0.5 * beyond ** 2


def _positive_solve(hessian: np.ndarray, gradient_step: np.ndarray) -> np.ndarray:
    """Solve ``H x = r`` with ``H`` made positive definite if it is not (Levenberg shift)."""
    shift = 0.0
    scale = float(np.mean(np.abs(np.diag(hessian))))
    for _ in range(30):
        try:
            factor = np.linalg.cholesky(hessian + shift * np.eye(len(hessian)))
        except np.linalg.LinAlgError:
            shift = max(2.0 * shift, 1e-6 * scale)
            continue
        return np.linalg.solve(factor.T, np.linalg.solve(factor, gradient_step))
    return gradient_step / np.diag(hessian).clip(min=1e-12)
