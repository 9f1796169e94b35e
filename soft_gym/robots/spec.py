"""Arm and segment descriptions: geometry, material and actuation, validated on construction.

All quantities are SI (m, kg, s, Pa, rad). The derived section properties follow from a solid
silicone cylinder with three chamber bores at distance ``chamber_offset_m`` from the axis at angles
``sigma_i = 2 pi i / 3``, and an optional central cavity of radius ``r_c`` on the axis (ho2018's
carries the distal segment's tubes; docs/architecture.md, "Chambers"):

* cross-section area ``A = pi R^2 - 3 A_c - pi r_c^2``
* second moment of area about any diameter
  ``I = pi R^4 / 4 - 3 A_c^2 / (4 pi) - 1.5 A_c d^2 - pi r_c^4 / 4``
  (each bore treated as a circle of area ``A_c``; the parallel-axis terms sum to ``1.5 A_c d^2``
  whatever the bending direction, since ``sum_i sin^2(sigma_i - phi) = 3/2``)
* the thinnest wall: the least of the outer wall ``R - d - r``, the wall to the cavity
  ``d - r - r_c`` and the wall between two bores ``sqrt(3) d - 2 r``, with ``r = sqrt(A_c / pi)``
* polar moment ``J = 2 I``; shear modulus ``G = E / (2 (1 + nu))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np

from soft_gym._validation import require_in_range, require_non_negative, require_positive
from soft_gym.robots.chambers import CHAMBER_ANGLES_RAD

MOUNTS = ("hanging", "upright", "horizontal")
GRAVITY_M_S2 = 9.81

MAX_LOAD_TO_WEIGHT = {"hanging": 4.0, "horizontal": 4.0, "upright": 2.0}
"""Heaviest load an arm bears, as a multiple of its own weight, by mount
(:attr:`ArmSpec.max_load_n`).

Tip masses, a filling container, a swaying mass and held pushes together may weigh or push at
most this much. Up to it the simulated arm stays on its joints' end stops under any actuation
and from any direction (``tests/soft_gym/engines/test_runaway.py``); at eight times its weight a hanging ho2018
arm under random pressures no longer does. An upright arm folds over under a load on top: an
upright ho2018 arm of 41.7 g stayed on its stops under random pressures with 120 g (2.9 times
its weight) and not with 150 g, so upright arms bear twice their weight (the present 60.0 g arm
is checked at its 120 g). The papers' loads are well inside it (zhao2021's 263 g is 1.3 times
its hanging arm's own weight, ho2018's 32 g fluid tip 0.53 of its upright arm's)."""
"""How the arm base is mounted: hanging (tip down, the papers' setups), upright, horizontal."""

MAX_CHAMBER_AREA_GROWTH = 4.0
"""Largest :attr:`SegmentSpec.chamber_area_growth`: a bore up to five times its rest area at
``p_max``. A wrapped chamber bulging further is past what the quadratic force law describes."""

MAX_CHAMBER_AREA_GROWTH_EXPONENT = 6.0
"""Largest :attr:`SegmentSpec.chamber_area_growth_exponent`: how late in the pressure range the
bore's growth may set in."""


