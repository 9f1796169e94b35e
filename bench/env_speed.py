"""Speed and step-size accuracy benchmark of the soft-arm environments.

For every arm preset (or the ``--presets`` subset) this script measures:

1. **Env steps per second** -- ``env.step(action)`` with seeded random actions for ``--steps``
   control steps after a seeded ``reset``. When an episode truncates the env is reset; those
   resets are timed separately and are *not* part of the step rate.
2. **Physics-only bound** -- on the same PyBullet client and body, after the env loop and one
   more ``reset`` (the arm rests, settled, with its last spring torques still applied),
   ``pybullet.stepSimulation`` is called ``steps * substeps_per_control`` times with nothing else
   (no spring-torque updates, no pneumatics, no observations). Its wall time is expressed as the
   equivalent "env steps per second" and the ratio ``env / physics`` says which fraction of the
   raw PyBullet rate the full environment reaches (1 would mean zero Python overhead).
   As a cross-check from the env loop itself, the time spent inside ``stepSimulation`` during the
   ``env.step`` calls is accumulated too ("phys share" = that time / env step time). The timing
   wrapper this needs adds about 0.3 us per physics substep to the env step time (well under 1%).
   The two need not agree: the bare loop steps a resting arm, and a bare ``stepSimulation`` has
   been seen to take longer per call than one inside ``env.step``, so ``env / physics`` can
   overstate what the physics alone would allow; "phys share" is the direct in-loop figure.
3. **Reset time** -- mean and max wall time of ``env.reset()`` over ``--resets`` calls (this
   includes the env's settling time, ``settle_s`` of simulated rest).
4. **Simulated time per wall second** -- ``steps * control_period_s`` divided by the wall time
   of the env steps (also given with the in-loop resets included).
5. **Step-size accuracy** -- a fixed, seeded sequence of random chamber pressures (uniform in
   ``[p_pre, p_max]``, each held for ``--hold-steps`` control periods (default 10, 0.5 s; 1 gives
   a command jump every period, a far harsher whip), ``--accuracy-steps`` periods after the
   same settling as the env) is simulated with ``ArmSimulator(spec)`` and with a reference whose
   physics step is 4x smaller (``dataclasses.replace(spec, physics_dt_s=physics_dt_s / 4)``, the
   actuation update period unchanged). The tip positions are compared after every control period;
   the maximum and final deviations are reported in mm, next to the tip's largest excursion from
   its settled position for scale.

6. **SoMo-style reference** -- in the same process, in ``REFERENCE_BLOCKS`` blocks taking turns
   with the env's timed steps (A B A B ..., so both see the same machine load): 10 rigid links,
   one revolute joint each with alternating axes, explicit spring torques set every 1 ms physics
   step, 20 Hz control (:class:`SoMoReference`). Reported as its control steps per second and
   ``env / reference`` (the env's steps/s over the reference's: above 1 the env steps faster
   than that rigid-link approach on the same machine at the same moment, below 1 slower).
   :data:`SPEED_TARGET` (5) is the speed this env was designed for relative to that approach;
   the printout says how many presets meet it.
   ``--reference-steps 0`` skips it.

Also reported: ``physics_dt_s``, physics substeps per control step, and the number of joints of
the PyBullet body.

Table columns: ``joints`` (PyBullet joints), ``dt ms`` (physics step), ``sub/step`` (physics
substeps per control step), ``env st/s`` (1), ``phys st/s`` and ``env/phys`` (2), ``phys share``
(2, in-loop), ``ref st/s`` and ``env/ref`` (6), ``reset ms`` (3, mean), ``sim s/wall s`` (4,
resets excluded), ``dev max mm``,
``dev final mm`` and ``excursion mm`` (5). The JSON holds these and more (make time, in-loop
reset count and time, reset max, real-time factor with resets, mean deviation, settings and
versions).

Results are printed as a table; the full results go to ``--json PATH`` or, without it, are printed
as JSON on stdout after the table. Timings are single-threaded wall-clock times
(``time.perf_counter``) and depend on the machine and its load.

Example::

    PYTHONPATH=. python bench/env_speed.py
    PYTHONPATH=. python bench/env_speed.py --presets wang2023 ho2018 --steps 2000 --json speed.json
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import datetime
import json
import os
import platform
import sys
import time
from typing import Iterator

import gymnasium as gym
import numpy as np
import pybullet

import soft_gym  # noqa: F401  (registers the environment ids)
from soft_gym._cli import CommandParser, HelpFormatter
from soft_gym.envs.config import TASKS
from soft_gym.envs.registration import TASK_IDS
from soft_gym.robots import PRESETS, get_preset
from soft_gym.engines.pybullet.simulator import ArmSimulator

REFERENCE_REFINEMENT = 4
REFERENCE_BLOCKS = 10
"""The env's timed steps and the SoMo-style reference's run in this many alternating blocks."""

SPEED_TARGET = 5.0
"""The design target of ``env / reference``: the env stepping 5 times as fast as the SoMo-style
rigid-link reference (the ratio each preset reaches is printed beside it)."""


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence C-level writes to stdout (PyBullet prints ``argv[0]=`` when it connects)."""
    sys.stdout.flush()
    try:
        saved = os.dup(1)
    except OSError:  # no real file descriptor (e.g. captured stdout): nothing to silence
        yield
        return
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            try:
                yield
            finally:
                sys.stdout.flush()
                os.dup2(saved, 1)
    finally:
        os.close(saved)


