"""The ho2018 tracking experiments: offline vs online local learning under static and filling
tip loads (Ho et al. 2018, Sections 3.4-3.5, Tables 1-2, Figs. 7, 8 and 10).

The ``lwpr_rwr`` baseline (:mod:`agents.controllers.lwpr_rwr`) tracks a rectangle projected onto
the upright ho2018 arm's workspace with EM feedback, driving the chambers' volumes through their
cylinders as the paper did (Section 3.1; ``actuation="volume"``, docs/architecture.md "Volume
actuation"; its ``u`` is then each cylinder's stroke, the paper's stepper position):

| experiment | rectangle | cycles | pre-training | window | runs (setting: load)       |
|------------|-----------|--------|--------------|--------|----------------------------|
| `static`   | 25 x 100 mm | 3    | 80 waypoints | 425    | offline: none; online: 14.2 g tip |
| `varying`  | 40 x 60 mm  | 4    | 320 waypoints| 550    | offline: empty 14 g fluid tip; offline: filling; online: filling |

How long and how fast (:data:`PROTOCOLS`):

| protocol | `static` cycle | `static` decisions | `varying` cycle | `varying` decisions | lead-in |
|----------|----------------|--------------------|-----------------|---------------------|---------|
| `paper` (default) | 133.3 s | 20 Hz | 45 s | offline 20 Hz, online 6.7 Hz | 30 s |
| `quick`  | 40 s | 10 Hz | 30 s | 10 Hz | 15 s |

The paper's: three static cycles "had a total runtime of 400 s" with online updates at 23 Hz on
average (Section 3.4.2). In the varying experiment's online run "the update rate was limited to
approximately 7 Hz, i.e. each online update took ~0.143 s" (Section 3.5.3), with "approximately
300 new training points" per cycle; its offline runs, without the updates, are read as running
at the loop's own rate, as the static ones. The varying cycle time is not stated, so 45 s gives
the online run 300 decisions at 6.7 Hz. One decision spans ``hold_steps`` of the env's 20 Hz
control steps, so 20 Hz (1 step) and 6.7 Hz (3 steps) are the rates nearest 23 and 7 Hz; each
run's ``lwpr_rwr`` is pre-trained on the same waypoints at its own decision period (the paper
pre-trained one model for the three runs). Each record counts the transitions online learning
took in each cycle (``learnt_per_cycle``; the paper had about 400 and 300 against windows of 425
and 550). ``quick`` is the shorter protocol: 400 and 300 decisions per cycle at 10 Hz.

Filling (ho2018 Section 3.5.2): +10 g from the start of cycle 3 and +6 g from the start of cycle 4,
at 0.6 g/s (0.6 mL/s of water), onto the 14 g container.

Projection onto the workspace (ho2018 Section 3.4: "projected to the 3D workspace of the robot,
which was approximated from the pre-training data"): a quadratic surface
``z = a + b x + c y + d x^2 + e x y + f y^2`` is fitted by least squares to the pre-training tip
positions, and the rectangle, centred on the arm's axis with its long side along x, is lifted
onto it. Before each run the tip tracks the rectangle's first corner for ``lead_in_s`` so that the
error settles ("the robot was allowed to track to the first point of the desired trajectory
until the error converged, at which point data acquisition was initiated": online learners learn
from then on; each record gives the lead-in's mean error over its last 5 s and the change from
the 5 s before, ``lead_in_settled_mm`` and ``lead_in_drift_mm``); the error is then recorded over
the cycles: the Euclidean distance between the target and the true tip (mm), per cycle mean,
standard deviation and maximum.

Further baselines (``cc_model``, ``hybrid_gpr``, ``sb3:PATH``) model or were trained on chamber
pressures, so they drive pressures on the same rectangle and load.

Pre-training check (ho2018 Section 3.2, Figs. 4-5; :func:`run_pretraining_check`): the static
experiment's pre-training walk, its transitions split 80/20 at random into training and test
sets, the forward LWPR trained on the 80 % epoch by epoch as ``lwpr_rwr`` trains it; the RMSE of
its predicted tip transitions ``dp`` on both sets (the paper: about 1 mm on the test set, best
at 11 of 15 epochs, 139 receptive fields), and the error of the inverse's command pushed through
the learned forward model against the asked ``dp`` of each test transition, per axis (the paper:
under 0.5 mm).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib
import numpy as np
from tqdm import tqdm

import soft_gym  # noqa: F401
from agents.policies import make_policy
from eval.report import package_version, write_json
from eval.runner import agent_error
from soft_gym._threads import one_compute_thread
from soft_gym._validation import require_bool, require_seed
from soft_gym.scenarios import FillingLoad, TipMass
from soft_gym.tasks.paths import PathSpec, make_reference_trajectory, workspace_surface

EXPERIMENTS = ("static", "varying")


@dataclass(frozen=True)
class Run:
    """One tracking run of an experiment: a policy (``lwpr_rwr`` offline or online, or another
    baseline) under a load (``none``, ``tip``, ``empty`` or ``filling``)."""

    label: str
    online: bool
    load: str
    policy: str = "lwpr_rwr"


@dataclass(frozen=True)
class Experiment:
    """One of the paper's two experiments (see the module docstring)."""

    name: str
    width_mm: float
    height_mm: float
    cycles: int
    pretrain_waypoints: int
    window: int
    runs: tuple[Run, ...]
    paper: dict[str, tuple[float, ...]] = field(default_factory=dict, compare=False)


