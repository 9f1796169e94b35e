"""The zhao2021 arm fitted jointly to its paper's key points and to the poses its experiments need.

zhao2021 states the arm's outer diameter (35 mm), material (E = 15 psi, nu = 0.48,
1.07 g/cm^3, Table I), the threads' 150 mm limit and the 0-0.8 bar range; it does not state the
rest length, the chambers' offset and bore, how the thread-wound bores respond to pressure, the
rings' mass, nor where its key-point frame sits. :func:`fit_arm` fits those to

* Table III: the six key points under regulator pressures (0, 0.5, 0.6, 0.8, 0.7, 0) bar (paper
  frame, mm), and
* the experiments of Sections VI-C and VI-D: the point-to-point start (40, 20, 300) mm with the arm
  free and with the swaying 119 g block, the goal (-50, 70, 210) mm with the heaviest static load
  (100 g), and points of the 100 mm circle, free and carrying the 263 g block,

in one ``scipy.optimize.least_squares``: the arm's parameters and, for every pose, the six
pressures that hold it are the unknowns; the residuals are the key points' errors and every
pose's tip-to-target distance (mm, weighted). Each pose is a static equilibrium of the chain
(:class:`~soft_gym.robots.statics.StaticArm`), so a fit takes a minute or two, not hours of
simulated settling. ``python -m soft_gym.papers.zhao2021.arm_fit`` runs it and prints the
residuals; the preset's notes carry them (docs/architecture.md, "zhao2021 arm fit").
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from soft_gym._cli import CommandParser, HelpFormatter, finite_float, int_at_least
from soft_gym.procedures.static_reach import closest_reach
from soft_gym.papers.zhao2021.arm import ZHAO2021
from soft_gym.papers.zhao2021.frames import (ZHAO2021_PAPER_CHAMBERS, base_point_from_paper,
                                             paper_point_from_base, paper_pressures_to_chambers)
from soft_gym.robots.spec import ArmSpec
from soft_gym.robots.statics import StaticArm
from soft_gym.sensing.key_points import key_points_from_backbone

BAR_PA = 1e5
TABLE3_PRESSURES_BAR = (0.0, 0.5, 0.6, 0.8, 0.7, 0.0)
"""zhao2021 Table III: regulators 1-6 in the paper's order (bar)."""
TABLE3_KEY_POINTS_MM = np.array([[-0.1, 0.5, 49.6], [4.2, 4.9, 90.1], [3.8, 9.6, 133.2],
                                 [-22.6, 19.9, 172.9], [-35.9, 35.2, 210.8],
                                 [-58.7, 64.7, 248.5]])
"""zhao2021 Table III: "True Position" of P1..P6 (mm, paper frame)."""
P2P_START_MM = (40.0, 20.0, 300.0)
P2P_GOAL_MM = (-50.0, 70.0, 210.0)
"""zhao2021 Section VI-C: the point-to-point start and goal (mm, paper frame)."""
P2P_LOADS_KG = (0.0, 0.050, 0.075, 0.100)
"""zhao2021 Section VI-C-1: the tip loads of the point-to-point runs (kg)."""
SWAY_MASS_KG = 0.119
"""zhao2021 Section VI-C-2: the swaying aluminium block (kg)."""
CIRCLE_DIAMETER_MM = 100.0
CIRCLE_MASS_KG = 0.263
"""zhao2021 Section VI-D: the circle's diameter (mm) and the block added at step 29 (kg)."""
CIRCLE_FIT_POINTS = 4
"""Points of the circle (evenly spaced, the first on the paper's +x) held in the fit, free and
loaded."""
MIN_WALL_M = 1.5e-3
"""Thinnest silicone wall a moulded bore may leave (m): outside, between bores, around the
thread."""