def speed_target_note(rows: list[dict]) -> str:
    """The line printed under the table that says what ``env/ref`` is, and how many presets
    reach :data:`SPEED_TARGET` (``rows``: the results, with ``env_over_reference``)."""
    ratios = [row["env_over_reference"] for row in rows
              if row.get("env_over_reference") is not None]
    met = sum(ratio >= SPEED_TARGET for ratio in ratios)
    span = f"{min(ratios):.2f}-{max(ratios):.2f}" if ratios else "none measured"
    return (f"env/ref: the env's steps/s over a SoMo-style rigid-link reference's control "
            f"steps/s on this machine at this moment (10 rigid links, spring torques set every "
            f"1 ms step, 20 Hz control, {REFERENCE_BLOCKS} alternating blocks); above 1 the env "
            f"is faster. Measured {span}; the design target of {SPEED_TARGET:g} or more is met "
            f"by {met} of {len(ratios)} presets")


class SoMoReference:
    """The yardstick of measurement 6: a SoMo-style rigid-link model of a soft arm.

    10 rigid links (10 mm capsules, 10 g), each on one revolute joint, the axes alternating
    between x and y; every 1 ms physics step the joint states are read, explicit spring-damper
    torques ``-k q - c v`` plus the held actuation torque are computed with numpy and set, and
    PyBullet steps; one control step (20 Hz) sets a new random actuation torque and runs 50
    physics steps. This is how SoMo (Graule et al. 2021) and similar PyBullet soft-arm models
    simulate, so ``env / reference`` says how the environment compares with that approach on
    the same machine at the same moment.
    """

    N_LINKS = 10
    PHYSICS_DT_S = 0.001
    CONTROL_PERIOD_S = 0.05

    def __init__(self, seed: int = 0) -> None:
        from pybullet_utils import bullet_client

        with quiet_stdout():
            self.client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
        c, n = self.client, self.N_LINKS
        c.setPhysicsEngineParameter(fixedTimeStep=self.PHYSICS_DT_S, numSubSteps=1)
        c.setGravity(0.0, 0.0, -9.81)
        length, radius, mass = 0.01, 0.004, 0.01
        shape = c.createCollisionShape(pybullet.GEOM_CAPSULE, radius=radius, height=length,
                                       collisionFramePosition=[0, 0, length / 2])
        self.body = c.createMultiBody(
            baseMass=0.0, basePosition=[0, 0, 0.2], baseOrientation=[1, 0, 0, 0],
            linkMasses=[mass] * n, linkCollisionShapeIndices=[shape] * n,
            linkVisualShapeIndices=[-1] * n,
            linkPositions=[[0, 0, 0]] + [[0, 0, length]] * (n - 1),
            linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=[[0, 0, length / 2]] * n,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=list(range(n)), linkJointTypes=[pybullet.JOINT_REVOLUTE] * n,
            linkJointAxis=[[1, 0, 0] if i % 2 == 0 else [0, 1, 0] for i in range(n)])
        self.joints = list(range(n))
        c.setJointMotorControlArray(self.body, self.joints, pybullet.VELOCITY_CONTROL,
                                    forces=[0.0] * n)
        # a 10 mm silicone-like beam segment: omega = sqrt(k / I) well below 1 / dt
        self.stiffness = np.full(n, 0.05)      # N m / rad
        self.damping = np.full(n, 2e-4)        # N m s / rad
        self.actuation = np.zeros(n)
        self.rng = np.random.default_rng(seed)
        self.substeps = int(round(self.CONTROL_PERIOD_S / self.PHYSICS_DT_S))

    def step(self) -> None:
        """One control step: a new actuation torque, then 50 physics steps with spring torques."""
        c, body, joints = self.client, self.body, self.joints
        self.actuation = self.rng.uniform(-0.02, 0.02, size=self.N_LINKS)
        for _ in range(self.substeps):
            states = c.getJointStates(body, joints)
            q = np.array([s[0] for s in states])
            v = np.array([s[1] for s in states])
            torque = self.actuation - self.stiffness * q - self.damping * v
            c.setJointMotorControlArray(body, joints, pybullet.TORQUE_CONTROL,
                                        forces=torque.tolist())
            c.stepSimulation()

    def close(self) -> None:
        self.client.disconnect()