EXPERIMENT_SPECS = {
    "static": Experiment(
        "static", 100.0, 25.0, 3, 80, 425,
        (Run("offline, no load", False, "none"), Run("online, 14.2 g tip", True, "tip")),
        paper={"offline, no load": (4.56, 5.72, 5.53), "online, 14.2 g tip": (4.42, 3.33, 1.63)}),
    "varying": Experiment(
        "varying", 60.0, 40.0, 4, 320, 550,
        (Run("offline, empty 14 g tip", False, "empty"),
         Run("offline, filling", False, "filling"), Run("online, filling", True, "filling")),
        paper={"offline, empty 14 g tip": (6.01, 7.19, 7.08, 6.94),
               "offline, filling": (5.82, 7.24, 10.36, 12.84),
               "online, filling": (4.16, 3.10, 1.07, 0.98)}),
}
"""The experiments, with the paper's per-cycle mean errors (mm, Tables 1 and 2)."""


@dataclass(frozen=True)
class Protocol:
    """How long and how fast the experiments run (see the module docstring).

    Attributes:
        cycle_s: seconds per rectangle cycle, per experiment.
        hold_steps: the env's 20 Hz control steps per ``lwpr_rwr`` decision (1: 20 Hz, 2: 10
            Hz, 3: 6.7 Hz), per experiment, for its ``"offline"`` and its ``"online"`` runs.
        lead_in_s: seconds tracking the first corner before recording.
    """

    cycle_s: dict[str, float]
    hold_steps: dict[str, dict[str, int]]
    lead_in_s: float


PROTOCOLS = {
    "paper": Protocol(cycle_s={"static": 400.0 / 3.0, "varying": 45.0},
                      hold_steps={"static": {"offline": 1, "online": 1},
                                  "varying": {"offline": 1, "online": 3}}, lead_in_s=30.0),
    "quick": Protocol(cycle_s={"static": 40.0, "varying": 30.0},
                      hold_steps={"static": {"offline": 2, "online": 2},
                                  "varying": {"offline": 2, "online": 2}}, lead_in_s=15.0),
}
"""The paper's protocol (the default) and the shorter one (``--quick``)."""

ACTUATION = "volume"
"""How ``lwpr_rwr`` drives the chambers in these experiments: the paper's cylinder volumes."""


def workspace_rectangle(surface: np.ndarray, width_mm: float, height_mm: float,
                        points_per_mm: float = 1.0) -> np.ndarray:
    """The closed rectangle ``width x height`` (mm, long side along x) centred on the axis,
    lifted onto the fitted surface; points (m) along its edges, first corner first."""
    corners = np.array([[-width_mm / 2, -height_mm / 2], [width_mm / 2, -height_mm / 2],
                        [width_mm / 2, height_mm / 2], [-width_mm / 2, height_mm / 2]])
    points = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) * points_per_mm)))
        points.extend(a + (b - a) * t for t in np.arange(n) / n)
    xy = np.array(points)
    x, y = xy.T
    z = surface @ np.stack([np.ones_like(x), x, y, x * x, x * y, y * y])  # as recorded: same bits
    return np.column_stack([xy, z]) / 1000.0