@dataclass(frozen=True)
class SegmentSpec:
    """One pneumatic segment with three chambers.

    Attributes:
        length_m: rest length of the backbone (m).
        outer_radius_m: outer radius of the silicone body (m).
        chamber_offset_m: distance ``d`` of each chamber centre from the axis (m).
        chamber_area_m2: pressurised cross-section ``A_c`` of one chamber (m^2).
        youngs_modulus_pa: small-strain Young's modulus ``E`` of the body (Pa).
        poisson_ratio: ``nu`` (silicone is nearly incompressible, about 0.48).
        density_kg_m3: body density (kg/m^3).
        n_links: rigid links the segment is cut into in the simulator.
        p_max_pa: highest chamber pressure (gauge, Pa).
        p_pre_pa: pre-pressure every chamber rests at (gauge, Pa); ho2018 uses 0.04 MPa.
        bending_stiffening: dimensionless ``beta_b`` of the hyperelastic stiffening
            ``k_b(kappa) = k_b0 (1 + beta_b (kappa R)^2)`` (secant stiffness).
        axial_stiffening: ``beta_a`` in ``k_a(eps) = k_a0 (1 + beta_a eps^2)``.
        axial_modulus_pa: axial modulus if it differs from ``E`` (e.g. a braided PMA bundle).
        max_extension_ratio: longest allowed link length over rest length (joint limit), > 1.
        thread_length_m: length of an inextensible central thread between the segment's end
            rings (m), or ``None`` for no thread (zhao2021, Section II-A: the thread holds each
            segment to at most 150 mm). The thread is slack while the segment is shorter and taut
            at its length, so the backbone cannot lengthen past it: each link's axial joint stops
            at ``thread_length_m / n_links`` (a stiff tether,
            :data:`soft_gym.robots.stops.THREAD_STIFFNESS_FACTOR`), while shortening stays
            free. Must lie in ``[length_m, length_m * max_extension_ratio]``; equal to
            ``length_m`` the segment cannot lengthen at all and the chambers' axial force goes into
            the thread, leaving only their bending moment.
        chamber_area_growth: dimensionless growth ``g`` of a chamber's pressurised cross-section
            with its pressure, ``A_c(p) = A_c (1 + g p / p_max)`` (0: a rigid bore). A silicone
            chamber wrapped in a thread (zhao2021 Section II-A: "Nylon thread was twined around
            the soft manipulator to limit radial expansion") still bulges between the windings
            and its bore widens as the walls thin, so its force ``p A_c(p)`` (axial and bending
            alike, :func:`soft_gym.robots.pneumatics.effective_pressure_pa`) grows faster than
            linearly with the pressure. In ``[0, 4]``.
        chamber_area_growth_exponent: ``n`` of the bore's growth law
            ``A_c(p) = A_c (1 + g (p / p_max)^n)``: 1 grows the bore in proportion to the pressure;
            larger, the growth sets in late, as a wrapped membrane that bulges little until its
            windings are taken up and then balloons. In ``[1, 6]``.
        max_bend_per_m_rad: largest curvature allowed by the joint limits (rad/m).
        damping_ratio: damping ratio of the arm's first bending mode. The damping is
            stiffness-proportional, as for a viscoelastic solid: every joint of the segment gets
            ``c = 2 zeta k / omega_1`` with ``omega_1`` the whole arm's first mode
            (:attr:`ArmSpec.first_bending_mode_rad_s`), so higher modes are damped more, as in
            silicone.
        torsion: whether links get a torsion joint (stiffness ``G J / ds``).
        extra_tip_mass_kg: mass fixed at this segment's distal end (connector, tip cap, camera).
        central_cavity_radius_m: radius ``r_c`` of a hollow core along the axis (m; 0: solid).
            ho2018 Section 2.1: the proximal segment's centre cavity carries the distal segment's
            air tubes.
        braid_twist_m: torsion lever ``r_t`` (m) of an unbalanced braid: a braided (McKibben)
            muscle whose braid is not balanced rotates as it extends, so each pressurised chamber
            twists the segment about its axis with the moment ``r_t p A_c(p)`` (the same effective
            force as its axial load), signed by ``r_t``. It acts through the torsion joints, so it
            needs ``torsion=True``; 0 (default): no twist. With the bending plane turning along the
            arm, a bend becomes a 3-D twisted curve that constant curvature cannot describe.
    """

    length_m: float
    outer_radius_m: float
    chamber_offset_m: float
    chamber_area_m2: float
    youngs_modulus_pa: float
    poisson_ratio: float = 0.48
    density_kg_m3: float = 1070.0
    n_links: int = 4
    p_max_pa: float = 100e3
    p_pre_pa: float = 0.0
    bending_stiffening: float = 0.0
    axial_stiffening: float = 0.0
    axial_modulus_pa: float | None = None
    max_extension_ratio: float = 1.6
    thread_length_m: float | None = None
    chamber_area_growth: float = 0.0
    chamber_area_growth_exponent: float = 1.0
    max_bend_per_m_rad: float = 40.0
    damping_ratio: float = 0.7
    torsion: bool = False
    extra_tip_mass_kg: float = 0.0
    braid_twist_m: float = 0.0
    central_cavity_radius_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("length_m", "outer_radius_m", "chamber_offset_m", "chamber_area_m2",
                     "youngs_modulus_pa", "density_kg_m3", "p_max_pa", "max_bend_per_m_rad",
                     "damping_ratio"):
            require_positive(name, getattr(self, name))
        for name in ("p_pre_pa", "bending_stiffening", "axial_stiffening", "extra_tip_mass_kg",
                     "central_cavity_radius_m"):
            require_non_negative(name, getattr(self, name))
        if not np.isfinite(self.braid_twist_m) or (self.braid_twist_m != 0.0 and not self.torsion):
            raise ValueError(f"braid_twist_m must be finite, and 0 without torsion joints "
                             f"(torsion=False), got {self.braid_twist_m!r}")
        require_in_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5)
        if self.axial_modulus_pa is not None:
            require_positive("axial_modulus_pa", self.axial_modulus_pa)
        if not isinstance(self.n_links, (int, np.integer)) or not 2 <= self.n_links <= 40:
            raise ValueError(f"n_links must be an integer in [2, 40], got {self.n_links!r}")
        if self.max_extension_ratio <= 1.0 or not np.isfinite(self.max_extension_ratio):
            raise ValueError(f"max_extension_ratio must be > 1, got {self.max_extension_ratio!r}")
        growth = self.chamber_area_growth
        if (isinstance(growth, (bool, np.bool_)) or not isinstance(growth, (int, float, np.integer,
                                                                             np.floating))
                or not np.isfinite(growth) or not 0.0 <= growth <= MAX_CHAMBER_AREA_GROWTH):
            raise ValueError(
                f"chamber_area_growth must be a number in [0, {MAX_CHAMBER_AREA_GROWTH}] (relative "
                f"growth of the chamber area at p_max), got {growth!r}")
        exponent = self.chamber_area_growth_exponent
        if (isinstance(exponent, (bool, np.bool_)) or not isinstance(
                exponent, (int, float, np.integer, np.floating)) or not np.isfinite(exponent)
                or not 1.0 <= exponent <= MAX_CHAMBER_AREA_GROWTH_EXPONENT):
            raise ValueError(
                f"chamber_area_growth_exponent must be a number in "
                f"[1, {MAX_CHAMBER_AREA_GROWTH_EXPONENT}], got {exponent!r}")
        if self.thread_length_m is not None:
            longest = self.length_m * self.max_extension_ratio
            if (not isinstance(self.thread_length_m, (int, float, np.floating))
                    or isinstance(self.thread_length_m, bool)
                    or not np.isfinite(self.thread_length_m)
                    or not self.length_m <= self.thread_length_m <= longest):
                raise ValueError(
                    f"thread_length_m must be None or a length in [length_m={self.length_m}, "
                    f"length_m * max_extension_ratio={longest:.6g}] m (a thread shorter than the "
                    f"rest length would compress the body at rest), got {self.thread_length_m!r}")
        if self.chamber_offset_m >= self.outer_radius_m:
            raise ValueError(
                f"chamber_offset_m must be smaller than outer_radius_m={self.outer_radius_m}, "
                f"got {self.chamber_offset_m!r}")
        if self.area_m2 <= 0 or self.second_moment_m4 <= 0 or self.wall_thickness_m <= 0:
            raise ValueError(
                f"chamber_area_m2={self.chamber_area_m2!r} leaves no wall between the bores, the "
                f"outer surface and the central cavity for outer_radius_m={self.outer_radius_m}, "
                f"chamber_offset_m={self.chamber_offset_m} and central_cavity_radius_m="
                f"{self.central_cavity_radius_m} (thinnest wall {self.wall_thickness_m:.6g} m)")
        if self.p_pre_pa > self.p_max_pa:
            raise ValueError(f"p_pre_pa must be <= p_max_pa={self.p_max_pa}, got {self.p_pre_pa!r}")

    # --- derived section properties -------------------------------------------------------------
    @property
    def area_m2(self) -> float:
        """Solid cross-section area ``pi R^2 - 3 A_c - pi r_c^2`` (m^2)."""
        return (math.pi * self.outer_radius_m**2 - 3.0 * self.chamber_area_m2
                - math.pi * self.central_cavity_radius_m**2)

    @property
    def second_moment_m4(self) -> float:
        """Second moment of area ``I`` about any diameter (m^4), see the module docstring."""
        a_c, d = self.chamber_area_m2, self.chamber_offset_m
        return (math.pi * self.outer_radius_m**4 / 4.0 - 3.0 * a_c**2 / (4.0 * math.pi)
                - 1.5 * a_c * d**2 - math.pi * self.central_cavity_radius_m**4 / 4.0)

    @property
    def wall_thickness_m(self) -> float:
        """The thinnest silicone wall of the cross-section (m): outer wall ``R - d - r``, wall
        to the central cavity ``d - r - r_c`` or wall between two bores ``sqrt(3) d - 2 r``,
        with ``r = sqrt(A_c / pi)`` the bore's radius."""
        r = math.sqrt(self.chamber_area_m2 / math.pi)
        d = self.chamber_offset_m
        return min(self.outer_radius_m - d - r, d - r - self.central_cavity_radius_m,
                   math.sqrt(3.0) * d - 2.0 * r)

    @property
    def bending_rigidity_nm2(self) -> float:
        """``E I`` (N m^2)."""
        return self.youngs_modulus_pa * self.second_moment_m4

    @property
    def axial_rigidity_n(self) -> float:
        """``E_a A`` (N)."""
        modulus = self.axial_modulus_pa if self.axial_modulus_pa is not None else self.youngs_modulus_pa
        return modulus * self.area_m2

    @property
    def torsional_rigidity_nm2(self) -> float:
        """``G J`` with ``J = 2 I`` (N m^2)."""
        shear = self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))
        return shear * 2.0 * self.second_moment_m4

    @property
    def max_length_m(self) -> float:
        """Longest the backbone can get (m): the thread's length, or else ``length_m`` times
        ``max_extension_ratio``."""
        if self.thread_length_m is not None:
            return float(self.thread_length_m)
        return self.length_m * self.max_extension_ratio

    @property
    def link_length_m(self) -> float:
        """Rest length ``ds = L / n_links`` of one link (m)."""
        return self.length_m / self.n_links

    @property
    def mass_kg(self) -> float:
        """Body mass without ``extra_tip_mass_kg`` (kg)."""
        return self.density_kg_m3 * self.area_m2 * self.length_m

    @property
    def chamber_angles_rad(self) -> np.ndarray:
        """Chamber angles ``sigma_i = 2 pi i / 3`` (rad), read-only
        (:data:`soft_gym.robots.actuation.CHAMBER_ANGLES_RAD`)."""
        return CHAMBER_ANGLES_RAD


