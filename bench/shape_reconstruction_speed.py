"""Estimates per second of zhao2021's whole shape reconstruction: six SFE-PD networks and the
backbone fit (soft_gym.papers.zhao2021.shape_reconstruction), against the target of >= 50 per second on
one core (the paper: 0.37 s per estimate).

A small model is trained on the zhao2021 arm (or taken from the calibration cache), then the
script reconstructs ``--repeats`` recorded exploration states one at a time, as the ``strain_sr``
feedback source does each env step, and prints milliseconds per estimate (mean, 95th percentile,
maximum) split into the networks and the fit. Torch runs on one thread.

Example::

    python bench/shape_reconstruction_speed.py
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from soft_gym._cli import CommandParser, HelpFormatter  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--repeats", type=int, default=500, help="estimates timed")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    import torch

    from soft_gym.robots.presets import get_preset
    from soft_gym.papers.zhao2021.backbone_fit import fit_backbone
    from soft_gym.papers.zhao2021.sfe_pd import sequences
    from soft_gym.papers.zhao2021.exploration import cached_reconstruction, exploration_of
    from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig
    from soft_gym.sensors.strain_gauge import StrainGauges

    torch.set_num_threads(1)
    config = ReconstructionConfig(n_free=400, n_loaded=200, max_iterations=20)
    spec, gauges = get_preset("zhao2021"), StrainGauges()
    reconstructor, _ = cached_reconstruction(spec, gauges, config)
    data = exploration_of(spec, gauges, config)
    x = sequences(data.pressures_pa, data.readings)
    n = data.pressures_pa.shape[1]
    states = [x[i % len(x)] for i in range(args.repeats)]
    reconstructor.reconstruct(states[0][:, :n], states[0][:, n:])  # warm-up
    networks, fits = [], []
    for state in states:
        start = time.perf_counter()
        points = reconstructor.key_points(state[:, :n], state[:, n:])
        middle = time.perf_counter()
        fit_backbone(np.vstack([np.zeros(3), points]), n_points=reconstructor.n_points)
        networks.append(middle - start)
        fits.append(time.perf_counter() - middle)
    total = (np.array(networks) + np.array(fits)) * 1000.0
    for name, values in (("networks", np.array(networks) * 1000.0),
                         ("backbone fit", np.array(fits) * 1000.0), ("total", total)):
        print(f"{name:>12}: mean {values.mean():.2f} ms, p95 {np.percentile(values, 95):.2f} ms, "
              f"max {values.max():.2f} ms")
    print(f"estimates per second: {1000.0 / total.mean():.0f} (target >= 50; paper 2.7)")


if __name__ == "__main__":
    main()