def _scenario(load: str, lead_in_s: float, cycle_s: float) -> list:
    if load == "none":
        return []
    if load == "tip":
        return [TipMass(mass_kg=0.0142)]
    if load == "empty":
        return [TipMass(mass_kg=0.014)]
    if load == "filling":
        return [FillingLoad(initial_mass_kg=0.014, added_mass_kg=0.010, rate_kg_s=0.0006,
                            start_s=lead_in_s + 2 * cycle_s),
                FillingLoad(initial_mass_kg=0.0, added_mass_kg=0.006, rate_kg_s=0.0006,
                            start_s=lead_in_s + 3 * cycle_s)]
    raise ValueError(f"load must be one of none, tip, empty, filling; got {load!r}")


def check_baselines(baselines: tuple[str, ...], preset: str = "ho2018") -> None:
    """Refuse (``ValueError``) a baseline that cannot drive ``preset`` with this experiment's
    observation (pose and target, EM feedback), or an ``sb3:PATH`` agent that holds no model or
    reads or writes other spaces than its env's (pose, target and pressure, with the agent's own
    interface), before any work."""
    for policy in baselines:
        if policy.startswith("sb3:"):
            message = agent_error(policy, "SoftArmReach-v0",
                                  {"preset": preset, "feedback": "em",
                                   "obs": ("pose", "target", "pressure")})
            if message is not None:
                raise ValueError(f"{policy}: {message}")
        else:
            probe = gym.make("SoftArmReach-v0", preset=preset, feedback="em",
                             obs=("pose", "target"))
            try:
                make_policy(policy, probe)
            finally:
                probe.close()


def run_experiment(name: str, seed: int = 0, protocol: str = "paper",
                   cycle_s: float | None = None, lead_in_s: float | None = None,
                   preset: str = "ho2018", pretrain_waypoints: int | None = None,
                   baselines: tuple[str, ...] = (), progress: bool = True,
                   env_options: dict[str, Any] | None = None,
                   **controller_params: Any) -> dict[str, dict]:
    """Run every setting of experiment ``name`` once; returns per-run records (targets, tips,
    errors, per-cycle statistics, transitions learnt per cycle, the lead-in's settling).

    ``protocol``: ``"paper"`` or ``"quick"`` (:data:`PROTOCOLS`); ``cycle_s`` and ``lead_in_s``
    (s) replace its cycle time and lead-in, ``hold_steps`` among ``controller_params`` its
    decision rate. ``baselines``: further policies (``cc_model``, ``hybrid_gpr``, ``sb3:PATH``)
    run on the same rectangle under the load of the experiment's online run, for comparison
    (their own calibration, driving pressures; ``controller_params`` go to ``lwpr_rwr`` only,
    ``window`` among them replacing the experiment's). ``env_options``: further ``gym.make``
    keywords of every run's env (e.g. ``sensor_config``, or ``actuation="pressure"`` for the
    ``lwpr_rwr`` runs).
    """
    if name not in EXPERIMENT_SPECS:
        raise ValueError(f"experiment must be one of {list(EXPERIMENT_SPECS)}, got {name!r}")
    if protocol not in PROTOCOLS:
        raise ValueError(f"protocol must be one of {list(PROTOCOLS)}, got {protocol!r}")
    experiment = EXPERIMENT_SPECS[name]
    timing = PROTOCOLS[protocol]
    waypoints = experiment.pretrain_waypoints if pretrain_waypoints is None else pretrain_waypoints
    cycle_s = timing.cycle_s[name] if cycle_s is None else cycle_s
    lead_in_s = timing.lead_in_s if lead_in_s is None else lead_in_s
    load = experiment.runs[-1].load
    runs = list(experiment.runs) + [Run(f"{policy}, {_LOAD_NAMES[load]}", False, load, policy)
                                    for policy in baselines]
    check_baselines(baselines, preset)
    results = {}
    path_m = None
    for run in runs:
        total_s = lead_in_s + experiment.cycles * cycle_s
        interface: dict[str, Any] = {"obs": ("pose", "target"), "actuation": ACTUATION}
        agent = None
        if run.policy.startswith("sb3:"):  # the env as the agent was trained (its obs, actions)
            agent = make_policy(run.policy)
            interface = {"obs": ("pose", "target", "pressure"), **agent.env_interface}
        elif run.policy != "lwpr_rwr":
            interface["actuation"] = "pressure"  # their models are in chamber pressures
        env = gym.make("SoftArmReach-v0", preset=preset, feedback="em",
                       scenario=_scenario(run.load, lead_in_s, cycle_s),
                       episode_steps=int(round(total_s / 0.05)) + 10,
                       **{**interface, **(env_options or {})})
        try:
            if run.policy == "lwpr_rwr":
                policy = make_policy("lwpr_rwr", env, **lwpr_rwr_settings(
                    name, run.online, seed, protocol, waypoints, **controller_params))
                report = policy.pretrain()
                if path_m is None:
                    path_m = workspace_rectangle(workspace_surface(policy.pretraining_tips_mm()),
                                                 experiment.width_mm, experiment.height_mm)
            else:
                if path_m is None:
                    raise ValueError("baselines run after the lwpr_rwr runs, which place the "
                                     "rectangle")
                if agent is not None:
                    agent.check_env(env)
                    policy = agent
                else:
                    policy = make_policy(run.policy, env)
                report = {}
            results[run.label] = _track(env, policy, path_m, experiment.cycles, cycle_s,
                                        lead_in_s, seed, progress, f"{name}: {run.label}")
            results[run.label]["pretraining"] = report
        finally:
            env.close()
    return results


