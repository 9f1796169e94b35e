"""Roll out every arm preset under a few pressure patterns and print tip positions and bending.

    python -m soft_gym.demo [--presets wang2023 ho2018] [--hold-s 2.0]

For each preset and pattern the arm starts at rest (pre-pressure, gravity from its mount), the
pattern is commanded, and after ``--hold-s`` seconds of simulated time the table lists the tip
position (mm, base frame), its distance from the rest tip (mm), the tip's bending angle from the
base axis (deg) and the mean chamber length (mm).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from soft_gym._cli import CommandParser, HelpFormatter, finite_float
from soft_gym.robots.actuation import pressure_at_fraction
from soft_gym.robots.presets import PRESETS
from soft_gym.engines import make_simulator

PATTERNS = {
    "rest": lambda n: np.zeros(n),
    "chamber 0 full": lambda n: np.tile([1.0, 0.0, 0.0], n // 3),
    "chambers 0+1 half": lambda n: np.tile([0.5, 0.5, 0.0], n // 3),
    "all full": lambda n: np.ones(n),
    "distal chamber 1 full": lambda n: np.r_[np.zeros(n - 3), [0.0, 1.0, 0.0]],
}
"""Fractions of the way from pre-pressure to p_max, per chamber."""


def run(presets: list[str], hold_s: float) -> list[dict]:
    rows = []
    for name in presets:
        spec = PRESETS[name]
        sim = make_simulator(spec)
        sim.reset(settle_s=1.0)
        rest_tip = sim.tip_pose()[0]
        for pattern, make in PATTERNS.items():
            fraction = make(spec.n_chambers)
            sim.reset(settle_s=1.0)
            sim.set_pressures(pressure_at_fraction(spec, fraction))
            start = time.perf_counter()
            sim.step_physics(hold_s)
            wall = time.perf_counter() - start
            tip, quaternion = sim.tip_pose()
            backbone = sim.backbone()
            tangent = backbone[-1] - backbone[-2]
            angle = np.degrees(np.arccos(np.clip(tangent[2] / np.linalg.norm(tangent), -1, 1)))
            rows.append({"preset": name, "pattern": pattern, "tip_mm": tip * 1000,
                         "moved_mm": np.linalg.norm(tip - rest_tip) * 1000, "bend_deg": angle,
                         "mean_chamber_mm": sim.chamber_lengths().mean() * 1000,
                         "realtime_factor": hold_s / wall})
        sim.close()
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="python -m soft_gym.demo", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", default=list(PRESETS), choices=list(PRESETS),
                        help="arm presets to roll out")
    parser.add_argument("--hold-s", type=finite_float(0.0, 600.0, low_open=True), default=2.0,
                        help="simulated seconds each pattern is held before reading, in (0, 600]")
    args = parser.parse_args(argv)
    rows = run(args.presets, args.hold_s)
    header = (f"{'preset':<10} {'pattern':<22} {'tip x':>8} {'tip y':>8} {'tip z':>8} "
              f"{'moved':>8} {'bend':>6} {'chamber':>8} {'x real':>7}")
    print(header)
    print(f"{'':<10} {'':<22} {'(mm)':>8} {'(mm)':>8} {'(mm)':>8} {'(mm)':>8} {'(deg)':>6} "
          f"{'(mm)':>8} {'time':>7}")
    print("-" * len(header))
    for row in rows:
        x, y, z = row["tip_mm"]
        print(f"{row['preset']:<10} {row['pattern']:<22} {x:8.1f} {y:8.1f} {z:8.1f} "
              f"{row['moved_mm']:8.1f} {row['bend_deg']:6.1f} {row['mean_chamber_mm']:8.1f} "
              f"{row['realtime_factor']:7.1f}")


if __name__ == "__main__":
    main()
