"""Render speed of the soft-arm environments: milliseconds per ``env.render()`` frame.

For every arm preset (or the ``--presets`` subset) a seeded reach env with ground-truth feedback
is reset and stepped with seeded random actions; after each step one frame is rendered at
``--size`` with the full overlay (targets, path, loads, markers, text) and one with the scene,
floor and grid only (``SoftArmEnv.make_renderer(overlays=False)``). The first frame, which
builds the camera and the static background, is timed apart ("first ms").

Columns: ``overlay ms`` and ``scene ms`` (mean per frame, with and without overlays),
``overlay cost ms`` (their difference), ``first ms``.

Sensor panels (``render_frame(env, ("scene", "camera"))``) are timed on a second env of the preset
that simulates a camera: the stereo pair for zou2022 (its paper's sensor), the eye-in-hand camera
for the others. A camera's scenery is in PyBullet's world too, so the scene alone costs more
there: ``cam scene ms`` is that env's ``env.render()``, ``panels ms`` the whole panel frame and
``camera panel ms`` their difference (the sensor's own rendering happens in ``step`` and is not
counted). ``panel size`` is the frame's width x height.

``--video-run`` also times the video overhead: ``cc_model`` tracks one wang2023 circle (400 steps
of 0.05 s) with fused feedback via :func:`agents.rollout.run_episode`, without and with a video
(scene and eye-in-hand panels, MP4 through imageio-ffmpeg), and checks that both runs give the
same record.

Example::

    python bench/render_speed.py --frames 50 --size 320 240 --video-run
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from soft_gym._cli import CommandParser, HelpFormatter
from soft_gym.envs import SoftArmEnv
from soft_gym.robots import PRESETS


def _time_side_by_side(env, frames: int, seed: int, first, second) -> tuple[float, float]:
    """Mean ms per call of ``first()`` and ``second()``, both called after each of ``frames``
    random env steps."""
    rng = np.random.default_rng(seed)
    totals = [0.0, 0.0]
    for _ in range(frames):
        env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        for k, draw in enumerate((first, second)):
            start = time.perf_counter()
            draw()
            totals[k] += time.perf_counter() - start
    return totals[0] / frames * 1e3, totals[1] / frames * 1e3


def time_preset(preset: str, frames: int, size: tuple[int, int], seed: int) -> dict[str, float]:
    """Mean wall time per frame (ms) with and without overlays, and of the first frame."""
    env = SoftArmEnv(preset=preset, render_mode="rgb_array", feedback="ground_truth",
                     render_size=size, episode_steps=10 * frames)
    env.reset(seed=seed)
    start = time.perf_counter()
    env.render()
    first_ms = (time.perf_counter() - start) * 1e3
    bare = env.make_renderer(overlays=False)
    overlay_ms, scene_ms = _time_side_by_side(env, frames, seed, env.render,
                                              lambda: bare.render(env.sim))
    env.close()
    return {"overlay_ms": overlay_ms, "scene_ms": scene_ms,
            "overlay_cost_ms": overlay_ms - scene_ms, "first_ms": first_ms}


def camera_sensor(preset: str) -> str:
    """The camera sensor whose panel is timed for ``preset``."""
    return "stereo" if preset == "zou2022" else "image"


def time_panels(preset: str, frames: int, size: tuple[int, int], seed: int) -> dict[str, float]:
    """Mean wall time per frame (ms) of the scene alone and with the camera panel, on an env
    with the preset's camera sensor."""
    from soft_gym.envs.rendering import render_frame

    env = SoftArmEnv(preset=preset, render_mode="rgb_array", feedback="ground_truth",
                     render_size=size, episode_steps=10 * frames,
                     sensors=(camera_sensor(preset),))
    env.reset(seed=seed)
    frame = render_frame(env, ("scene", "camera"))  # builds the renderer
    scene_ms, panels_ms = _time_side_by_side(env, frames, seed, env.render,
                                             lambda: render_frame(env, ("scene", "camera")))
    env.close()
    return {"scene_ms": scene_ms, "panels_ms": panels_ms, "camera_panel_ms": panels_ms - scene_ms,
            "width": frame.shape[1], "height": frame.shape[0]}


def time_video(size: tuple[int, int], seed: int, folder: str) -> dict[str, float]:
    """Wall time (s) of one wang2023 circle (400 steps) without and with a video."""
    import gymnasium as gym

    from agents.policies import make_policy
    from agents.rollout import run_episode
    from eval.video import EpisodeVideo

    times, records = {}, {}
    for video in (False, True):
        env = gym.make("SoftArmTrack-v0", preset="wang2023", path="circle", cycles=1,
                       feedback="fused", render_size=size)
        policy = make_policy("cc_model", env=env, kp=0.06)
        start = time.perf_counter()
        frames = EpisodeVideo(env, f"{folder}/bench_video.mp4", None) if video else None
        records[video] = run_episode(env, policy, seed=seed, frames=frames)
        times[video] = time.perf_counter() - start
        env.close()
    for key in records[False]:
        np.testing.assert_array_equal(records[False][key], records[True][key], err_msg=key)
    steps_run = len(records[False]["time_s"])
    return {"steps": steps_run, "plain_s": times[False], "video_s": times[True],
            "overhead_s": times[True] - times[False],
            "overhead_ms_per_frame": (times[True] - times[False]) / (steps_run + 1) * 1e3}


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", default=sorted(PRESETS), choices=sorted(PRESETS),
                        help="arm presets to time")
    parser.add_argument("--frames", type=int, default=30, help="frames timed per preset")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 240),
                        metavar=("WIDTH", "HEIGHT"), help="frame size in pixels")
    parser.add_argument("--seed", type=int, default=0, help="seed of the env and the actions")
    parser.add_argument("--no-panels", action="store_true", help="skip the sensor-panel timing")
    parser.add_argument("--video-run", action="store_true",
                        help="also time one wang2023 circle (400 steps) with and without a video")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error(f"--frames must be >= 1, got {args.frames}")
    print(f"{'preset':<10} {'overlay ms':>10} {'scene ms':>9} {'overlay cost ms':>16} "
          f"{'first ms':>9}")
    for preset in args.presets:
        row = time_preset(preset, args.frames, tuple(args.size), args.seed)
        print(f"{preset:<10} {row['overlay_ms']:>10.2f} {row['scene_ms']:>9.2f} "
              f"{row['overlay_cost_ms']:>16.2f} {row['first_ms']:>9.1f}")
    if not args.no_panels:
        print(f"\n{'preset':<10} {'camera':>7} {'cam scene ms':>13} {'panels ms':>10} "
              f"{'camera panel ms':>16} {'panel size':>11}")
        for preset in args.presets:
            row = time_panels(preset, args.frames, tuple(args.size), args.seed)
            size = f"{row['width']}x{row['height']}"
            print(f"{preset:<10} {camera_sensor(preset):>7} {row['scene_ms']:>13.2f} "
                  f"{row['panels_ms']:>10.2f} {row['camera_panel_ms']:>16.2f} {size:>11}")
    if args.video_run:
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            row = time_video(tuple(args.size), args.seed, folder)
        print(f"\nvideo of a {row['steps']}-step wang2023 circle run (fused feedback): "
              f"{row['plain_s']:.1f} s without, {row['video_s']:.1f} s with "
              f"(+{row['overhead_s']:.1f} s, {row['overhead_ms_per_frame']:.1f} ms per frame); "
              "records identical")


if __name__ == "__main__":
    main()