@dataclass(frozen=True)
class ArmParameters:
    """What the fit chooses: both segments moulded alike (the paper makes them the same way),
    each wound on its own.

    Attributes:
        length_m: each segment's rest length (m); the thread stops it at 150 mm.
        chamber_offset_m: chamber centre's distance from the axis (m).
        bore_radius_m: a chamber's bore radius at rest (m).
        growth: segment 1's bores' area growth ``g`` at 0.8 bar.
        growth_exponent: segment 1's growth law's exponent ``n``.
        distal_growth, distal_growth_exponent: the same of segment 2 (each segment is wound
            with its own nylon thread, by hand).
        ring_mass_kg: a segment's distal PLA ring (kg).
        origin_z_m: the paper's origin above our base along the axis (m): the base ring.
        frame_deg: the paper's x axis turned from ours about the axis (deg).
        circle_z_mm: the circle's height in the paper's frame (mm): not stated.
    """

    length_m: float
    chamber_offset_m: float
    bore_radius_m: float
    growth: float
    growth_exponent: float
    distal_growth: float
    distal_growth_exponent: float
    ring_mass_kg: float
    origin_z_m: float
    frame_deg: float
    circle_z_mm: float

    def spec(self, base: ArmSpec = ZHAO2021) -> ArmSpec:
        """``base`` with these parameters on every segment."""
        growths = ((self.growth, self.growth_exponent),
                   (self.distal_growth, self.distal_growth_exponent))
        segments = tuple(dataclasses.replace(
            segment, length_m=self.length_m, chamber_offset_m=self.chamber_offset_m,
            chamber_area_m2=math.pi * self.bore_radius_m ** 2, chamber_area_growth=growth,
            chamber_area_growth_exponent=exponent,
            extra_tip_mass_kg=self.ring_mass_kg, max_extension_ratio=MAX_EXTENSION_RATIO)
            for segment, (growth, exponent) in zip(base.segments, growths))
        return dataclasses.replace(base, segments=segments)

    def base_from_paper(self, point_mm: np.ndarray) -> np.ndarray:
        """A paper-frame point (mm) in our base frame (m), in this fit's paper frame."""
        return base_point_from_paper(np.asarray(point_mm, dtype=float) / 1000.0,
                                     self.frame_deg, self.origin_z_m)

    def paper_from_base(self, points_m: np.ndarray) -> np.ndarray:
        """Base-frame points (m, (..., 3)) in this fit's paper frame (mm)."""
        return 1000.0 * paper_point_from_base(points_m, self.frame_deg, self.origin_z_m)


MAX_EXTENSION_RATIO = 2.0
"""The segments' material limit on stretch (longest over rest length): above what the thread
allows (it only bounds the thread, :attr:`~soft_gym.robots.spec.SegmentSpec.thread_length_m`),
so rest lengths down to 75 mm are open to the fit."""

BOUNDS = {"length_m": (0.080, 0.150), "chamber_offset_m": (0.005, 0.0125),
          "bore_radius_m": (0.003, 0.0085), "growth": (0.0, 4.0), "growth_exponent": (1.0, 6.0),
          "distal_growth": (0.0, 4.0), "distal_growth_exponent": (1.0, 6.0),
          "ring_mass_kg": (0.003, 0.008), "origin_z_m": (0.0, 0.010),
          "frame_deg": (0.0, 360.0), "circle_z_mm": (180.0, 300.0)}
"""Physically plausible range of each parameter: rest lengths from which 0.8 bar can stretch a
segment to its 150 mm thread (silicone at 15 psi stretches that far under the chambers'
end-cap force), bores and offsets inside the 35 mm
body, a bore at most five times its area at 0.8 bar, 35 mm PLA rings 2.5-6.5 mm thick
(1.29 g/cm^3, Table I), up to 10 mm of ring below the paper's origin (its arm is 310 mm long
with 300 mm of thread, Section VI-E)."""


