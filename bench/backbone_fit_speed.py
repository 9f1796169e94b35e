"""Fits per second of the zhao2021 backbone fit, eqs. (7)-(10) (soft_gym.papers.zhao2021.backbone_fit).

The shape-reconstruction pipeline of Zhao et al. 2021 runs six key-point networks and this fit per
estimate and must reach >= 50 estimates/s on one core, so the fit's budget is 10 ms per call. The
script draws random two-segment constant-curvature shapes (2 x 150 mm, bends up to
``--max-bend-deg`` per segment in random planes; key points at s = 0, 50, ..., 300 mm, optionally
with uniform noise ``U(-xi, xi)`` per coordinate as in the paper's Table II), fits each once
untimed (warm-up) and then ``--repeats`` times timed, and prints the mean, 95th-percentile and
maximum milliseconds per fit, the fits per second, how often the paper's ISF was used per
subsegment (the rest is the cubic fallback) and the mean eq. (21) error against the true backbone.
Timings are wall-clock (``time.perf_counter``), one process; run with ``OPENBLAS_NUM_THREADS=1``
for one core.

Example::

    PYTHONPATH=. python bench/backbone_fit_speed.py
    PYTHONPATH=. python bench/backbone_fit_speed.py --noise-mm 3 --curve cubic_fallback --json fit.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from soft_gym._cli import CommandParser, HelpFormatter  # noqa: E402
from soft_gym.kinematics import cc_backbone, lengths_from_curvature  # noqa: E402
from soft_gym.papers.zhao2021.backbone_fit import (BACKBONE_CURVES, fit_backbone,  # noqa: E402
                                                    mean_backbone_error_m)

SEGMENT_M = 0.15
CHAMBER_DISTANCE_M = 0.01
BUDGET_MS = 10.0


def random_shapes(count: int, max_bend_deg: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Key points (count, 7, 3) and true backbones (count, 301, 3) of random CC arms."""
    rng = np.random.default_rng(seed)
    theta = np.radians(rng.uniform(0.0, max_bend_deg, (count, 2)))
    phi = rng.uniform(-np.pi, np.pi, (count, 2))
    kappa = theta / SEGMENT_M
    lengths = lengths_from_curvature(np.full((count, 2), SEGMENT_M), kappa * np.cos(phi),
                                     kappa * np.sin(phi), CHAMBER_DISTANCE_M)
    return (cc_backbone(lengths, CHAMBER_DISTANCE_M, points_per_segment=3),
            cc_backbone(lengths, CHAMBER_DISTANCE_M, points_per_segment=150))


def main(argv: list[str] | None = None) -> dict:
    parser = CommandParser(
        description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--shapes", type=int, default=200, help="random arm shapes")
    parser.add_argument("--repeats", type=int, default=5, help="timed fits per shape")
    parser.add_argument("--max-bend-deg", type=float, default=120.0,
                        help="largest bending angle per segment (deg)")
    parser.add_argument("--noise-mm", type=float, default=0.0,
                        help="key-point noise xi: U(-xi, xi) mm per coordinate of P1..P6")
    parser.add_argument("--n-points", type=int, default=60, help="points of the fitted backbone")
    parser.add_argument("--curve", choices=BACKBONE_CURVES, default="paper",
                        help="the fitted curve (default: paper, eqs. 7-10 in each "
                             "subsegment's frame)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the shapes and the noise")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    args = parser.parse_args(argv)
    if args.shapes < 1 or args.repeats < 1 or args.n_points < 2 or args.noise_mm < 0 \
            or not 0 <= args.max_bend_deg < 180:
        parser.error("shapes, repeats >= 1, n-points >= 2, noise-mm >= 0, "
                     "0 <= max-bend-deg < 180")

    key_points, true = random_shapes(args.shapes, args.max_bend_deg, args.seed)
    rng = np.random.default_rng(args.seed + 1)
    noise_mm = rng.uniform(-args.noise_mm, args.noise_mm, key_points[:, 1:].shape)
    key_points[:, 1:] += 1e-3 * noise_mm

    times, errors, methods = [], [], []
    for points, backbone in zip(key_points, true):
        fit = fit_backbone(points, args.n_points, curve=args.curve)  # warm-up
        errors.append(mean_backbone_error_m(backbone, fit.points_m))
        methods.extend(fit.methods)
        for _ in range(args.repeats):
            start = time.perf_counter()
            fit_backbone(points, args.n_points, curve=args.curve)
            times.append(time.perf_counter() - start)
    ms = 1e3 * np.array(times)
    errors_mm = 1e3 * np.array(errors)
    isf_fraction = float(np.mean(np.array(methods) == "isf"))
    results = {
        "settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "mean_ms": float(ms.mean()), "p95_ms": float(np.percentile(ms, 95)),
        "max_ms": float(ms.max()), "fits_per_s": float(1e3 / ms.mean()),
        "isf_fraction": isf_fraction,
        "mean_error_mm": float(errors_mm.mean()),
        "p95_error_mm": float(np.percentile(errors_mm, 95)),
        "max_error_mm": float(errors_mm.max()),
        "versions": {"python": platform.python_version(), "numpy": np.__version__,
                     "scipy": scipy.__version__},
        "machine": platform.platform(),
    }
    print(f"fit_backbone (curve={args.curve}): {args.shapes} random two-segment CC shapes up to "
          f"{args.max_bend_deg:g} deg per segment, key-point noise xi = {args.noise_mm:g} mm, "
          f"{args.n_points} output points, {len(ms)} timed fits")
    print(f"{'':14s}{'mean':>9s}{'p95':>9s}{'max':>9s}")
    print(f"{'ms per fit':14s}{ms.mean():9.3f}{np.percentile(ms, 95):9.3f}{ms.max():9.3f}")
    print(f"{'eq.(21) mm':14s}{errors_mm.mean():9.2f}{np.percentile(errors_mm, 95):9.2f}"
          f"{errors_mm.max():9.2f}")
    print(f"fits per second: {results['fits_per_s']:.0f}")
    print(f"subsegments fitted by the paper's ISF: {100 * isf_fraction:.1f} % "
          f"(rest: cubic fallback)")
    verdict = "within" if results["p95_ms"] <= BUDGET_MS else "OVER"
    print(f"p95 {results['p95_ms']:.2f} ms per fit: {verdict} the {BUDGET_MS:g} ms budget "
          f"(>= 50 estimates/s with six networks)")
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