def lwpr_rwr_settings(name: str, online: bool, seed: int = 0, protocol: str = "paper",
                      pretrain_waypoints: int | None = None,
                      **controller_params: Any) -> dict[str, Any]:
    """``lwpr_rwr``'s keywords in experiment ``name``'s offline or ``online`` runs under
    ``protocol``: the protocol's decision rate, the experiment's window and pre-training
    waypoints (``pretrain_waypoints`` replaces them), ``seed``; ``controller_params`` replace
    any of them but the waypoints and the seed."""
    experiment = EXPERIMENT_SPECS[name]
    waypoints = experiment.pretrain_waypoints if pretrain_waypoints is None else pretrain_waypoints
    rate = PROTOCOLS[protocol].hold_steps[name]["online" if online else "offline"]
    return {"online": online, "hold_steps": rate, "window": experiment.window,
            **controller_params, "pretrain_waypoints": waypoints, "seed": seed}


QUICK_PRETRAIN_WAYPOINTS = 8
"""``run_pretraining_check(quick=True)``'s waypoints: a tenth of the static experiment's 80
(240 transitions at its 30 decisions a line)."""


def run_pretraining_check(seed: int = 0, quick: bool = False, progress: bool = True) -> dict:
    """ho2018 Section 3.2's validation of the pre-trained models (Figs. 4-5), on the static
    experiment's pre-training (the paper's protocol: 80 random actuator-space waypoints joined by
    straight lines, a decision every 20 Hz control step, on the unloaded, volume-driven arm with
    EM feedback; ``quick``: :data:`QUICK_PRETRAIN_WAYPOINTS` waypoints, the rest alike).

    The walk and the forward LWPR's training are ``lwpr_rwr``'s own
    (:meth:`~agents.controllers.lwpr_rwr.LWPRRWRController.pretrain`): the transitions
    ``(p, u, du) -> dp`` are split 80/20 at random (seeded by ``seed``), the model is trained
    on the 80 % for up to ``max_epochs`` (15) epochs and the epoch with the lowest test RMSE is
    kept, so the test set also picks the epoch, as in the paper's Fig. 4. The inverse
    (reward-weighted regression on the forward model's receptive fields, with its null-space
    attractor) is fitted on the training transitions only, so the test transitions are new to
    both models (``lwpr_rwr`` fits it on all of them: ``inverse_error_deployed_mm``).

    Returns (JSON-able; lengths and positions in mm):

    * ``n_transitions``, ``n_train``, ``n_test``, ``waypoints``, ``hold_steps``;
    * ``receptive_fields``: the kept forward model's fields per output coordinate (x, y, z);
    * ``forward_rmse_mm``: ``train`` and ``test``, the RMSE of the predicted ``dp`` (the root of
      the mean squared 3-D error); ``forward_rmse_axis_mm``: the same per axis;
      ``forward_rmse_history_mm``: ``train`` and ``test`` after every epoch run;
    * ``zero_dp_rmse_mm``: ``train`` and ``test``, the RMSE of predicting no motion (a reference
      the model must beat); ``em_noise_floor_mm``: the RMSE a perfect model would still have
      against ``dp`` read from two noisy EM readings (``sqrt(6)`` times the per-axis noise);
    * ``inverse_error_mm``: for each test transition, the inverse's ``du`` for its ``dp`` at its
      ``(p, u)``, pushed through the learned forward model, against that ``dp``:
      ``max_per_axis`` (the paper's error bounds), ``rmse_per_axis`` and ``mean`` (of the 3-D
      error); ``inverse_error_reachable_mm``: the same for the ``dp`` the forward model predicts
      for the recorded transition (a ``dp`` the model can reach, without the tracker's noise);
      ``inverse_error_deployed_mm``: ``inverse_error_mm`` of the inverse fitted on all
      transitions, as ``lwpr_rwr`` deploys it;
    * ``epochs`` (the kept epoch, 1-based), ``epochs_run``, ``max_epochs``.
    """
    seed = require_seed("seed", seed)
    quick = require_bool("quick", quick)
    progress = require_bool("progress", progress)
    name = "static"
    env = gym.make("SoftArmReach-v0", preset="ho2018", feedback="em", obs=("pose", "target"),
                   actuation=ACTUATION)
    try:
        policy = make_policy("lwpr_rwr", env, cache=False, progress=progress,
                             **lwpr_rwr_settings(name, False, seed, pretrain_waypoints=(
                                 QUICK_PRETRAIN_WAYPOINTS if quick else None)))
        noise_m = float(env.unwrapped.sensors["em"].position_noise_m)
        with one_compute_thread():  # as the pre-training's cache computes it: the same bits
            data = policy._collect_pretraining_data()
            p, u, du, dp = data
            inputs = np.concatenate([p, u, du], axis=1)
            split: dict[str, np.ndarray] = {}
            train_history: list[float] = []

            def on_epoch(model, train: np.ndarray, test: np.ndarray) -> None:
                split.update(train=train, test=test)
                train_history.append(_rmse(model.predict_batch(inputs[train]) - dp[train]))

            forward, report = policy._train_forward(data, on_epoch=on_epoch)
            policy.forward = forward
            train, test = split["train"], split["test"]
            inverse = policy._fit_inverse(tuple(array[train] for array in data))
            deployed = policy._fit_inverse(data)
            errors = {part: forward.predict_batch(inputs[rows]) - dp[rows]
                      for part, rows in split.items()}
            reachable = forward.predict_batch(inputs[test])
            inverse_errors = {
                "inverse_error_mm": _inverse_error(forward, inverse, p[test], u[test], dp[test]),
                "inverse_error_reachable_mm": _inverse_error(forward, inverse, p[test], u[test],
                                                             reachable),
                "inverse_error_deployed_mm": _inverse_error(forward, deployed, p[test], u[test],
                                                            dp[test])}
    finally:
        env.close()
    best = report["best_epoch"]
    return {"n_transitions": int(len(inputs)), "n_train": int(len(train)),
            "n_test": int(len(test)),
            "waypoints": policy.pretrain_waypoints, "hold_steps": policy.hold_steps,
            "receptive_fields": [int(n) for n in forward.fields_per_output],
            "forward_rmse_mm": {part: _rmse(error) for part, error in errors.items()},
            "forward_rmse_axis_mm": {part: [float(v) for v in np.sqrt(np.mean(error ** 2, axis=0))]
                                     for part, error in errors.items()},
            "forward_rmse_history_mm": {"train": train_history,
                                        "test": [float(v) for v in report["test_rmse_mm"]]},
            "zero_dp_rmse_mm": {part: _rmse(dp[rows]) for part, rows in split.items()},
            "em_noise_floor_mm": float(np.sqrt(6.0) * noise_m * 1000.0),
            **inverse_errors,
            "epochs": int(best), "epochs_run": len(report["test_rmse_mm"]),
            "max_epochs": policy.max_epochs}


