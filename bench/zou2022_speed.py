"""Speed of zou2022's shape estimators against their targets on one core: ASES on a 2 x 320 x 180
stereo pair in at most 30 ms, the DNN in under 0.1 ms per estimate (the paper's CC kinematics
took ~9 ms; its ZED ran ASES offline).

ASES (soft_gym.papers.zou2022.stereo_shape): frame pairs of the zou2022 arm are rendered in
``--poses`` random settled poses, then each pair is processed ``--repeats`` times (Gaussian
filter, HSV mask, contour, the SOM of both images, triangulation); the DNN
(soft_gym.papers.zou2022.shape_dnn): a Table 2 network (trained for a few epochs on CC shapes: the speed
does not depend on the weights) predicts ``--repeats`` single readings through its numpy path,
as the ``encoder_dnn`` source does each env step. Prints milliseconds per estimate (median, 95th
percentile, maximum). OpenCV and torch run on one thread.

Example::

    python bench/zou2022_speed.py
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from soft_gym._cli import CommandParser, HelpFormatter  # noqa: E402


def _summary(name: str, seconds: list[float], target_ms: float) -> None:
    ms = np.array(seconds) * 1000.0
    verdict = "meets" if np.median(ms) <= target_ms else "MISSES"
    print(f"{name}: median {np.median(ms):.4f} ms, p95 {np.percentile(ms, 95):.4f} ms, "
          f"max {ms.max():.4f} ms per estimate ({verdict} the {target_ms} ms target)")


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--poses", type=int, default=8, help="rendered stereo pairs")
    parser.add_argument("--repeats", type=int, default=20,
                        help="ASES runs per pair; DNN estimates are 100 times as many")
    args = parser.parse_args(argv)
    if args.poses < 1:
        parser.error(f"--poses must be >= 1, got {args.poses}")
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    import cv2
    import torch

    from soft_gym.robots.presets import get_preset
    from soft_gym.papers.zou2022.cc_shape import cc_shape_points
    from soft_gym.papers.zou2022.shape_dnn import ShapeDNN, default_stereo
    from soft_gym.papers.zou2022.stereo_shape import estimate_stereo_shape
    from soft_gym.engines.pybullet.simulator import ArmSimulator

    cv2.setNumThreads(1)
    torch.set_num_threads(1)
    spec = get_preset("zou2022")
    sim = ArmSimulator(spec)
    camera = default_stereo()
    rng = np.random.default_rng(0)
    pairs, lengths = [], []
    for _ in range(args.poses):
        sim.set_pressures(spec.p_max_pa * rng.integers(0, 31, spec.n_chambers) / 30.0)
        sim.step_physics(1.5)
        pairs.append(camera.sample(sim))
        lengths.append(sim.chamber_lengths())
    sim.close()
    ases, lost = [], 0
    for reading in pairs:
        for _ in range(args.repeats):
            start = time.perf_counter()
            shape = estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                          reading["P_right"])
            ases.append(time.perf_counter() - start)
        lost += shape.lost
    print(f"ASES on {args.poses} pairs of {camera.intrinsics.width} x {camera.intrinsics.height} "
          f"({lost} lost):")
    _summary("  ASES", ases, 30.0)

    samples = np.array(lengths) * rng.uniform(0.9, 1.1, (64, 1, spec.n_chambers))
    samples = samples.reshape(-1, spec.n_chambers)
    dnn = ShapeDNN(spec.n_chambers)
    index = np.arange(len(samples))
    dnn.fit(samples, cc_shape_points(samples, spec.chamber_offset_m), index, index, epochs=3,
            progress=False)
    dnn.predict(samples[0])  # warm-up
    times = []
    for i in range(100 * args.repeats):
        reading = samples[i % len(samples)]
        start = time.perf_counter()
        dnn.predict(reading)
        times.append(time.perf_counter() - start)
    print("DNN (Table 2, numpy inference):")
    _summary("  DNN", times, 0.1)


if __name__ == "__main__":
    main()
