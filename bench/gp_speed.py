"""Per-control-step cost of the sliding-window GP error compensator (wang2023 Section III-B).

The compensator of Wang et al. 2023 regresses the actuation error ``dp_e`` (3 values) on
``[u(k-1), dz(k)]`` (3 + 2 values) over the most recent ``N_r^max`` samples and is retrained at
every 0.05 s control step. This script feeds a synthetic stream of that shape to
:class:`agents.learners.SlidingWindowGP` and measures, per step,

1. **incremental**: ``gp.add(x_k, y_k)`` (drop the oldest sample, rank-one update of the
   Cholesky factor, append the new row; every ``--refactor-every`` steps a full refactorisation)
   followed by ``gp.predict(x_query)`` (the mean, plus the std with ``--std``), which includes
   recomputing ``alpha`` for the changed window;
2. **from scratch**: on the same windows, building the kernel matrix, ``scipy.linalg.cho_factor``,
   ``cho_solve`` for ``alpha`` and the same prediction -- what "retrain at every step" costs
   without the incremental factor.

Both start with a full window (the warm-up fill is not timed). The report gives the mean, 95th
percentile and maximum microseconds per step, the split of the incremental step into ``add`` and
``predict``, the ratio from-scratch / incremental, and the largest difference between the two
predictions (a correctness check). Timings are wall-clock (``time.perf_counter``), single
process; they depend on the machine, its load and the BLAS thread count
(e.g. ``OPENBLAS_NUM_THREADS=1``). The control period of the paper is 50 ms.

Example::

    PYTHONPATH=. python bench/gp_speed.py
    PYTHONPATH=. python bench/gp_speed.py --window 500 --std --json gp_speed.json
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
import scipy.linalg
from scipy.spatial.distance import cdist

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.learners import SlidingWindowGP  # noqa: E402
from soft_gym._cli import CommandParser, HelpFormatter  # noqa: E402


def make_stream(steps: int, input_dim: int, output_dim: int, seed: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Slowly drifting actuation plus small desired displacements, and a smooth error map."""
    rng = np.random.default_rng(seed)
    n_u = input_dim - 2 if input_dim > 2 else input_dim
    u = np.clip(0.5 + np.cumsum(0.03 * rng.standard_normal((steps, n_u)), axis=0), 0.0, 1.0)
    dz = 0.2 * rng.standard_normal((steps, input_dim - n_u))
    X = np.hstack([u, dz])
    W = rng.standard_normal((input_dim, output_dim))
    Y = 0.1 * np.sin(2.0 * X @ W) + 0.05 * (X**2) @ np.abs(W)
    return X, Y + 1e-3 * rng.standard_normal(Y.shape)


def percentile_summary(seconds: np.ndarray) -> dict[str, float]:
    us = 1e6 * np.asarray(seconds)
    return {"mean_us": float(us.mean()), "p95_us": float(np.percentile(us, 95)),
            "max_us": float(us.max()), "median_us": float(np.median(us))}


