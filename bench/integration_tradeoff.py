"""Links per segment and physics step: speed against accuracy, measured side by side.

For one preset (default wang2023) and every combination of ``--links`` and ``--dt-ms`` this prints

* ``steps/s``: simulated control steps per wall second (physics only, no env wrapper);
* ``dyn dev``: the largest tip deviation (mm) from the same run at a 4x smaller physics step,
  over a seeded sequence of random pressure commands each held for ``--hold-steps`` control steps;
* ``arc err``: gravity and stiffening off, one chamber at half pressure (a pure moment): the
  largest distance of a backbone vertex from the analytic arc ``kappa = M / (E I)`` (stretched
  by the measured axial strain), in % of L;
* ``beam err``: gravity and stiffening off, a transverse tip force: the tip deflection's relative
  error against ``F L^3 / (3 E I)`` (%).

    python bench/integration_tradeoff.py --preset wang2023 --links 3 4 6 8 --dt-ms 1.25 2.5 5
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import numpy as np

from soft_gym._cli import CommandParser, HelpFormatter
from soft_gym.robots.pneumatics import chamber_loads
from soft_gym.robots.presets import PRESETS
from soft_gym.robots.spec import ArmSpec
from soft_gym.engines.pybullet.simulator import ArmSimulator


def variant(spec: ArmSpec, n_links: int, dt_s: float, linear: bool = False) -> ArmSpec:
    """``spec`` with ``n_links`` per segment and physics step ``dt_s`` (optionally linear)."""
    extra = {"bending_stiffening": 0.0, "axial_stiffening": 0.0} if linear else {}
    segments = tuple(dataclasses.replace(s, n_links=n_links, **extra) for s in spec.segments)
    return dataclasses.replace(spec, segments=segments, physics_dt_s=dt_s)


def random_run(spec: ArmSpec, steps: int, hold_steps: int, seed: int) -> tuple[np.ndarray, float]:
    sim = ArmSimulator(spec)
    rng = np.random.default_rng(seed)
    sim.reset(settle_s=0.5)
    tips = np.empty((steps, 3))
    start = time.perf_counter()
    for k in range(steps):
        if k % hold_steps == 0:
            fraction = rng.uniform(0, 1, spec.n_chambers)
            sim.set_pressures(spec.p_pre_pa + fraction * (spec.p_max_pa - spec.p_pre_pa))
        sim.step_physics(spec.control_period_s)
        tips[k] = sim.tip_pose()[0]
    rate = steps / (time.perf_counter() - start)
    sim.close()
    return tips, rate


def arc_error_percent(spec: ArmSpec) -> float:
    """Pure moment on a weightless, linear single segment vs the analytic arc (% of L)."""
    sim = ArmSimulator(spec)
    sim.set_gravity([0.0, 0.0, 0.0])
    pressure = np.zeros(spec.n_chambers)
    pressure[0] = 0.5 * spec.p_max_pa[0]
    sim.reset(pressure_pa=pressure)
    sim.set_pressures(pressure)
    sim.step_physics(3.0)
    segment = spec.segments[0]
    _, moment = chamber_loads(spec, pressure)
    kappa = np.linalg.norm(moment[0]) / segment.bending_rigidity_nm2
    points = sim.backbone()[: segment.n_links + 1]
    # the moment bends each rest length element by kappa ds; the pressure's axial force also
    # stretches the segment uniformly by (1 + strain), which scales the arc
    strain = sim.joint_positions()[sim.arm.station_axial_joint].mean() / segment.link_length_m
    rest_arc = np.arange(segment.n_links + 1) * segment.link_length_m
    # chamber 0 at +x bends the segment towards -x, in the x-z plane
    analytic = (1 + strain) * np.stack([-(1 - np.cos(kappa * rest_arc)) / kappa,
                                        np.zeros_like(rest_arc),
                                        np.sin(kappa * rest_arc) / kappa], axis=1)
    sim.close()
    return float(np.linalg.norm(points - analytic, axis=1).max() / segment.length_m * 100)


def beam_error_percent(spec: ArmSpec) -> float:
    """Small transverse tip force on a weightless, linear segment vs F L^3 / (3 E I) (%)."""
    sim = ArmSimulator(spec)
    sim.set_gravity([0.0, 0.0, 0.0])
    segment = spec.segments[0]
    force = 0.02 * segment.bending_rigidity_nm2 / segment.length_m**2
    sim.apply_tip_force([force, 0.0, 0.0])
    sim.step_physics(3.0)
    deflection = sim.tip_pose()[0][0]
    expected = force * segment.length_m**3 / (3 * segment.bending_rigidity_nm2)
    sim.close()
    return float((deflection - expected) / expected * 100)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--preset", default="wang2023", choices=sorted(PRESETS),
                        help="arm preset to vary")
    parser.add_argument("--links", type=int, nargs="+", default=[3, 4, 6, 8],
                        help="links per segment to compare")
    parser.add_argument("--dt-ms", type=float, nargs="+", default=[1.25, 2.5, 5.0],
                        help="physics steps to compare (ms); must divide the actuation update")
    parser.add_argument("--steps", type=int, default=80, help="control steps per dynamic run")
    parser.add_argument("--hold-steps", type=int, default=10,
                        help="control steps each random command is held")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random commands")
    parser.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = parser.parse_args(argv)
    base = PRESETS[args.preset]
    rows = []
    print(f"{'links':>5} {'dt ms':>6} {'steps/s':>8} {'dyn dev mm':>10} {'arc err %L':>10} "
          f"{'beam err %':>10}")
    for n_links in args.links:
        static_spec = variant(base, n_links, base.physics_dt_s, linear=True)
        arc = arc_error_percent(static_spec) if base.n_segments == 1 else float("nan")
        beam = beam_error_percent(static_spec) if base.n_segments == 1 else float("nan")
        for dt_ms in args.dt_ms:
            spec = variant(base, n_links, dt_ms / 1000)
            fine = variant(base, n_links, dt_ms / 4000)
            tips, rate = random_run(spec, args.steps, args.hold_steps, args.seed)
            reference, _ = random_run(fine, args.steps, args.hold_steps, args.seed)
            deviation = float(np.linalg.norm(tips - reference, axis=1).max() * 1000)
            row = {"preset": args.preset, "links": n_links, "dt_ms": dt_ms, "steps_per_s": rate,
                   "dynamic_deviation_mm": deviation, "arc_error_percent_L": arc,
                   "beam_error_percent": beam}
            rows.append(row)
            print(f"{n_links:5d} {dt_ms:6.2f} {rate:8.0f} {deviation:10.3f} {arc:10.2f} "
                  f"{beam:10.2f}", flush=True)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)


if __name__ == "__main__":
    main()