def _rmse(error: np.ndarray) -> float:
    """The root of the mean squared norm of the rows of ``error``."""
    return float(np.sqrt(np.mean(np.sum(error ** 2, axis=1))))


def _inverse_error(forward, inverse, p: np.ndarray, u: np.ndarray,
                   wanted: np.ndarray) -> dict[str, Any]:
    """The forward model's ``dp`` for the inverse's ``du`` at each ``(p, u)``, less the
    ``wanted`` ``dp`` (mm): the largest per axis, the RMSE per axis and the mean 3-D error."""
    du = np.array([inverse.predict(w, p_k, u_k) for w, p_k, u_k in zip(wanted, p, u)])
    error = forward.predict_batch(np.concatenate([p, u, du], axis=1)) - wanted
    return {"max_per_axis": [float(v) for v in np.abs(error).max(axis=0)],
            "rmse_per_axis": [float(v) for v in np.sqrt(np.mean(error ** 2, axis=0))],
            "mean": float(np.linalg.norm(error, axis=1).mean())}


LEAD_IN_WINDOW_S = 5.0
"""The lead-in's settling is read over its last ``LEAD_IN_WINDOW_S`` (s) against the one before."""


def lead_in_settling(errors_mm: np.ndarray, window: int) -> tuple[float, float]:
    """How far the lead-in's error had settled: its mean over the last ``window`` steps (mm), and
    that mean less the mean of the ``window`` steps before (mm; negative while still falling).
    A lead-in shorter than a window is read over what it has; NaN where there is nothing."""
    errors_mm = np.asarray(errors_mm, dtype=float)
    end = len(errors_mm)
    settled = errors_mm[max(0, end - window):]
    before = errors_mm[max(0, end - 2 * window):max(0, end - window)]
    if not settled.size:
        return float("nan"), float("nan")
    mean = float(settled.mean())
    return mean, (mean - float(before.mean())) if before.size else float("nan")