def walls_m(parameters: ArmParameters) -> float:
    """The thinnest wall of the cross-section (m) (see
    :attr:`~soft_gym.robots.spec.SegmentSpec.wall_thickness_m`)."""
    r, d = parameters.bore_radius_m, parameters.chamber_offset_m
    return min(ZHAO2021.segments[0].outer_radius_m - d - r, d - r, math.sqrt(3.0) * d - 2 * r)


@dataclass(frozen=True)
class Pose:
    """A pose the arm must hold: a target (paper frame, mm) with a tip mass (kg)."""

    name: str
    target_mm: tuple[float, float, float] | None  # None: a circle point, see circle_index
    mass_kg: float
    circle_index: int = -1


def fit_poses() -> list[Pose]:
    """The poses of the fit: start free and with the swaying block, goal with 100 g, the
    circle's points free and with 263 g."""
    poses = [Pose("start, free", P2P_START_MM, 0.0),
             Pose(f"start, {SWAY_MASS_KG * 1000:.0f} g", P2P_START_MM, SWAY_MASS_KG),
             Pose(f"goal, {max(P2P_LOADS_KG) * 1000:.0f} g", P2P_GOAL_MM, max(P2P_LOADS_KG))]
    for mass in (0.0, CIRCLE_MASS_KG):
        for i in range(CIRCLE_FIT_POINTS):
            poses.append(Pose(f"circle {i}, {mass * 1000:.0f} g", None, mass, i))
    return poses


def circle_point_mm(index: int, z_mm: float, n: int = CIRCLE_FIT_POINTS) -> np.ndarray:
    """Point ``index`` of ``n`` on the 100 mm circle about the paper's z axis at ``z_mm``."""
    angle = 2 * np.pi * index / n
    radius = CIRCLE_DIAMETER_MM / 2
    return np.array([radius * np.cos(angle), radius * np.sin(angle), z_mm])


def target_mm(pose: Pose, parameters: ArmParameters) -> np.ndarray:
    return (np.asarray(pose.target_mm, dtype=float) if pose.circle_index < 0
            else circle_point_mm(pose.circle_index, parameters.circle_z_mm))


@dataclass
class FitResult:
    """A fit's arm and what it leaves: Table III's key-point errors, each pose's distance."""

    parameters: ArmParameters
    key_point_errors_mm: np.ndarray
    pose_distances_mm: dict[str, float]
    pose_pressures_bar: dict[str, np.ndarray]

    @property
    def key_point_rms_mm(self) -> float:
        return float(np.sqrt(np.mean(self.key_point_errors_mm ** 2)))