def time_env(preset: str, task: str, steps: int, resets: int, seed: int,
             feedback: str = "ground_truth", reference_steps: int = 0) -> dict:
    """Measurements 1-4 and 6 for one preset (one env, one PyBullet client)."""
    start = time.perf_counter()
    with quiet_stdout():
        env = gym.make(TASK_IDS[task], preset=preset, feedback=feedback)
    make_s = time.perf_counter() - start
    try:
        sim = env.unwrapped.sim
        spec = sim.spec
        control_period_s = float(spec.control_period_s)
        physics_dt_s = float(sim.physics_dt_s)
        substeps = int(round(control_period_s / physics_dt_s))

        # 1. + 4. the env loop, with the time spent inside stepSimulation accumulated
        client_id = sim._client_id
        step_simulation = sim._step_simulation  # pybullet.stepSimulation, called by the loop
        in_step = [0.0]
        clock = time.perf_counter

        def timed_step_simulation(**kwargs):
            t = clock()
            step_simulation(**kwargs)
            in_step[0] += clock() - t

        env.action_space.seed(seed)
        env.reset(seed=seed)
        actions = [env.action_space.sample() for _ in range(steps)]
        step_s = 0.0
        loop_reset_s = 0.0
        loop_resets = 0
        # 6. the SoMo-style reference runs in the same process, block by block in turn with the
        # env's steps (A B A B ...), so that both see the same machine load
        reference = SoMoReference(seed) if reference_steps > 0 else None
        blocks = max(1, min(REFERENCE_BLOCKS, steps))
        reference_s, reference_done, block_ratios = 0.0, 0, []
        sim._step_simulation = timed_step_simulation
        try:
            for block in range(blocks):
                block_actions = actions[block * steps // blocks:(block + 1) * steps // blocks]
                block_s = 0.0
                for action in block_actions:
                    t0 = clock()
                    _, _, terminated, truncated, _ = env.step(action)
                    t1 = clock()
                    block_s += t1 - t0
                    if terminated or truncated:
                        in_reset = in_step[0]
                        env.reset()
                        loop_reset_s += clock() - t1
                        loop_resets += 1
                        in_step[0] = in_reset  # count only the physics of env.step calls
                step_s += block_s
                if reference is not None:
                    count = ((block + 1) * reference_steps // blocks
                             - block * reference_steps // blocks)
                    t0 = clock()
                    for _ in range(count):
                        reference.step()
                    elapsed = clock() - t0
                    reference_s += elapsed
                    reference_done += count
                    if count and block_actions:
                        block_ratios.append((len(block_actions) / block_s) / (count / elapsed))
        finally:
            sim._step_simulation = step_simulation
            if reference is not None:
                reference.close()
        in_loop_physics_s = in_step[0]

        # 2. physics-only bound: the same client and body, bare stepSimulation calls, from the
        # settled rest state of a reset (the last spring torques stay applied, so it rests there)
        env.reset(seed=seed)
        n_substeps = steps * substeps
        t0 = time.perf_counter()
        for _ in range(n_substeps):
            step_simulation(physicsClientId=client_id)
        physics_s = time.perf_counter() - t0

        # 3. reset time
        reset_times = []
        for i in range(resets):
            t0 = time.perf_counter()
            env.reset(seed=seed + 1 + i)
            reset_times.append(time.perf_counter() - t0)

        env_sps = steps / step_s
        physics_sps = steps / physics_s
        return {
            "preset": preset,
            "task": task,
            "n_joints": int(sim.arm.n_joints),
            "n_chambers": int(spec.n_chambers),
            "control_period_s": control_period_s,
            "physics_dt_s": physics_dt_s,
            "actuation_update_s": float(spec.actuation_update_s),
            "substeps_per_control": substeps,
            "settle_s": float(env.unwrapped.settle_s),
            "make_s": make_s,
            "steps": steps,
            "env_step_wall_s": step_s,
            "env_steps_per_s": env_sps,
            "env_step_ms": 1000.0 * step_s / steps,
            "loop_resets": loop_resets,
            "loop_reset_wall_s": loop_reset_s,
            "physics_substeps": n_substeps,
            "physics_wall_s": physics_s,
            "physics_substeps_per_s": n_substeps / physics_s,
            "physics_equiv_env_steps_per_s": physics_sps,
            "env_over_physics": env_sps / physics_sps,
            "in_loop_physics_wall_s": in_loop_physics_s,
            "in_loop_physics_fraction": in_loop_physics_s / step_s,
            "reset_count": resets,
            "reset_ms_mean": 1000.0 * float(np.mean(reset_times)) if reset_times else None,
            "reset_ms_max": 1000.0 * float(np.max(reset_times)) if reset_times else None,
            "sim_s_per_wall_s": steps * control_period_s / step_s,
            "sim_s_per_wall_s_with_resets": steps * control_period_s / (step_s + loop_reset_s),
            "reference_steps": reference_done,
            "reference_steps_per_s": reference_done / reference_s if reference_done else None,
            "env_over_reference": (env_sps / (reference_done / reference_s)
                                   if reference_done else None),
            "env_over_reference_block_median": (float(np.median(block_ratios))
                                                if block_ratios else None),
        }
    finally:
        env.close()


def tip_trajectory(spec, physics_dt_s: float, commands: np.ndarray, settle_s: float) -> np.ndarray:
    """Tip positions (m) after settling and after each held command, shape (len(commands)+1, 3)."""
    with quiet_stdout():
        sim = ArmSimulator(spec, physics_dt_s=physics_dt_s)
    try:
        sim.reset(settle_s=settle_s)
        tips = [sim.tip_pose()[0]]
        for pressure in commands:
            sim.set_pressures(pressure)
            sim.step_physics(spec.control_period_s)
            tips.append(sim.tip_pose()[0])
        return np.array(tips)
    finally:
        sim.close()


def accuracy(preset: str, control_steps: int, settle_s: float, seed: int,
             hold_steps: int = 10) -> dict:
    """Measurement 5: tip deviation of the default physics step from a 4x finer one."""
    spec = get_preset(preset)
    rng = np.random.default_rng(seed)
    low, high = spec.p_pre_pa, spec.p_max_pa
    n_commands = -(-control_steps // hold_steps)
    held = low + rng.random((n_commands, spec.n_chambers)) * (high - low)
    commands = np.repeat(held, hold_steps, axis=0)[:control_steps]
    fine_dt = spec.physics_dt_s / REFERENCE_REFINEMENT
    fine_spec = dataclasses.replace(spec, physics_dt_s=fine_dt)
    t0 = time.perf_counter()
    coarse = tip_trajectory(spec, spec.physics_dt_s, commands, settle_s)
    fine = tip_trajectory(fine_spec, fine_dt, commands, settle_s)
    wall_s = time.perf_counter() - t0
    deviation_mm = 1000.0 * np.linalg.norm(coarse - fine, axis=1)
    excursion_mm = 1000.0 * np.linalg.norm(fine - fine[0], axis=1)
    return {
        "accuracy_control_steps": control_steps,
        "accuracy_hold_steps": hold_steps,
        "reference_physics_dt_s": fine_dt,
        "tip_dev_max_mm": float(deviation_mm.max()),
        "tip_dev_final_mm": float(deviation_mm[-1]),
        "tip_dev_mean_mm": float(deviation_mm.mean()),
        "tip_excursion_max_mm": float(excursion_mm.max()),
        "accuracy_wall_s": wall_s,
    }


COLUMNS = (
    # header, key, format
    ("preset", "preset", "{}"),
    ("joints", "n_joints", "{:d}"),
    ("dt ms", "physics_dt_s", "{:.3g}", 1000.0),
    ("sub/step", "substeps_per_control", "{:d}"),
    ("env st/s", "env_steps_per_s", "{:.0f}"),
    ("phys st/s", "physics_equiv_env_steps_per_s", "{:.0f}"),
    ("env/phys", "env_over_physics", "{:.2f}"),
    ("phys share", "in_loop_physics_fraction", "{:.2f}"),
    ("ref st/s", "reference_steps_per_s", "{:.0f}"),
    ("env/ref", "env_over_reference", "{:.2f}"),
    ("reset ms", "reset_ms_mean", "{:.1f}"),
    ("sim s/wall s", "sim_s_per_wall_s", "{:.1f}"),
    ("dev max mm", "tip_dev_max_mm", "{:.3f}"),
    ("dev final mm", "tip_dev_final_mm", "{:.3f}"),
    ("excursion mm", "tip_excursion_max_mm", "{:.1f}"),
)


def format_table(rows: list[dict]) -> str:
    cells = []
    for row in rows:
        line = []
        for header, key, fmt, *scale in COLUMNS:
            value = row.get(key)
            if value is None:
                line.append("-")
                continue
            if scale:
                value = value * scale[0]
            line.append(fmt.format(value))
        cells.append(line)
    headers = [c[0] for c in COLUMNS]
    widths = [max(len(h), *(len(line[i]) for line in cells)) for i, h in enumerate(headers)]
    aligned = [str.ljust] + [str.rjust] * (len(headers) - 1)
    out = ["  ".join(a(h, w) for a, h, w in zip(aligned, headers, widths)),
           "  ".join("-" * w for w in widths)]
    out += ["  ".join(a(c, w) for a, c, w in zip(aligned, line, widths)) for line in cells]
    return "\n".join(out)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = CommandParser(
        description="Benchmark soft_gym environments: env step rate, physics-only bound, reset "
                    "time, simulated time per wall second and tip accuracy against a 4x finer "
                    "physics step. Prints a table, then JSON (or writes it to --json).",
        formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", choices=list(PRESETS), default=list(PRESETS),
                        metavar="NAME", help=f"arm presets to measure, from {list(PRESETS)}")
    parser.add_argument("--feedback", default="ground_truth",
                        choices=["ground_truth", "em", "fused", "camera", "fbg"],
                        help="feedback pose source; 'ground_truth' runs no camera, "
                             "'fused' the whole sensing pipeline (camera + vision + F-emp)")
    parser.add_argument("--task", choices=TASKS, default="reach",
                        help="environment task (reach: SoftArmReach-v0, track: SoftArmTrack-v0)")
    parser.add_argument("--steps", type=int, default=1000,
                        help="timed env steps per preset (also sets the physics-only substeps)")
    parser.add_argument("--resets", type=int, default=5, help="timed resets per preset")
    parser.add_argument("--reference-steps", type=int, default=None,
                        help="control steps of the SoMo-style reference run beside each preset's "
                             "env steps (default: a quarter of --steps; 0 skips it)")
    parser.add_argument("--hold-steps", type=int, default=10,
                        help="control periods each random command is held in the accuracy test "
                             "(10 = 0.5 s)")
    parser.add_argument("--accuracy-steps", type=int, default=60,
                        help="control steps of random pressure commands in the accuracy test "
                             "(0 skips it)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the env, its random actions and the pressure commands")
    parser.add_argument("--json", metavar="PATH", default=None,
                        help="write the results as JSON to PATH ('-' or omitted: print the JSON "
                             "to stdout after the table)")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps must be >= 1, got {args.steps}")
    if args.resets < 0:
        parser.error(f"--resets must be >= 0, got {args.resets}")
    if args.reference_steps is None:
        args.reference_steps = max(1, args.steps // 4)
    if args.reference_steps < 0:
        parser.error(f"--reference-steps must be >= 0, got {args.reference_steps}")
    if args.hold_steps < 1:
        parser.error(f"--hold-steps must be >= 1, got {args.hold_steps}")
    if args.accuracy_steps < 0:
        parser.error(f"--accuracy-steps must be >= 0, got {args.accuracy_steps}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rows = []
    total = time.perf_counter()
    for preset in args.presets:
        print(f"measuring {preset} ...", file=sys.stderr, flush=True)
        row = time_env(preset, args.task, args.steps, args.resets, args.seed, args.feedback,
                       args.reference_steps)
        if args.accuracy_steps:
            row.update(accuracy(preset, args.accuracy_steps, row["settle_s"], args.seed,
                                args.hold_steps))
        rows.append(row)
    total_s = time.perf_counter() - total

    results = {
        "benchmark": "soft_gym env speed",
        "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "settings": {"presets": args.presets, "task": args.task, "steps": args.steps,
                     "resets": args.resets, "accuracy_steps": args.accuracy_steps,
                     "reference_steps": args.reference_steps,
                     "seed": args.seed, "reference_refinement": REFERENCE_REFINEMENT},
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "processor": platform.processor() or platform.machine(),
                    "cpu_count": os.cpu_count(), "pybullet_api_version": pybullet.getAPIVersion(),
                    "numpy": np.__version__, "gymnasium": gym.__version__},
        "total_wall_s": total_s,
        "results": rows,
    }

    print(format_table(rows))
    accuracy_note = (f"{args.accuracy_steps} control steps vs physics_dt/{REFERENCE_REFINEMENT}"
                     if args.accuracy_steps else "skipped")
    print(f"({args.steps} env steps per preset, task {args.task}, seed {args.seed}; "
          f"accuracy: {accuracy_note}; total {total_s:.1f} s)")
    if args.reference_steps:
        print(speed_target_note(rows))
    text = json.dumps(results, indent=2)
    if args.json in (None, "-"):
        print(text)
    else:
        with open(args.json, "w", encoding="utf-8") as handle:
            handle.write(text + "\n")
        print(f"JSON written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