ATMOSPHERIC_PA = 101_325.0
"""Standard atmospheric pressure (Pa): gauge pressures plus this are absolute."""


@dataclass(frozen=True)
class CylinderSpec:
    """The gas cylinders that drive chamber volumes (ho2018 Section 3.1: stepper-driven
    cylinders), one per chamber, all alike (docs/architecture.md, "Volume actuation").

    Each chamber, its cylinder and the dead volume between them hold a closed amount of gas at
    one temperature. The piston's stroke ``s`` (m, in ``[0, max_stroke_m]``) leaves
    ``V_cyl(s) = bore_area_m2 (max_stroke_m - s)`` of gas in the cylinder: ``s = 0`` is the rest
    stroke (cylinder full, every chamber at the pre-pressure with the arm at rest), a longer stroke
    pushes gas into the chamber. The gas law then gives the chamber's pressure from its current
    volume (:class:`soft_gym.robots.pneumatics.VolumeSupply`).

    Attributes:
        bore_area_m2: the piston's area ``A_b`` (m^2).
        max_stroke_m: the longest stroke ``S`` (m); a command outside ``[0, S]`` is refused.
            With the arm at rest, ``S`` must not raise a chamber above its ``p_max_pa``.
        dead_volume_m3: gas volume ``V_d`` (m^3) no stroke displaces (tubing, fittings, the
            cylinder's end clearance).
        atmospheric_pa: ambient pressure ``p_atm`` (Pa) that turns gauge into absolute
            pressures.
    """

    bore_area_m2: float
    max_stroke_m: float
    dead_volume_m3: float = 0.0
    atmospheric_pa: float = ATMOSPHERIC_PA

    def __post_init__(self) -> None:
        for name in ("bore_area_m2", "max_stroke_m", "atmospheric_pa"):
            require_positive(name, getattr(self, name))
        require_non_negative("dead_volume_m3", self.dead_volume_m3)


