"""Per-step cost of the sensors and the sensing pipeline (wang2023 preset), measured side by side.

Prints mean and 95th-percentile microseconds per call for: the FBG readout (17 gratings), one
eye-in-hand camera frame at 160 x 120, the vision pose update on that frame, camera + vision
together, the OS-ELM update (N = 200) and prediction, and a whole env step with fused feedback
next to one with ground-truth feedback (their ratio is the cost of the sensing), driven by a
slow spiral (a turn every 8 s, 5-30 % of the pressure range) and, for fused feedback, by a random
action per step, with the vision tracker on its own (the default), with F-emp's pose as its
prior (``sensing={"femp_prior": True}``) and with the tracker's matching as it was before the
image-motion stage (``image_motion_prediction=False``: a frame the motion model mispredicts is
matched against the whole local map); for each random-action run, the share of frames each
matching stage decided (``VisionPoseEstimator.match_stages``). Then the time to make a fused
env in a new process with the calibration taken from the disk cache
(:mod:`soft_gym.sensing.calibration_cache`), beside the calibration itself.

With ``--against REVISION`` it last times the random-action fused env of this tree and of that
git revision side by side (fresh processes taking turns, as ``bench/revision_speed.py`` does:
uniform random actions from a seeded generator, ``--rounds`` each) and prints the ratio. The
tracker before the image-motion stage and the compiled descriptor searches is ``49c7f69^``: the
matching ``image_motion_prediction=False`` gives today runs the same stages, but with today's
searches, so it is no longer that tracker's speed.

    python bench/sensor_speed.py [--steps 300] [--json out.json]
    python bench/sensor_speed.py --against 49c7f69^ --rounds 3
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import soft_gym  # noqa: F401
from soft_gym._cli import CommandParser, HelpFormatter, positive_int
from soft_gym.robots import get_preset
from soft_gym.papers.wang2023.elm import OSELM
from soft_gym.papers.wang2023.exploration import spiral_fractions
from soft_gym.papers.wang2023.vision_pose import VisionPoseEstimator
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.fbg import FBGFiber
from soft_gym.engines.pybullet.simulator import ArmSimulator

sys.path.insert(0, str(Path(__file__).resolve().parent))

from revision_speed import extract_commit, resolve_commit, take_turns  # noqa: E402


def stats(samples_s: list[float]) -> dict:
    micro = np.array(samples_s) * 1e6
    return {"mean_us": float(micro.mean()), "p95_us": float(np.percentile(micro, 95))}


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--steps", type=int, default=300, help="timed steps per measurement")
    parser.add_argument("--json", default=None, help="also write the results to this file")
    parser.add_argument("--against", metavar="REVISION", default=None,
                        help="also time the random-action fused env of this git revision side "
                             "by side with this tree's (e.g. 49c7f69^, the tracker before the "
                             "image-motion stage)")
    parser.add_argument("--rounds", type=positive_int, default=3,
                        help="processes per tree taking turns, with --against")
    args = parser.parse_args(argv)
    if args.steps < 10:
        parser.error(f"--steps must be >= 10, got {args.steps}")
    commit = None
    if args.against is not None:
        commit = resolve_commit(args.against)
        if commit is None:
            parser.error(f"--against {args.against!r} names no commit of this repository: "
                         "give a commit, tag or branch")
    spec = get_preset("wang2023")
    sim = ArmSimulator(spec)
    sim.reset(settle_s=0.5)
    rng = np.random.default_rng(0)
    fiber, camera = FBGFiber(rate_hz=None), EyeInHandCamera()
    fiber.reset(sim, rng)
    camera.reset(sim, rng)
    tip_from_camera = np.eye(4)
    tip_from_camera[:3, 3] = camera.offset_m
    vision = VisionPoseEstimator(camera.K(), tip_from_camera)
    vision.calibrate(*camera.render_clean(sim), camera.pose_matrix(sim))
    timings: dict[str, list[float]] = {"fbg": [], "camera": [], "vision": [], "camera+vision": []}
    for k in range(args.steps):
        fraction = spiral_fractions(k * spec.control_period_s, low=0.05, high=0.3)
        sim.set_pressures(spec.p_pre_pa + fraction * (spec.p_max_pa - spec.p_pre_pa))
        sim.step_physics(spec.control_period_s)
        start = time.perf_counter()
        fiber.read(sim, sim.time_s)
        after_fbg = time.perf_counter()
        frame = camera.read(sim, sim.time_s)
        after_camera = time.perf_counter()
        vision.update(frame, camera.last_depth)
        after_vision = time.perf_counter()
        timings["fbg"].append(after_fbg - start)
        timings["camera"].append(after_camera - after_fbg)
        timings["vision"].append(after_vision - after_camera)
        timings["camera+vision"].append(after_vision - after_fbg)
    model = OSELM(n_hidden=200).fit(rng.random((450, 17)), rng.random((450, 7)))
    inputs, targets = rng.random((args.steps, 17)), rng.random((args.steps, 7))
    timings["elm_update"], timings["elm_predict"] = [], []
    for x, z in zip(inputs, targets):
        start = time.perf_counter()
        model.update(x, z)
        middle = time.perf_counter()
        model.predict(x)
        timings["elm_update"].append(middle - start)
        timings["elm_predict"].append(time.perf_counter() - middle)
    # the env steps with the slow spiral (smooth motion, the vision tracker's search by
    # projection from the motion model holds) and with a random pressure every step (the worst
    # case: the image jumps and the motion model mispredicts nearly every frame)
    stages = {}
    for feedback, actions, variant in (("ground_truth", "spiral", ""), ("fused", "spiral", ""),
                                       ("fused", "random", ""), ("fused", "random", "femp_prior"),
                                       ("fused", "random", "old_matching")):
        sensing = {"": {}, "femp_prior": {"femp_prior": True},
                   "old_matching": {"vision": {"image_motion_prediction": False}}}[variant]
        env = gym.make("SoftArmReach-v0", feedback=feedback, episode_steps=10**6,
                       **({"sensing": sensing} if sensing else {}))
        env.reset(seed=0)
        env.action_space.seed(0)
        vision = (env.unwrapped.feedback_source.pipeline.vision if feedback == "fused"
                  else None)
        before = dict(vision.match_stages) if vision is not None else {}
        steps = []
        for k in range(args.steps):
            if actions == "random":
                action = env.action_space.sample()
            else:
                fraction = spiral_fractions(k * spec.control_period_s, low=0.05, high=0.3)
                action = (2.0 * fraction - 1.0).astype(np.float32)
            start = time.perf_counter()
            env.step(action)
            steps.append(time.perf_counter() - start)
        name = (f"env_step_{feedback}" + ("_random_actions" if actions == "random" else "")
                + (f"_{variant}" if variant else ""))
        timings[name] = steps
        if vision is not None and actions == "random":
            counts = {stage: vision.match_stages[stage] - before.get(stage, 0)
                      for stage in vision.match_stages}
            stages[name] = {stage: count / args.steps for stage, count in counts.items()}
        env.close()
    results = {name: stats(values) for name, values in timings.items()}
    calibrate_s = _make_in_new_process(cache="off")
    _make_in_new_process(cache="on")  # fills the disk cache if it is cold
    results["make_fused_env_calibrating_s"] = calibrate_s
    results["make_fused_env_from_disk_cache_s"] = _make_in_new_process(cache="on")
    results["fused_over_ground_truth"] = (results["env_step_fused"]["mean_us"]
                                          / results["env_step_ground_truth"]["mean_us"])
    results["random_actions_speedup_over_old_matching"] = (
        results["env_step_fused_random_actions_old_matching"]["mean_us"]
        / results["env_step_fused_random_actions"]["mean_us"])
    results["match_stage_shares"] = stages
    print(f"{'measurement':<26} {'mean us':>10} {'p95 us':>10}")
    for name, value in results.items():
        if isinstance(value, dict) and "mean_us" in value:
            print(f"{name:<26} {value['mean_us']:10.1f} {value['p95_us']:10.1f}")
    print(f"fused env step / ground-truth env step: {results['fused_over_ground_truth']:.1f}x; "
          f"fused env steps/s: {1e6 / results['env_step_fused']['mean_us']:.0f} (spiral), "
          f"{1e6 / results['env_step_fused_random_actions']['mean_us']:.0f} (random actions), "
          f"{1e6 / results['env_step_fused_random_actions_femp_prior']['mean_us']:.0f} "
          "(random actions, F-emp prior), "
          f"{1e6 / results['env_step_fused_random_actions_old_matching']['mean_us']:.0f} "
          "(random actions, the matching without the image-motion stage: "
          f"{results['random_actions_speedup_over_old_matching']:.2f}x slower)")
    print("share of random-action frames decided by each matching stage "
          "(the rest lost before matching):")
    for name, shares in stages.items():
        print(f"  {name:<44} " + ", ".join(f"{stage} {share:.0%}"
                                             for stage, share in shares.items()))
    print(f"make a fused env in a new process: {results['make_fused_env_calibrating_s']:.2f} s "
          f"calibrating, {results['make_fused_env_from_disk_cache_s']:.2f} s from the disk cache")
    if commit is not None:
        results["against"] = _against_revision(args.against, commit, args.steps, args.rounds)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2)


def _against_revision(revision: str, commit: str, steps: int, rounds: int) -> dict:
    """Random-action fused env steps/s of this tree and of ``commit``, fresh processes taking
    turns (``bench/revision_speed.py``'s measurement); prints and returns the figures."""
    with tempfile.TemporaryDirectory(prefix="sensor_speed_") as scratch:
        figures = take_turns(extract_commit(commit, Path(scratch)), "wang2023", "fused", steps,
                             seed=0, rounds=rounds)
    ours, theirs = ([wall for wall, _ in tree] for tree in figures)
    ratios = [a / b for a, b in zip(ours, theirs)]
    print(f"random-action fused env steps/s, side by side over {rounds} rounds: this tree "
          f"{statistics.median(ours):.0f}, {revision} ({commit[:12]}) "
          f"{statistics.median(theirs):.0f}; ratio {statistics.median(ratios):.2f} "
          f"(rounds {min(ratios):.2f}-{max(ratios):.2f})")
    return {"revision": revision, "commit": commit, "this_tree_steps_per_s": ours,
            "revision_steps_per_s": theirs, "ratios": ratios}


_MAKE = """
import time, gymnasium as gym, soft_gym
start = time.perf_counter()
gym.make("SoftArmReach-v0", feedback="fused")
print(time.perf_counter() - start)
"""


def _make_in_new_process(cache: str) -> float:
    """Seconds to make a fused env in a fresh process (imports done) with SOFT_GYM_CACHE=cache."""
    import os

    result = subprocess.run([sys.executable, "-c", _MAKE], capture_output=True, text=True,
                            check=True, env={**os.environ, "SOFT_GYM_CACHE": cache})
    return float(result.stdout.strip().splitlines()[-1])


if __name__ == "__main__":
    main()
