"""Whether a change moved any trajectory: SHA-256 digests of seeded episodes, this tree against a
git revision.

A refactoring promises "behaviour unchanged bit for bit"; this script checks the promise. Each
case makes an env through ``gymnasium.make`` (the public API, so both trees understand it),
resets it with a seed, steps it with seeded actions (bang-bang and uniform random, alternating in
blocks of 25) and feeds every observation, reward, end flag and the info's arrays (ground truth,
sensor readings, estimates) into one SHA-256. The cases cover every preset, every feedback
source (the learned ones with a quick model), every observation part, every load, visual faults,
domain randomisation, the track task, a reach start and ``render()``.

``--against REV`` runs the same cases in a fresh process importing ``soft_gym`` from the
revision's tracked files (``git archive``) and prints each case's digest side by side with
``same`` or ``DIFFERENT``; the exit status is 1 when any case differs. ``--expect FILE``
compares against digests saved earlier with ``--json FILE`` instead (quicker across many
commits). Without either it prints this tree's digests. ``--only`` picks cases by name.

    python bench/trajectory_hash.py --against HEAD~1
    python bench/trajectory_hash.py --against main --only wang2023_fused ho2018_em
    python bench/trajectory_hash.py --json before.json   # then, after the change:
    python bench/trajectory_hash.py --expect before.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from revision_speed import extract_commit, resolve_commit  # noqa: E402

from soft_gym._cli import CommandParser, HelpFormatter, positive_int  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

QUICK_SR = {"n_free": 60, "n_loaded": 30, "max_iterations": 3}
QUICK_DNN = {"n_samples": 40, "epochs": 3}

CASES: dict[str, dict] = {
    "wang2023_truth": {"preset": "wang2023", "feedback": "ground_truth",
                       "obs": ("pose", "target", "pressure", "fbg", "shape")},
    "wang2023_fused": {"preset": "wang2023", "feedback": "fused", "steps": 60,
                       "obs": ("pose", "target", "pressure", "image"), "obs_format": "dict"},
    "wang2023_camera_faults": {"preset": "wang2023", "feedback": "camera", "steps": 40,
                               "faults": [{"name": "wang2023_occlusion", "time_scale": 0.01},
                                          "motion_blur"]},
    "wang2023_fbg_randomised": {"preset": "wang2023", "feedback": "fbg", "steps": 60,
                                "randomization": True},
    "zhao2021_truth_loads": {"preset": "zhao2021", "feedback": "ground_truth",
                             "obs": ("pose", "target", "pressure", "strain"),
                             "scenario": [{"name": "tip_mass", "mass_kg": 0.05}, "push"]},
    "zhao2021_strain_sr": {"preset": "zhao2021", "feedback": "strain_sr", "steps": 40,
                           "obs": ("pose", "shape", "strain"), "sensing": QUICK_SR},
    "zou2022_encoder_cc": {"preset": "zou2022", "feedback": "encoder_cc",
                           "obs": ("pose", "target", "encoder", "shape"),
                           "scenario": "swaying_mass"},
    "zou2022_stereo": {"preset": "zou2022", "feedback": "stereo", "steps": 30,
                       "faults": "led_glare"},
    "zou2022_encoder_dnn": {"preset": "zou2022", "feedback": "encoder_dnn", "steps": 40,
                            "sensing": QUICK_DNN},
    "ho2018_em_track": {"preset": "ho2018", "feedback": "em", "task": "track",
                        "path": "rectangle", "obs": ("pose", "target", "pressure", "em"),
                        "scenario": ["filling_load", "flick"]},
    "ho2018_truth_obstacle": {"preset": "ho2018", "feedback": "ground_truth",
                              "scenario": "obstacle_rod", "action_mode": "delta"},
    "zou2022_truth_randomised": {"preset": "zou2022", "feedback": "ground_truth",
                                 "randomization": True, "task": "track", "path": "star"},
    "wang2023_start_render": {"preset": "wang2023", "feedback": "ground_truth", "steps": 30,
                              "start_m": [-0.028, 0.0, 0.09], "render": True},
    "wang2023_mujoco_truth": {"preset": "wang2023", "feedback": "ground_truth",
                              "engine": "mujoco", "obs": ("pose", "target", "pressure", "fbg")},
    "zhao2021_mujoco_loads": {"preset": "zhao2021", "feedback": "ground_truth",
                              "engine": "mujoco", "obs": ("pose", "target", "strain"),
                              "scenario": [{"name": "tip_mass", "mass_kg": 0.05}, "push"]},
    "zou2022_mujoco_randomised": {"preset": "zou2022", "feedback": "ground_truth",
                                  "engine": "mujoco", "task": "track",
                                  "randomization": {"load_weights": {"none": 0.3, "tip_mass": 0.4,
                                                                     "filling_load": 0.15,
                                                                     "push": 0.15}},
                                  "path": "star"},
    "ho2018_mujoco_em_track": {"preset": "ho2018", "feedback": "em", "engine": "mujoco",
                               "task": "track", "path": "rectangle",
                               "scenario": ["filling_load", "flick"]},
}
"""Case name -> env keyword arguments, plus ``steps`` (default 200), ``task`` and ``render``."""

CHILD = r"""
import hashlib, json, sys
sys.path.insert(0, sys.argv[1])
import numpy as np, gymnasium as gym
import soft_gym  # noqa: F401
cases = json.loads(sys.argv[2])