@dataclass(frozen=True)
class ArmSpec:
    """A whole arm: segments from base to tip plus mounting, pneumatics and timing.

    Attributes:
        name: preset name.
        segments: segments from base to tip.
        mount: one of :data:`MOUNTS`; sets gravity in the base frame (hanging: +z).
        pneumatic_time_constant_s: first-order lag from commanded to chamber pressure (s).
        control_period_s: environment step (s).
        physics_dt_s: physics substep (s); must divide ``control_period_s``.
        actuation_update_s: how often pressures, stiffening and scenario masses are refreshed
            inside a control step (s); a multiple of ``physics_dt_s``.
        mujoco_physics_dt_s: the MuJoCo engine's physics step (s; ``None``: ``physics_dt_s``),
            chosen per preset so that its tip stays within 0.5 mm of a 4x finer step
            (docs/architecture.md, "The MuJoCo engine"); ``actuation_update_s`` must be a whole
            multiple of it.
        description: where the numbers come from.
        cylinders: ``None`` (default): the chambers are driven by pressure (the commands are
            chamber pressures). A :class:`CylinderSpec`: volume actuation (ho2018 Section 3.1),
            each chamber a closed gas volume driven by a cylinder's stroke, its pressure
            following from the gas law (:class:`soft_gym.robots.pneumatics.VolumeSupply`).
            Shown in the repr (the calibration cache key) only when set, so pressure-driven
            arms keep their keys.
    """

    name: str
    segments: tuple[SegmentSpec, ...]
    mount: str = "hanging"
    pneumatic_time_constant_s: float = 0.15
    control_period_s: float = 0.05
    physics_dt_s: float = 2.5e-3
    actuation_update_s: float = 0.01
    # not in the repr (the calibration cache key): calibrations run on the PyBullet engine
    mujoco_physics_dt_s: float | None = field(default=None, repr=False)
    description: str = ""
    notes: dict = field(default_factory=dict, compare=False)
    cylinders: CylinderSpec | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.cylinders is not None and not isinstance(self.cylinders, CylinderSpec):
            raise ValueError(f"cylinders must be None or a CylinderSpec, got "
                             f"{type(self.cylinders).__name__}")
        if not self.segments:
            raise ValueError("segments must hold at least one SegmentSpec, got an empty tuple")
        for i, segment in enumerate(self.segments):
            if not isinstance(segment, SegmentSpec):
                raise ValueError(f"segments[{i}] must be a SegmentSpec, got {type(segment).__name__}")
        if self.mount not in MOUNTS:
            raise ValueError(f"mount must be one of {list(MOUNTS)}, got {self.mount!r}")
        for name in ("pneumatic_time_constant_s", "control_period_s", "physics_dt_s",
                     "actuation_update_s"):
            require_positive(name, getattr(self, name))
        steps = [("physics_dt_s", self.physics_dt_s)]
        if self.mujoco_physics_dt_s is not None:
            steps.append(("mujoco_physics_dt_s",
                          require_positive("mujoco_physics_dt_s", self.mujoco_physics_dt_s)))
        for step_name, step in steps:
            for name, value in (("control_period_s", self.control_period_s),
                                ("actuation_update_s", self.actuation_update_s)):
                ratio = value / step
                if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
                    raise ValueError(
                        f"{name}={value} must be a whole multiple of {step_name}={step}")

    def __repr__(self) -> str:
        # the dataclass repr, with ``cylinders`` appended only when set
        text = _dataclass_repr(self)
        if self.cylinders is None:
            return text
        return f"{text[:-1]}, cylinders={self.cylinders!r})"

    @property
    def actuation(self) -> str:
        """``"pressure"`` (commands are chamber pressures) or ``"volume"`` (cylinder strokes,
        :attr:`cylinders`)."""
        return "pressure" if self.cylinders is None else "volume"

    @property
    def n_segments(self) -> int:
        return len(self.segments)

    @property
    def n_chambers(self) -> int:
        return 3 * len(self.segments)

    @property
    def length_m(self) -> float:
        """Total rest length (m)."""
        return sum(segment.length_m for segment in self.segments)

    @cached_property
    def p_max_pa(self) -> np.ndarray:
        """Per-chamber pressure limit (Pa), shape (n_chambers,), read-only (computed once: the
        spec is frozen and this is read every control step)."""
        return _read_only(np.repeat([segment.p_max_pa for segment in self.segments], 3)
                          .astype(float))

    @cached_property
    def p_pre_pa(self) -> np.ndarray:
        """Per-chamber pre-pressure (Pa), shape (n_chambers,), read-only."""
        return _read_only(np.repeat([segment.p_pre_pa for segment in self.segments], 3)
                          .astype(float))

    @cached_property
    def chamber_offset_m(self) -> np.ndarray:
        """Per-segment chamber offset ``d`` (m), shape (n_segments,), read-only."""
        return _read_only(np.array([segment.chamber_offset_m for segment in self.segments]))

    @property
    def substeps_per_control(self) -> int:
        return int(round(self.control_period_s / self.physics_dt_s))

    @property
    def first_bending_mode_rad_s(self) -> float:
        """First bending mode of the whole arm as one cantilever (rad/s):
        ``3.516 sqrt(E I / (mu L^4))`` with ``E I`` the series (length-weighted harmonic) mean and
        ``mu`` the total mass, tip masses included, over the total length."""
        length = self.length_m
        rigidity = length / sum(s.length_m / s.bending_rigidity_nm2 for s in self.segments)
        mu = sum(s.mass_kg + s.extra_tip_mass_kg for s in self.segments) / length
        return 3.516 * math.sqrt(rigidity / (mu * length**4))

    def damping_time_s(self, segment: SegmentSpec) -> float:
        """Stiffness-proportional damping coefficient ``2 zeta / omega_1`` of ``segment`` (s)."""
        return 2.0 * segment.damping_ratio / self.first_bending_mode_rad_s

    @property
    def mass_kg(self) -> float:
        """Mass of the whole arm, fixed tip masses included (kg)."""
        return sum(segment.mass_kg + segment.extra_tip_mass_kg for segment in self.segments)

    @property
    def max_load_n(self) -> float:
        """Largest total load the arm accepts (N): its mount's ``MAX_LOAD_TO_WEIGHT`` times its
        weight."""
        return MAX_LOAD_TO_WEIGHT[self.mount] * self.mass_kg * GRAVITY_M_S2

    @property
    def max_reach_m(self) -> float:
        """Farthest the tip can be from the base (m): every link at its longest (a segment's thread,
        where it has one, :attr:`SegmentSpec.max_length_m`)."""
        return sum(segment.max_length_m for segment in self.segments)

    @property
    def gravity_base(self) -> np.ndarray:
        """Gravity in the base frame (m/s^2) for the mount."""
        g = GRAVITY_M_S2
        return {"hanging": np.array([0.0, 0.0, g]), "upright": np.array([0.0, 0.0, -g]),
                "horizontal": np.array([-g, 0.0, 0.0])}[self.mount]


def _read_only(array: np.ndarray) -> np.ndarray:
    """``array``, marked read-only (a cached value shared by every reader)."""
    array.flags.writeable = False
    return array


def _dataclass_repr(spec: ArmSpec) -> str:
    """What the dataclass's own repr gives: every field shown in the repr, in order."""
    return (f"{type(spec).__name__}(" + ", ".join(
        f"{f.name}={getattr(spec, f.name)!r}" for f in fields(spec) if f.repr) + ")")

