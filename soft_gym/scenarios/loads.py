"""Loads and disturbances that act on the arm through PyBullet itself.

Each element has a time window (``start_s``, ``end_s``; ``end_s=None`` means until the episode
ends) and is refreshed by the simulator at its actuation rate (``ArmSpec.actuation_update_s``).
Masses change the tip link's mass in PyBullet; forces are external forces applied every physics
substep; the swaying mass is a separate rigid body hung from the tip by a point-to-point
constraint; the obstacle is a fixed collision body.

Every parameter is checked on construction (a ``ValueError`` naming it, its value and what is
allowed): its type, finiteness and sign, and physical bounds. The loads of the papers are a few
grams to 263 g (zhao2021) and pushes of 0.2-1 N, and the arms bear at most a few newtons. How much
a load weighs or pushes is checked when it is attached to an arm (the simulator's ``add_load``):
first against what that arm bears (:attr:`soft_gym.robots.spec.ArmSpec.max_load_n`, 0.8-7.2 N for
the presets), then against absolute bounds that hold whatever the arm:

* a mass (a tip mass, a filled container, a swaying ball) is at most :data:`MAX_MASS_KG`;
* a force (a push, a flick's force ``impulse / duration``) is at most :data:`MAX_FORCE_N`.

On construction:

* a container fills at most at :data:`MAX_FILL_RATE_KG_S`;
* a swaying ball hangs at most :data:`MAX_SWAY_LENGTH_M` under the tip and is at most
  :data:`MAX_SWAY_RADIUS_M` in radius;
* an obstacle rod is at most :data:`MAX_ROD_RADIUS_M` thick and :data:`MAX_ROD_LENGTH_M` long, and
  must not cut through the arm where it is attached (the arm would be thrown out of it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from soft_gym._timing import TimeWindow
from soft_gym._validation import (as_finite_array, require_bool, require_non_negative,
                                  require_positive)

MAX_MASS_KG = 1.0
"""Heaviest mass a load element may have (kg): about four times zhao2021's heaviest tip load
(263 g), and above what any preset arm bears (zhao2021's ``max_load_n`` of 7.2 N is 734 g), which
the simulator checks when the load is attached."""

MAX_FORCE_N = 10.0
"""Strongest force a push or flick may exert (N): ten times zhao2021's 1 N pull, fifty times
wang2023's 0.2 N push, and above what any preset arm bears (at most 7.2 N, zhao2021)."""

MAX_FILL_RATE_KG_S = 1.0
"""Fastest a filling container may fill (kg/s, a litre of water a second; ho2018 pours 0.6 g/s)."""

MAX_SWAY_LENGTH_M = 0.5
"""Longest string a swaying mass may hang on (m): over twice the longest preset arm (214 mm);
zhao2021 hangs its ball 50 mm under the tip."""

MAX_SWAY_RADIUS_M = 0.05
"""Largest swaying ball (m radius; zhao2021's 119 g ball: 15 mm)."""

MIN_SWAY_RADIUS_M = 1e-3
"""Smallest swaying ball (m radius): a smaller one's inertia is too small for a stable step."""

MAX_ROD_RADIUS_M = 0.1
"""Thickest obstacle rod (m radius; wang2023's aluminium rod: 4 mm)."""

MAX_ROD_LENGTH_M = 2.0
"""Longest obstacle rod (m; the default: 0.2 m)."""


def _check_peak_mass(load: "_Timed", name: str, mass_kg: float) -> None:
    """Refuse (when attaching ``load``) a mass above ``MAX_MASS_KG``, naming ``name``."""
    if mass_kg > MAX_MASS_KG:
        raise ValueError(f"{name} must be at most {MAX_MASS_KG:g} kg (MAX_MASS_KG), got "
                         f"{mass_kg!r} kg in {load!r}")


def _check_peak_force(load: "Push", name: str) -> None:
    """Refuse (when attaching ``load``) a force above ``MAX_FORCE_N``, naming ``name``."""
    magnitude = float(np.linalg.norm(load.force_n))
    if magnitude > MAX_FORCE_N:
        raise ValueError(f"{name} must be a force of at most {MAX_FORCE_N:g} N in magnitude "
                         f"(MAX_FORCE_N), got {magnitude:.3g} N in {load!r}")


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

    The simulator carries it as a tip payload (:meth:`soft_gym.engines.pybullet.simulator.ArmSimulator.set_tip_payload`):
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

    def attach(self, sim) -> None:
        _check_peak_mass(self, "mass_kg" if isinstance(self, TipMass)
                         else "initial_mass_kg + added_mass_kg", self.peak_mass_kg())

    def update(self, sim, time_s: float) -> None:
        sim.set_tip_payload(self._key(), self.extra_mass_kg(time_s) if self.active(time_s) else 0.0)

    def detach(self, sim) -> None:
        sim.set_tip_payload(self._key(), 0.0)


@dataclass
class TipMass(_TipMassBase):
    """A static mass on the tip (kg), e.g. ho2018's 14.2 g load or zhao2021's 50-263 g."""

    mass_kg: float = 0.02

    def __post_init__(self) -> None:
        require_non_negative("mass_kg", self.mass_kg, unit="kg")
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
        require_non_negative("initial_mass_kg", self.initial_mass_kg, unit="kg")
        require_non_negative("added_mass_kg", self.added_mass_kg, unit="kg")
        require_positive("rate_kg_s", self.rate_kg_s, maximum=MAX_FILL_RATE_KG_S, unit="kg/s")
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

    engine_features: ClassVar[frozenset[str]] = frozenset({"bodies"})
    """A ball beside the arm, tethered to its tip (:data:`soft_gym.engines.ENGINE_FEATURES`)."""

    mass_kg: float = 0.02
    length_m: float = 0.02
    radius_m: float = 0.006
    _body: int = field(default=-1, init=False, repr=False)
    _constraint: int = field(default=-1, init=False, repr=False)

    def __post_init__(self) -> None:
        require_positive("mass_kg", self.mass_kg, unit="kg")
        require_positive("length_m", self.length_m, maximum=MAX_SWAY_LENGTH_M, unit="m")
        radius = require_positive("radius_m", self.radius_m, maximum=MAX_SWAY_RADIUS_M, unit="m")
        if radius < MIN_SWAY_RADIUS_M:
            raise ValueError(f"radius_m must be at least {MIN_SWAY_RADIUS_M:g} m "
                             f"(MIN_SWAY_RADIUS_M), got {self.radius_m!r}")
        self.check_window()

    def peak_load_n(self, gravity_m_s2: float) -> float:
        return self.mass_kg * gravity_m_s2

    def attach(self, sim) -> None:
        _check_peak_mass(self, "mass_kg", self.mass_kg)
        tip, _ = sim.tip_pose()
        down = sim.gravity / max(np.linalg.norm(sim.gravity), 1e-9)
        self._body = sim.world.add_body("sphere", radius_m=self.radius_m, mass_kg=self.mass_kg,
                                        position_m=(tip + down * self.length_m).tolist(),
                                        rgba=(0.2, 0.4, 0.9, 1))
        # no collision between the ball and the arm it hangs from
        sim.world.ignore_arm_collisions(self._body)
        self._constraint = sim.world.tether_to_tip(self._body, -down * self.length_m)

    def update(self, sim, time_s: float) -> None:
        if self._body < 0:
            return
        if not self.active(time_s) and time_s > 0:
            sim.world.set_tether_force(self._constraint, 0.0)
        elif self.active(time_s):
            sim.world.set_tether_force(self._constraint, 1e3)

    def reset(self, sim) -> None:
        """Put the ball back at rest under the tip (called when the arm is reset)."""
        tip, _ = sim.tip_pose()
        down = sim.gravity / max(np.linalg.norm(sim.gravity), 1e-9)
        sim.world.set_body_pose(self._body, (tip + down * self.length_m).tolist(), [0, 0, 0, 1])
        sim.world.stop_body(self._body)

    def detach(self, sim) -> None:
        if self._body >= 0:
            sim.world.remove_tether(self._constraint)
            sim.world.remove_body(self._body)
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
        self._check_link_and_cap()
        require_non_negative("ramp_s", self.ramp_s, unit="s")
        self.check_window()

    def _check_link_and_cap(self) -> None:
        if isinstance(self.link, (bool, np.bool_)) or not isinstance(self.link, (int, np.integer)):
            raise ValueError(f"link must be an integer link index (0 at the base, -1 the tip), "
                             f"got {self.link!r} ({type(self.link).__name__})")
        self.on_tip_cap = require_bool("on_tip_cap", self.on_tip_cap)

    def _link_index(self, sim) -> int:
        n = sim.n_links
        if isinstance(self.link, (bool, np.bool_)) or not isinstance(self.link, (int, np.integer)) \
                or not -n <= self.link < n:
            raise ValueError(f"link must be an integer in [{-n}, {n - 1}] for this arm "
                             f"({n} links), got {self.link!r}")
        return int(self.link) % n

    def attach(self, sim) -> None:
        _check_peak_force(self, "impulse_ns / duration_s" if isinstance(self, Flick)
                          else "force_n")
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
            sim.set_external_force(key, -1, force, (0.0, 0.0, sim.link_rest_lengths_m[-1]),
                                   on_body=False)
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
        duration = require_positive("duration_s", self.duration_s, unit="s")
        self.force_n = tuple((impulse / duration).tolist())
        self._check_link_and_cap()
        self.check_window()
        self.end_s = self.start_s + duration


@dataclass
class ObstacleRod(_Timed):
    """A fixed rod (collision body): a cylinder of ``radius_m`` through ``point_m`` along ``axis``.

    wang2023 fixes an aluminium rod in the workspace that limits bending on one side.
    """

    engine_features: ClassVar[frozenset[str]] = frozenset({"bodies"})
    """A body beside the arm that it touches (:data:`soft_gym.engines.ENGINE_FEATURES`)."""

    point_m: tuple[float, float, float] = (-0.02, 0.0, 0.07)
    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    radius_m: float = 0.004
    length_m: float = 0.2
    _body: int = field(default=-1, init=False, repr=False)

    def __post_init__(self) -> None:
        self.point_m = tuple(as_finite_array("point_m", self.point_m, shape=(3,)).tolist())
        axis = as_finite_array("axis", self.axis, shape=(3,))
        if np.linalg.norm(axis) == 0:
            raise ValueError("axis must be a non-zero vector, got (0, 0, 0)")
        self.axis = tuple(axis.tolist())
        require_positive("radius_m", self.radius_m, maximum=MAX_ROD_RADIUS_M, unit="m")
        require_positive("length_m", self.length_m, maximum=MAX_ROD_LENGTH_M, unit="m")
        self.check_window()

    def clearance_m(self, backbone_m: np.ndarray, arm_radius_m: float) -> float:
        """Gap (m) between the rod's surface and an arm of radius ``arm_radius_m`` (m) along the
        polyline ``backbone_m`` (m, base frame); negative where they overlap."""
        axis = np.asarray(self.axis, dtype=float) / np.linalg.norm(self.axis)
        centre = np.asarray(self.point_m, dtype=float)
        rod = (centre - axis * self.length_m / 2, centre + axis * self.length_m / 2)
        points = np.asarray(backbone_m, dtype=float)
        distance = min(_segment_distance(rod[0], rod[1], a, b)
                       for a, b in zip(points[:-1], points[1:]))
        return distance - self.radius_m - arm_radius_m

    def attach(self, sim) -> None:
        """Build the rod; refuse one that cuts through the arm as every reset puts it: straight
        along the base's z axis, rest length (s) long."""
        spec = sim.spec
        arm_radius = max(segment.outer_radius_m for segment in spec.segments)
        gap = self.clearance_m(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, spec.length_m]]),
                               arm_radius)
        if gap < 0:
            raise ValueError(
                f"point_m, axis and radius_m put the obstacle rod through the {spec.name} arm "
                f"at rest ({-gap * 1e3:.1f} mm deep; the straight arm runs from the base along z "
                f"for {spec.length_m * 1e3:.0f} mm and is {arm_radius * 1e3:.1f} mm in radius): "
                f"place it beside the arm, got point_m={self.point_m}, axis={self.axis}, "
                f"radius_m={self.radius_m!r}")
        axis = np.asarray(self.axis, dtype=float)
        axis /= np.linalg.norm(axis)
        z = np.array([0.0, 0.0, 1.0])
        rotation_axis = np.cross(z, axis)
        angle = math.acos(float(np.clip(axis @ z, -1, 1)))
        if np.linalg.norm(rotation_axis) < 1e-9:
            rotation_axis = np.array([1.0, 0.0, 0.0])
        self._body = sim.world.add_body(
            "cylinder", radius_m=self.radius_m, length_m=self.length_m,
            position_m=list(self.point_m), axis_angle=(rotation_axis.tolist(), angle),
            rgba=(0.7, 0.7, 0.75, 1))

    def update(self, sim, time_s: float) -> None:
        pass

    def detach(self, sim) -> None:
        if self._body >= 0:
            sim.world.remove_body(self._body)
            self._body = -1