class _Problem:
    """The joint least-squares problem: arm parameters, then six pressure fractions per pose."""

    def __init__(self, pose_weight: float, poses: list[Pose]) -> None:
        self.names = list(BOUNDS)
        self.poses = poses
        self.pose_weight = pose_weight
        self.n_arm = len(self.names)
        self._q: dict[int, np.ndarray] = {}

    def parameters(self, x: np.ndarray) -> ArmParameters:
        return ArmParameters(**dict(zip(self.names, map(float, x[:self.n_arm]))))

    def fractions(self, x: np.ndarray, i: int) -> np.ndarray:
        return x[self.n_arm + 6 * i:self.n_arm + 6 * (i + 1)]

    def table3(self, arm: StaticArm, parameters: ArmParameters) -> np.ndarray:
        state = arm.equilibrium(paper_pressures_to_chambers(np.array(TABLE3_PRESSURES_BAR) * BAR_PA),
                               q_start=self._q.get(-1))
        self._q[-1] = state.q
        points = parameters.paper_from_base(key_points_from_backbone(arm.spec, state.backbone_m))
        return (points - TABLE3_KEY_POINTS_MM).ravel()

    def pose(self, arm: StaticArm, parameters: ArmParameters, x: np.ndarray, i: int
             ) -> np.ndarray:
        pose = self.poses[i]
        pressures = np.clip(self.fractions(x, i), 0.0, 1.0) * arm.spec.p_max_pa
        state = arm.equilibrium(pressures, tip_mass_kg=pose.mass_kg, q_start=self._q.get(i))
        self._q[i] = state.q
        tip_mm = parameters.paper_from_base(state.tip_m)
        return self.pose_weight * (tip_mm - target_mm(pose, parameters))

    def wall(self, parameters: ArmParameters) -> np.ndarray:
        return np.array([1e6 * max(0.0, MIN_WALL_M - walls_m(parameters))])

    def residuals(self, x: np.ndarray) -> np.ndarray:
        parameters = self.parameters(x)
        arm = StaticArm(parameters.spec())
        parts = [self.table3(arm, parameters)]
        parts += [self.pose(arm, parameters, x, i) for i in range(len(self.poses))]
        parts.append(self.wall(parameters))
        return np.concatenate(parts)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Forward differences, exploiting that a pose's pressures move only its residuals."""
        base = self.residuals(x)
        jac = np.zeros((len(base), len(x)))
        steps = {name: 1e-6 * (hi - lo) for name, (lo, hi) in BOUNDS.items()}
        for j, name in enumerate(self.names):
            shifted = x.copy()
            step = steps[name] if x[j] + steps[name] <= BOUNDS[name][1] else -steps[name]
            shifted[j] += step
            jac[:, j] = (self.residuals(shifted) - base) / step
        parameters = self.parameters(x)
        arm = StaticArm(parameters.spec())
        for i in range(len(self.poses)):
            first = TABLE3_KEY_POINTS_MM.size  # Table III's residuals come first
            rows = slice(first + 3 * i, first + 3 * (i + 1))
            for k in range(6):
                column = self.n_arm + 6 * i + k
                shifted = x.copy()
                step = 1e-5 if x[column] + 1e-5 <= 1.0 else -1e-5
                shifted[column] += step
                jac[rows, column] = (self.pose(arm, parameters, shifted, i) - base[rows]) / step
        return jac


def fit_arm(start: ArmParameters, pose_weight: float = 3.0, max_nfev: int = 60,
            poses: list[Pose] | None = None, verbose: int = 0) -> FitResult:
    """Fit the arm jointly to Table III and the experiments' poses.

    Args:
        start: the parameters to start from.
        pose_weight: weight of a pose's tip-to-target distance against a key point's error.
        max_nfev: most residual evaluations of ``least_squares``.
        poses: the poses to hold (default :func:`fit_poses`).
        verbose: ``least_squares``'s verbosity.
    """
    poses = fit_poses() if poses is None else poses
    problem = _Problem(pose_weight, poses)
    x0 = [getattr(start, name) for name in problem.names]
    arm = StaticArm(start.spec())
    for pose in poses:  # each pose's pressures start where the tip gets nearest its target
        reach = closest_reach(arm, start.base_from_paper(target_mm(pose, start)), pose.mass_kg)
        x0 += list(reach.pressures_pa / arm.spec.p_max_pa)
    lower = [BOUNDS[name][0] for name in problem.names] + [0.0] * 6 * len(poses)
    upper = [BOUNDS[name][1] for name in problem.names] + [1.0] * 6 * len(poses)
    x0 = np.clip(np.array(x0), lower, upper)
    fit = least_squares(problem.residuals, x0, jac=problem.jacobian, bounds=(lower, upper),
                        max_nfev=max_nfev, verbose=verbose, x_scale="jac")
    return evaluate(problem.parameters(fit.x), poses)


def evaluate_table3(parameters: ArmParameters) -> np.ndarray:
    """Distance of each of Table III's key points P1..P6 (mm) from where the arm of
    ``parameters`` rests under the table's pressures."""
    arm = StaticArm(parameters.spec())
    residual = _Problem(1.0, []).table3(arm, parameters)
    return np.linalg.norm(residual.reshape(6, 3), axis=1)


