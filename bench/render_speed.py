"""Render speed of the soft-arm environments: milliseconds per ``env.render()`` frame.

For every arm preset (or the ``--presets`` subset) a seeded reach env with ground-truth feedback
is reset and stepped with seeded random actions; after each step one frame is rendered at
``--size`` with the full overlay (targets, path, loads, markers, text) and one with the scene,
floor and grid only (``SoftArmEnv.make_renderer(overlays=False)``). The first frame, which
builds the camera and the static background, is timed apart ("first ms").

Columns: ``overlay ms`` and ``scene ms`` (mean per frame, with and without overlays),
``overlay cost ms`` (their difference), ``first ms``.

Example::

    python bench/render_speed.py --frames 50 --size 320 240
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from soft_gym._cli import HelpFormatter
from soft_gym.envs import SoftArmEnv
from soft_gym.robots import PRESETS


def time_preset(preset: str, frames: int, size: tuple[int, int], seed: int) -> dict[str, float]:
    """Mean wall time per frame (ms) with and without overlays, and of the first frame."""
    env = SoftArmEnv(preset=preset, render_mode="rgb_array", feedback="ground_truth",
                     render_size=size, episode_steps=10 * frames)
    env.reset(seed=seed)
    start = time.perf_counter()
    env.render()
    first_ms = (time.perf_counter() - start) * 1e3
    bare = env.make_renderer(overlays=False)
    rng = np.random.default_rng(seed)
    overlay_s = scene_s = 0.0
    for _ in range(frames):
        env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        start = time.perf_counter()
        env.render()
        overlay_s += time.perf_counter() - start
        start = time.perf_counter()
        bare.render(env.sim)
        scene_s += time.perf_counter() - start
    env.close()
    overlay_ms, scene_ms = overlay_s / frames * 1e3, scene_s / frames * 1e3
    return {"overlay_ms": overlay_ms, "scene_ms": scene_ms,
            "overlay_cost_ms": overlay_ms - scene_ms, "first_ms": first_ms}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", default=sorted(PRESETS), choices=sorted(PRESETS),
                        help="arm presets to time")
    parser.add_argument("--frames", type=int, default=30, help="frames timed per preset")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 240),
                        metavar=("WIDTH", "HEIGHT"), help="frame size in pixels")
    parser.add_argument("--seed", type=int, default=0, help="seed of the env and the actions")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error(f"--frames must be >= 1, got {args.frames}")
    print(f"{'preset':<10} {'overlay ms':>10} {'scene ms':>9} {'overlay cost ms':>16} "
          f"{'first ms':>9}")
    for preset in args.presets:
        row = time_preset(preset, args.frames, tuple(args.size), args.seed)
        print(f"{preset:<10} {row['overlay_ms']:>10.2f} {row['scene_ms']:>9.2f} "
              f"{row['overlay_cost_ms']:>16.2f} {row['first_ms']:>9.1f}")


if __name__ == "__main__":
    main()