def scratch_step(X: np.ndarray, Y: np.ndarray, xq: np.ndarray, scales: np.ndarray,
                 signal_variance: float, noise_variance: float, mean_mode: str, with_std: bool
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """One from-scratch refit on the window (X, Y) and a prediction at xq (1, d)."""
    Xs = X / scales
    K = signal_variance * np.exp(-0.5 * cdist(Xs, Xs, "sqeuclidean"))
    K.flat[:: len(X) + 1] += noise_variance
    factor = scipy.linalg.cho_factor(K, lower=True, check_finite=False)
    mu = Y.mean(axis=0) if mean_mode == "window_mean" else np.zeros(Y.shape[1])
    alpha = scipy.linalg.cho_solve(factor, Y - mu, check_finite=False)
    cross = signal_variance * np.exp(-0.5 * cdist(xq / scales, Xs, "sqeuclidean"))
    mean = cross @ alpha + mu
    std = None
    if with_std:
        v = scipy.linalg.solve_triangular(factor[0], cross.T, lower=True, check_finite=False)
        std = np.sqrt(np.maximum(signal_variance - np.sum(v**2, axis=0), 0.0))
    return mean[0], std


def main(argv: list[str] | None = None) -> dict:
    parser = CommandParser(
        description="Time add + predict per control step of SlidingWindowGP against a "
                    "from-scratch GP refit on the same window.",
        formatter_class=HelpFormatter)
    parser.add_argument("--window", type=int, default=300, help="window size N_r^max")
    parser.add_argument("--input-dim", type=int, default=5, help="input size: u(k-1) + dz")
    parser.add_argument("--output-dim", type=int, default=3, help="output size: dp_e")
    parser.add_argument("--steps", type=int, default=2000,
                        help="timed incremental steps after the window is full")
    parser.add_argument("--scratch-steps", type=int, default=300,
                        help="timed from-scratch steps, the first of the same stream")
    parser.add_argument("--refactor-every", type=int, default=200,
                        help="steps between full refactorisations")
    parser.add_argument("--noise-variance", type=float, default=1e-4,
                        help="GP noise variance (output units squared)")
    parser.add_argument("--length-scale", type=float, default=0.5,
                        help="GP length scale (input units)")
    parser.add_argument("--std", action="store_true", help="also predict the std every step")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample stream")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    args = parser.parse_args(argv)
    if args.window < 2 or args.steps < 1 or args.scratch_steps < 1 or args.input_dim < 1 \
            or args.output_dim < 1:
        parser.error("window must be >= 2 and steps, scratch-steps and dims >= 1")

    total = args.window + max(args.steps, args.scratch_steps) + 1
    X, Y = make_stream(total, args.input_dim, args.output_dim, args.seed)
    scales = np.full(args.input_dim, args.length_scale)
    gp = SlidingWindowGP(window=args.window, length_scales=scales,
                         noise_variance=args.noise_variance, refactor_every=args.refactor_every)
    fill_start = time.perf_counter()
    for k in range(args.window):
        gp.add(X[k], Y[k])
    fill_s = time.perf_counter() - fill_start

    t_add, t_pred, refactored, predictions = [], [], [], []
    for j in range(args.steps):
        k = args.window + j
        t0 = time.perf_counter()
        gp.add(X[k], Y[k])
        t1 = time.perf_counter()
        out = gp.predict(X[k + 1], return_std=args.std)
        t2 = time.perf_counter()
        t_add.append(t1 - t0)
        t_pred.append(t2 - t1)
        refactored.append(gp.adds_since_refactor == 0)
        if j < args.scratch_steps:
            predictions.append(out)
    t_add, t_pred = np.array(t_add), np.array(t_pred)
    t_step = t_add + t_pred

    t_scratch, max_mean_diff, max_std_diff = [], 0.0, 0.0
    for j in range(min(args.scratch_steps, args.steps)):
        k = args.window + j
        lo = k + 1 - args.window
        t0 = time.perf_counter()
        mean, std = scratch_step(X[lo:k + 1], Y[lo:k + 1], X[k + 1:k + 2], scales, 1.0,
                                 args.noise_variance, gp.mean, args.std)
        t_scratch.append(time.perf_counter() - t0)
        inc = predictions[j]
        if args.std:
            max_mean_diff = max(max_mean_diff, float(np.max(np.abs(inc[0] - mean))))
            max_std_diff = max(max_std_diff, float(np.max(np.abs(inc[1] - std[0]))))
        else:
            max_mean_diff = max(max_mean_diff, float(np.max(np.abs(inc - mean))))
    t_scratch = np.array(t_scratch)

    incremental = percentile_summary(t_step)
    scratch = percentile_summary(t_scratch)
    results = {
        "settings": {**{k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                     "mean": gp.mean},
        "incremental_step": incremental,
        "incremental_add": percentile_summary(t_add),
        "incremental_predict": percentile_summary(t_pred),
        "incremental_step_refactor_mean_us": float(1e6 * t_step[np.array(refactored)].mean())
        if any(refactored) else None,
        "scratch_step": scratch,
        "ratio_scratch_over_incremental_mean": scratch["mean_us"] / incremental["mean_us"],
        "ratio_scratch_over_incremental_p95": scratch["p95_us"] / incremental["p95_us"],
        "max_abs_mean_difference": max_mean_diff,
        "max_abs_std_difference": max_std_diff if args.std else None,
        "window_fill_s": fill_s,
        "versions": {"python": platform.python_version(), "numpy": np.__version__,
                     "scipy": scipy.__version__},
        "machine": platform.platform(),
    }

    what = "add + predict(mean, std)" if args.std else "add + predict(mean)"
    print(f"SlidingWindowGP, window {args.window}, {args.input_dim}-D inputs, "
          f"{args.output_dim} outputs, refactor every {args.refactor_every} steps; {what}")
    header = f"{'':28s}{'mean us':>10s}{'p95 us':>10s}{'max us':>10s}{'steps':>8s}"
    print(header)
    rows = [("incremental step", incremental, len(t_step)),
            ("  of which add", results["incremental_add"], len(t_add)),
            ("  of which predict", results["incremental_predict"], len(t_pred)),
            ("from-scratch refit + predict", scratch, len(t_scratch))]
    for name, summary, count in rows:
        print(f"{name:28s}{summary['mean_us']:10.1f}{summary['p95_us']:10.1f}"
              f"{summary['max_us']:10.1f}{count:8d}")
    print(f"ratio from-scratch / incremental: {results['ratio_scratch_over_incremental_mean']:.1f}x"
          f" (mean), {results['ratio_scratch_over_incremental_p95']:.1f}x (p95)")
    if results["incremental_step_refactor_mean_us"] is not None:
        print(f"incremental steps with a full refactorisation: {int(np.sum(refactored))}, "
              f"mean {results['incremental_step_refactor_mean_us']:.1f} us")
    diff = f"max |mean difference| {max_mean_diff:.2e}"
    if args.std:
        diff += f", max |std difference| {max_std_diff:.2e}"
    print(f"{diff} (incremental vs from scratch, same windows)")
    budget = 3000.0
    verdict = "within" if incremental["p95_us"] < budget else "OVER"
    print(f"p95 per step {incremental['p95_us']:.0f} us: {verdict} the 3 ms budget "
          f"(control period 50 ms)")
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