_LOAD_NAMES = {"none": "no load", "tip": "14.2 g tip", "empty": "empty 14 g tip",
               "filling": "filling"}


def _track(env, policy, path_m: np.ndarray, cycles: int, cycle_s: float, lead_in_s: float,
           seed: int, progress: bool, label: str) -> dict:
    """Lead-in on the first corner, then ``cycles`` rectangles; the policy sees the env's
    observation with its ``target`` part set to this experiment's targets."""
    unwrapped = env.unwrapped
    period = unwrapped.arm.control_period_s
    length = float(np.linalg.norm(np.diff(np.vstack([path_m, path_m[:1]]), axis=0), axis=1).sum())
    spec = PathSpec(shape="waypoints", center_m=(0.0, 0.0, 0.0), radius_m=1.0,
                    speed_m_s=length / cycle_s, cycles=cycles, waypoints_m=path_m)
    trajectory = make_reference_trajectory(spec, period)
    lead_in = int(round(lead_in_s / period))
    targets = np.vstack([np.repeat(trajectory[:1], lead_in, axis=0), trajectory])
    observation, _ = env.reset(seed=seed)
    policy.reset()
    tips = np.empty_like(targets)

    def with_targets(observation, k: int) -> np.ndarray:
        observation = np.array(observation, copy=True)
        unwrapped.observation_part(observation, "target")[:] = np.concatenate(
            [targets[k], targets[min(k + 1, len(targets) - 1)]])
        return observation

    learnt = np.zeros(len(targets), dtype=int)  # transitions learnt so far, after each step
    bar = tqdm(total=len(targets), desc=label, disable=not progress, leave=False)
    for k in range(len(targets)):
        seen = with_targets(observation, k)
        action, _ = policy.predict(seen, deterministic=True)
        observation, reward, _, _, info = env.step(action)
        if k >= lead_in:  # "at which point data acquisition was initiated" (Section 3.4)
            policy.update(seen, action, reward,
                          with_targets(observation, min(k + 1, len(targets) - 1)), info)
        tips[k] = info["tip_position_m"]
        learnt[k] = getattr(policy, "learnt_transitions", 0)
        bar.update(1)
    bar.close()
    # after step k the tip should be at the target the policy was sent to, targets[k + 1]
    aimed = np.vstack([targets[1:], targets[-1:]])
    all_errors_mm = np.linalg.norm(tips - aimed, axis=1) * 1000.0
    errors_mm = all_errors_mm[lead_in:]
    per_cycle = np.array_split(errors_mm, cycles)
    ends = np.cumsum([len(c) for c in per_cycle]) + lead_in - 1
    learnt_per_cycle = np.diff(np.concatenate([[learnt[lead_in - 1] if lead_in else 0],
                                               learnt[ends]]))
    settled_mm, drift_mm = lead_in_settling(all_errors_mm[:lead_in],
                                            int(round(LEAD_IN_WINDOW_S / period)))
    return {"targets_m": aimed[lead_in:], "tips_m": tips[lead_in:], "errors_mm": errors_mm,
            "time_s": np.arange(len(errors_mm)) * period,
            "cycle_mean_mm": [float(c.mean()) for c in per_cycle],
            "cycle_std_mm": [float(c.std()) for c in per_cycle],
            "cycle_max_mm": [float(c.max()) for c in per_cycle],
            "learnt_per_cycle": [int(n) for n in learnt_per_cycle],
            "actuation": "volume" if unwrapped.arm.cylinders is not None else "pressure",
            "decision_hz": 1.0 / (period * getattr(policy, "hold_steps", 1)),
            "lead_in_settled_mm": settled_mm, "lead_in_drift_mm": drift_mm}