def evaluate(parameters: ArmParameters, poses: list[Pose] | None = None) -> FitResult:
    """Table III's key-point errors (mm) and every pose's nearest distance (mm, by a fresh
    pressure search, :func:`~soft_gym.procedures.static_reach.closest_reach`) for
    ``parameters``."""
    poses = fit_poses() if poses is None else poses
    arm = StaticArm(parameters.spec())
    errors = evaluate_table3(parameters)
    distances, pressures = {}, {}
    for pose in poses:
        reach = closest_reach(arm, parameters.base_from_paper(target_mm(pose, parameters)),
                              pose.mass_kg)
        distances[pose.name] = reach.distance_m * 1000.0
        pressures[pose.name] = reach.pressures_pa[np.argsort(ZHAO2021_PAPER_CHAMBERS)] / BAR_PA
    return FitResult(parameters, errors, distances, pressures)


ZHAO2021_ARM_FIT = ArmParameters(
    length_m=0.1009, chamber_offset_m=0.01181, bore_radius_m=0.00361, growth=3.96,
    growth_exponent=6.0, distal_growth=3.22, distal_growth_exponent=5.79, ring_mass_kg=0.008,
    origin_z_m=0.0099, frame_deg=172.4, circle_z_mm=260.4)
"""The preset's arm (:data:`soft_gym.papers.zhao2021.arm.ZHAO2021`): every pose of the paper's
experiments held (the goal with 100 g within 1 mm), Table III's key points RMS 29 mm
(``fit_arm`` with ``pose_weight`` 20, rounded). docs/architecture.md, "zhao2021 arm fit"."""

ZHAO2021_TABLE3_FIT = ArmParameters(
    length_m=0.1075, chamber_offset_m=0.00693, bore_radius_m=0.00520, growth=3.34,
    growth_exponent=5.67, distal_growth=0.64, distal_growth_exponent=2.34, ring_mass_kg=0.0065,
    origin_z_m=0.0039, frame_deg=151.4, circle_z_mm=268.8)
"""The arm fitted to Table III with every pose but the goal (``fit_arm`` with the goal's pose
left out, ``pose_weight`` 5, rounded): key points RMS 6.7 mm, but the goal out of reach by
23-34 mm with 0-100 g. The measured conflict (docs/architecture.md, "zhao2021 arm fit")."""


def report(result: FitResult) -> str:
    """The fit's parameters and residuals as text."""
    lines = [f"{name} = {value:.6g}" for name, value in
             dataclasses.asdict(result.parameters).items()]
    lines.append("Table III key-point errors (mm): "
                 + ", ".join(f"{e:.2f}" for e in result.key_point_errors_mm)
                 + f"; RMS {result.key_point_rms_mm:.2f}")
    lines.append(f"thinnest wall {walls_m(result.parameters) * 1000:.2f} mm")
    for name, distance in result.pose_distances_mm.items():
        lines.append(f"{name}: {distance:.2f} mm off, pressures (paper order, bar) "
                     + " ".join(f"{p:.3f}" for p in result.pose_pressures_bar[name]))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(
        prog="python -m soft_gym.papers.zhao2021.arm_fit", description=__doc__,
        formatter_class=HelpFormatter)
    parser.add_argument("--pose-weight", type=finite_float(low=0.0), default=20.0,
                        help="weight of a pose's distance (mm) against a key point's error "
                             "(mm), >= 0; 0 fits Table III alone")
    parser.add_argument("--max-nfev", type=int_at_least(1), default=60,
                        help="most residual evaluations of the least-squares fit, >= 1 (each "
                             "about 10 s on one core; it starts from the preset's arm)")
    parser.add_argument("--evaluate-only", action="store_true",
                        help="only report the preset's residuals")
    args = parser.parse_args(argv)
    if args.evaluate_only:
        print(report(evaluate(ZHAO2021_ARM_FIT)))
        return
    print(report(fit_arm(ZHAO2021_ARM_FIT, args.pose_weight, args.max_nfev, verbose=2)))


if __name__ == "__main__":
    main()