def _segment_distance(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> float:
    """Shortest distance (m) between the segments ``p0``-``p1`` and ``q0``-``q1`` (m)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, f = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    if a <= 1e-18 and e <= 1e-18:
        return float(np.linalg.norm(r))
    if a <= 1e-18:
        s, t = 0.0, float(np.clip(f / e, 0.0, 1.0))
    else:
        c = float(d1 @ r)
        if e <= 1e-18:
            s, t = float(np.clip(-c / a, 0.0, 1.0)), 0.0
        else:
            b = float(d1 @ d2)
            denominator = a * e - b * b
            s = float(np.clip((b * f - c * e) / denominator, 0.0, 1.0)) if denominator > 1e-18 \
                else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = float(np.clip(-c / a, 0.0, 1.0)), 0.0
            elif t > 1.0:
                s, t = float(np.clip((b - c) / a, 0.0, 1.0)), 1.0
    return float(np.linalg.norm(p0 + d1 * s - (q0 + d2 * t)))


def heaviest_total_load_n(loads: list, gravity_m_s2: float) -> float:
    """The most the ``loads`` weigh or push together at any moment (N).

    Each acts in its time window, so the heaviest moment is where one of them starts (a flick
    every 10 s never adds up with the next one)."""
    moments = {0.0, *(float(getattr(load, "start_s", 0.0)) for load in loads)}
    return max(sum(load.peak_load_n(gravity_m_s2) for load in loads
                   if not hasattr(load, "active") or load.active(time_s))
               for time_s in moments)