def report_table(name: str, results: dict[str, dict]) -> str:
    """Markdown table like the paper's Tables 1-2: per-cycle mean (std) and max, ours and the
    paper's means."""
    experiment = EXPERIMENT_SPECS[name]
    header = ["setting"] + [f"cycle {i + 1} mean (std)" for i in range(experiment.cycles)] + \
        [f"cycle {i + 1} max" for i in range(experiment.cycles)] + ["learnt per cycle",
                                                                   "paper means"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for label, record in results.items():
        cells = [label] + [f"{m:.2f} ({s:.2f})" for m, s in zip(record["cycle_mean_mm"],
                                                                  record["cycle_std_mm"])]
        cells += [f"{m:.2f}" for m in record["cycle_max_mm"]]
        cells.append(", ".join(str(n) for n in record["learnt_per_cycle"]))
        cells.append(", ".join(f"{v:.2f}" for v in experiment.paper.get(label, ())))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot_experiment(path: str | Path, name: str, results: dict[str, dict]) -> Path:
    """Figs. 7/8/10-like figure: tracked path over the target (top view) and the error over
    time with the cycle boundaries, one column per setting."""
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # here: +0.4 s for every python -m eval command

    experiment = EXPERIMENT_SPECS[name]
    fig, axes = plt.subplots(2, len(results), figsize=(4.5 * len(results), 7), squeeze=False)
    for column, (label, record) in enumerate(results.items()):
        top, bottom = axes[0, column], axes[1, column]
        target, tip = record["targets_m"] * 1000, record["tips_m"] * 1000
        top.plot(target[:, 0], target[:, 1], "k--", lw=1, label="target")
        top.plot(tip[:, 0], tip[:, 1], lw=0.8, label="tip")
        top.set(title=label, xlabel="x (mm)", ylabel="y (mm)", aspect="equal")
        top.legend(fontsize=8)
        bottom.plot(record["time_s"], record["errors_mm"], lw=0.8)
        for i in range(1, experiment.cycles):
            bottom.axvline(record["time_s"][-1] * i / experiment.cycles, color="grey", ls=":")
        bottom.set(xlabel="time (s)", ylabel="tracking error (mm)")
    fig.suptitle(f"ho2018 {name} load experiment")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run_and_report(experiments: list[str], seeds: list[int], out: str | Path,
                   protocol: str = "paper", cycle_s: float | None = None,
                   lead_in_s: float | None = None, baselines: tuple[str, ...] = ()) -> dict:
    """Run the experiments for every seed under ``protocol`` (:data:`PROTOCOLS`); write
    ``ho2018_<experiment>_seed<N>.md/.png`` and ``ho2018.json`` under ``out`` and print the
    tables."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary: dict[str, Any] = {}
    for name in experiments:
        for seed in seeds:
            results = run_experiment(name, seed=seed, protocol=protocol, cycle_s=cycle_s,
                                     lead_in_s=lead_in_s, baselines=baselines)
            table = report_table(name, results)
            print(f"\n{name} load experiment, seed {seed} (tracking error, mm)\n{table}")
            (out / f"ho2018_{name}_seed{seed}.md").write_text(table + "\n")
            plot_experiment(out / f"ho2018_{name}_seed{seed}.png", name, results)
            summary[f"{name}_seed{seed}"] = {
                label: {key: record[key] for key in (
                    "cycle_mean_mm", "cycle_std_mm", "cycle_max_mm", "learnt_per_cycle",
                    "lead_in_settled_mm", "lead_in_drift_mm", "pretraining")}
                for label, record in results.items()}
    write_json(out / "ho2018.json", {"soft_arm_gym_version": package_version(),
                                     "protocol": protocol, "experiments": summary})
    return summary
