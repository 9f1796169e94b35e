"""Loads and disturbances that act on the arm through PyBullet itself.

Each element has a time window (``start_s``, ``end_s``; ``end_s=None`` means until the episode
ends) and is refreshed by the simulator at its actuation rate (``ArmSpec.actuation_update_s``).
Masses change the tip link's mass in PyBullet; forces are external forces applied every physics
substep; the swaying mass is a separate rigid body hung from the tip by a point-to-point
constraint; the obstacle is a fixed collision body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pybullet

from soft_gym._timing import TimeWindow
from soft_gym._validation import as_finite_array, require_non_negative, require_positive


@dataclass
class _Timed(TimeWindow):
    """Base of all scenario elements: a time window (:class:`~soft_gym._timing.TimeWindow`, s)."""

    def peak_load_n(self, gravity_m_s2: float) -> float:
        """Largest weight or force (N) the element puts on the arm (checked against
        :attr:`soft_gym.robots.spec.ArmSpec.max_load_n` when it is attached)."""
        return 0.0

    def attach(self, sim) -> None:  # noqa: D102 - default: nothing to build
        pass

    def reset(self, sim) -> None:  # noqa: D102 - default: no state of its own
        pass

    def detach(self, sim) -> None:  # noqa: D102
        pass


@dataclass
class _TipMassBase(_Timed):
    """Adds a time-varying point mass at the tip.

    The simulator carries it as a tip payload (:meth:`soft_gym.sim.ArmSimulator.set_tip_payload`):
    the tip link's mass and inertia grow and the weight acts at the tip. Detaching or clearing
    the loads restores the link exactly as it was built.
    """

    def extra_mass_kg(self, time_s: float) -> float:
        raise NotImplementedError

    def peak_mass_kg(self) -> float:
        raise NotImplementedError

    def peak_load_n(self, gravity_m_s2: float) -> float:
        return self.peak_mass_kg() * gravity_m_s2

    def _key(self) -> str:
        return f"tipmass{id(self)}"

    def update(self, sim, time_s: float) -> None:
        sim.set_tip_payload(self._key(), self.extra_mass_kg(time_s) if self.active(time_s) else 0.0)

    def detach(self, sim) -> None:
        sim.set_tip_payload(self._key(), 0.0)


@dataclass
class TipMass(_TipMassBase):
    """A static mass on the tip (kg), e.g. ho2018's 14.2 g load or zhao2021's 50-263 g."""

    mass_kg: float = 0.02

    def __post_init__(self) -> None:
        require_non_negative("mass_kg", self.mass_kg)
        self.check_window()

    def extra_mass_kg(self, time_s: float) -> float:
        return self.mass_kg

    def peak_mass_kg(self) -> float:
        return self.mass_kg


@dataclass
class FillingLoad(_TipMassBase):
    """A tip container filling with fluid (ho2018): mass rises at a rate up to a maximum.

    Defaults follow Ho et al. 2018: a 14 g container gaining 10 g, at 0.6 mL/s of water
    (0.6 g/s), starting 5 s into the episode.
    """

    initial_mass_kg: float = 0.014
    added_mass_kg: float = 0.010
    rate_kg_s: float = 0.0006
    start_s: float = 5.0

    def __post_init__(self) -> None:
        require_non_negative("initial_mass_kg", self.initial_mass_kg)
        require_non_negative("added_mass_kg", self.added_mass_kg)
        require_positive("rate_kg_s", self.rate_kg_s)
        self.check_window()

    def active(self, time_s: float) -> bool:
        return self.end_s is None or time_s < self.end_s

    def extra_mass_kg(self, time_s: float) -> float:
        filled = min(self.added_mass_kg, max(0.0, time_s - self.start_s) * self.rate_kg_s)
        return self.initial_mass_kg + filled

    def peak_mass_kg(self) -> float:
        return self.initial_mass_kg + self.added_mass_kg


@dataclass
class SwayingMass(_Timed):
    """A ball (kg) hanging from the tip on a point-to-point constraint of ``length_m`` (m)."""

    mass_kg: float = 0.02
    length_m: float = 0.02
    radius_m: float = 0.006
    _body: int = field(default=-1, init=False, repr=False)
    _constraint: int = field(default=-1, init=False, repr=False)

    def __post_init__(self) -> None:
        require_positive("mass_kg", self.mass_kg)
        require_positive("length_m", self.length_m)
        require_positive("radius_m", self.radius_m)
        self.check_window()

    def peak_load_n(self, gravity_m_s2: float) -> float:
        return self.mass_kg * gravity_m_s2

    def attach(self, sim) -> None:
        client = sim.client
        shape = client.createCollisionShape(pybullet.GEOM_SPHERE, radius=self.radius_m)
        visual = client.createVisualShape(pybullet.GEOM_SPHERE, radius=self.radius_m,
                                          rgbaColor=[0.2, 0.4, 0.9, 1])
        tip, _ = sim.tip_pose()
        down = sim.gravity / max(np.linalg.norm(sim.gravity), 1e-9)
        self._body = client.createMultiBody(self.mass_kg, shape, visual,
                                            (tip + down * self.length_m).tolist())
        # no collision between the ball and the arm it hangs from
        for link in range(-1, sim.arm.n_joints):
            client.setCollisionFilterPair(self._body, sim.arm.body_id, -1, link, 0)
        last = sim.arm.tip_link
        # constraint pivots are given in the link's centre-of-mass frame
        com = np.asarray(client.getDynamicsInfo(sim.arm.body_id, last)[3])
        pivot = np.array([0.0, 0.0, sim.arm.station_rest_length[-1]]) - com
        self._constraint = client.createConstraint(
            sim.arm.body_id, last, self._body, -1, pybullet.JOINT_POINT2POINT, [0, 0, 0],
            pivot.tolist(), (-down * self.length_m).tolist())
        client.changeConstraint(self._constraint, maxForce=1e3)

    def update(self, sim, time_s: float) -> None:
        if self._body < 0:
            return
        if not self.active(time_s) and time_s > 0:
            sim.client.changeConstraint(self._constraint, maxForce=0.0)
        elif self.active(time_s):
            sim.client.changeConstraint(self._constraint, maxForce=1e3)

    def reset(self, sim) -> None:
        """Put the ball back at rest under the tip (called when the arm is reset)."""
        tip, _ = sim.tip_pose()
        down = sim.gravity / max(np.linalg.norm(sim.gravity), 1e-9)
        sim.client.resetBasePositionAndOrientation(self._body, (tip + down * self.length_m).tolist(),
                                                   [0, 0, 0, 1])
        sim.client.resetBaseVelocity(self._body, [0, 0, 0], [0, 0, 0])

    def detach(self, sim) -> None:
        if self._body >= 0:
            sim.client.removeConstraint(self._constraint)
            sim.client.removeBody(self._body)
            self._body = -1


@dataclass
class Push(_Timed):
    """A force (N, base frame) on one link, ramped up over ``ramp_s`` and held until ``end_s``.

    ``link`` indexes the arm's links from the base (0) to the tip (-1); the force acts at the
    link's middle on the body's surface, or with ``on_tip_cap=True`` at the tip link's distal end
    on the rigid cap (which presses no fiber or gauge). wang2023 (Table III) pushes the tip cap
    and the fiber-covered body.
    """

    force_n: tuple[float, float, float] = (0.2, 0.0, 0.0)
    link: int = -1
    ramp_s: float = 1.0
    start_s: float = 2.0
    end_s: float | None = 6.0
    on_tip_cap: bool = False

    def __post_init__(self) -> None:
        self.force_n = tuple(as_finite_array("force_n", self.force_n, shape=(3,)).tolist())
        require_non_negative("ramp_s", self.ramp_s)
        self.check_window()

    def _link_index(self, sim) -> int:
        n = len(sim.arm.station_link)
        if isinstance(self.link, (bool, np.bool_)) or not isinstance(self.link, (int, np.integer)) \
                or not -n <= self.link < n:
            raise ValueError(f"link must be in [{-n}, {n - 1}] for this arm, got {self.link!r}")
        return int(sim.arm.station_link[self.link])

    def attach(self, sim) -> None:
        self._link_index(sim)

    def peak_load_n(self, gravity_m_s2: float) -> float:
        return float(np.linalg.norm(self.force_n))

    def scale(self, time_s: float) -> float:
        if not self.active(time_s):
            return 0.0
        if self.ramp_s == 0:
            return 1.0
        return min(1.0, (time_s - self.start_s) / self.ramp_s)

    def update(self, sim, time_s: float) -> None:
        key = f"push{id(self)}"
        force = np.array(self.force_n) * self.scale(time_s)
        if self.on_tip_cap:
            sim.set_external_force(key, sim.arm.tip_link, force,
                                   (0.0, 0.0, sim.arm.station_rest_length[-1]), on_body=False)
        else:
            sim.set_external_force(key, self._link_index(sim), force)

    def detach(self, sim) -> None:
        sim.set_external_force(f"push{id(self)}", self._link_index(sim), np.zeros(3))


@dataclass
class Flick(Push):
    """A short impulse (N s) on a link: a constant force held for ``duration_s`` (default 20 ms)."""

    impulse_ns: tuple[float, float, float] = (0.003, 0.0, 0.0)
    duration_s: float = 0.02
    start_s: float = 2.0
    force_n: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), init=False)
    end_s: float | None = field(default=None, init=False)
    ramp_s: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        impulse = as_finite_array("impulse_ns", self.impulse_ns, shape=(3,))
        require_positive("duration_s", self.duration_s)
        self.force_n = tuple((impulse / self.duration_s).tolist())
        self.end_s = self.start_s + self.duration_s
        self.check_window()


@dataclass
class ObstacleRod(_Timed):
    """A fixed rod (collision body): a cylinder of ``radius_m`` through ``point_m`` along ``axis``.

    wang2023 fixes an aluminium rod in the workspace that limits bending on one side.
    """

    point_m: tuple[float, float, float] = (-0.02, 0.0, 0.07)
    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    radius_m: float = 0.004
    length_m: float = 0.2
    _body: int = field(default=-1, init=False, repr=False)

    def __post_init__(self) -> None:
        as_finite_array("point_m", self.point_m, shape=(3,))
        axis = as_finite_array("axis", self.axis, shape=(3,))
        if np.linalg.norm(axis) == 0:
            raise ValueError("axis must be a non-zero vector, got (0, 0, 0)")
        require_positive("radius_m", self.radius_m)
        require_positive("length_m", self.length_m)
        self.check_window()

    def attach(self, sim) -> None:
        axis = np.asarray(self.axis, dtype=float)
        axis /= np.linalg.norm(axis)
        z = np.array([0.0, 0.0, 1.0])
        rotation_axis = np.cross(z, axis)
        angle = math.acos(float(np.clip(axis @ z, -1, 1)))
        if np.linalg.norm(rotation_axis) < 1e-9:
            rotation_axis = np.array([1.0, 0.0, 0.0])
        orientation = pybullet.getQuaternionFromAxisAngle(rotation_axis.tolist(), angle)
        client = sim.client
        shape = client.createCollisionShape(pybullet.GEOM_CYLINDER, radius=self.radius_m,
                                            height=self.length_m)
        visual = client.createVisualShape(pybullet.GEOM_CYLINDER, radius=self.radius_m,
                                          length=self.length_m, rgbaColor=[0.7, 0.7, 0.75, 1])
        self._body = client.createMultiBody(0.0, shape, visual, list(self.point_m), orientation)

    def update(self, sim, time_s: float) -> None:
        pass

    def detach(self, sim) -> None:
        if self._body >= 0:
            sim.client.removeBody(self._body)
            self._body = -1


def heaviest_total_load_n(loads: list, gravity_m_s2: float) -> float:
    """The most the ``loads`` weigh or push together at any moment (N).

    Each acts in its time window, so the heaviest moment is where one of them starts (a flick
    every 10 s never adds up with the next one)."""
    moments = {0.0, *(float(getattr(load, "start_s", 0.0)) for load in loads)}
    return max(sum(load.peak_load_n(gravity_m_s2) for load in loads
                   if not hasattr(load, "active") or load.active(time_s))
               for time_s in moments)