def feed(digest, value):
    if isinstance(value, dict):
        for key in sorted(value):
            digest.update(str(key).encode())
            feed(digest, value[key])
    elif isinstance(value, (list, tuple)):
        for item in value:
            feed(digest, item)
    elif isinstance(value, str):
        digest.update(value.encode())
    elif value is None:
        digest.update(b"None")
    else:
        array = np.asarray(value)
        digest.update(str(array.dtype).encode() + str(array.shape).encode())
        digest.update(np.ascontiguousarray(array).tobytes())

out = {}
for name, case in cases.items():
    case = dict(case)
    steps, render = case.pop("steps", 200), case.pop("render", False)
    task = case.pop("task", "reach")
    env_id = "SoftArmTrack-v0" if task == "track" else "SoftArmReach-v0"
    extra = {} if task == "track" else {"episode_steps": 10**6}
    if "obs" in case:
        case["obs"] = tuple(case["obs"])
    env = gym.make(env_id, render_mode="rgb_array" if render else None, **extra, **case)
    digest = hashlib.sha256()
    feed(digest, env.reset(seed=3))
    rng = np.random.default_rng(11)
    shape = env.action_space.shape
    for step in range(steps):
        if (step // 25) % 2 == 0:
            action = np.where(rng.random(shape) < 0.5, -1.0, 1.0).astype(np.float32)
        else:
            action = rng.uniform(-1.0, 1.0, shape).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        feed(digest, [obs, reward, terminated, truncated, info])
        if render and step % 10 == 0:
            feed(digest, env.render())
        if terminated or truncated:
            feed(digest, env.reset())
    env.close()
    out[name] = digest.hexdigest()
    print(name, out[name], file=sys.stderr, flush=True)
print(json.dumps(out))
"""
"""Runs the cases with the tree's root first on ``sys.path``; prints their digests as JSON."""


def digests(tree: Path, cases: dict[str, dict]) -> dict[str, str]:
    """Every case's digest, computed in a fresh process importing ``soft_gym`` from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, "-c", CHILD, str(tree), json.dumps(cases)],
                          stdout=subprocess.PIPE, text=True, env=env, cwd=str(tree))
    if done.returncode != 0:
        raise RuntimeError(f"the cases failed in {tree} (exit {done.returncode})")
    return json.loads(done.stdout.strip().splitlines()[-1])


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--against", metavar="REVISION", default=None,
                        help="git revision to compare with (commit, tag or branch)")
    parser.add_argument("--only", nargs="+", choices=list(CASES), metavar="CASE",
                        default=list(CASES), help=f"cases to run, from {list(CASES)}")
    parser.add_argument("--steps", type=positive_int, default=None,
                        help="steps per case (default: each case's own)")
    parser.add_argument("--json", metavar="PATH", default=None,
                        help="write this tree's digests here")
    parser.add_argument("--expect", metavar="PATH", default=None,
                        help="compare with digests written earlier by --json")
    args = parser.parse_args(argv)
    if args.against is not None and args.expect is not None:
        parser.error("--against and --expect are alternatives: give one")
    if args.expect is not None:
        try:
            args.expected = json.loads(Path(args.expect).read_text())
        except (OSError, ValueError) as error:
            parser.error(f"--expect {args.expect!r} is not a digest file written by --json: "
                         f"{error}")
        missing = [name for name in args.only if name not in args.expected]
        if missing:
            parser.error(f"--expect {args.expect!r} has no digest of the cases {missing}")
    args.commit = None
    if args.against is not None:
        args.commit = resolve_commit(args.against)
        if args.commit is None:
            parser.error(f"--against {args.against!r} names no commit of the repository at "
                         f"{ROOT}: give a commit, tag or branch")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cases = {name: dict(CASES[name]) for name in args.only}
    if args.steps is not None:
        for case in cases.values():
            case["steps"] = args.steps
    ours = digests(ROOT, cases)
    if args.json is not None:
        Path(args.json).write_text(json.dumps(ours, indent=2) + "\n")
    if args.commit is None and args.expect is None:
        for name, digest in ours.items():
            print(f"{name:<26} {digest}")
        return 0
    if args.expect is not None:
        theirs = args.expected
        print(f"trajectory digests: this tree against {args.expect}")
    else:
        with tempfile.TemporaryDirectory(prefix="trajectory_hash_") as scratch:
            theirs = digests(extract_commit(args.commit, Path(scratch)), cases)
        print(f"trajectory digests: this tree against {args.against} = {args.commit[:12]}")
    differing = 0
    for name in cases:
        same = ours[name] == theirs[name]
        differing += not same
        print(f"{name:<26} {ours[name][:16]} {theirs[name][:16]} "
              f"{'same' if same else 'DIFFERENT'}")
    print(f"{len(cases) - differing} same, {differing} different")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
