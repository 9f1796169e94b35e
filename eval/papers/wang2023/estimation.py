"""The wang2023 estimation experiments: camera, F-emp and fusion against ground truth.

The wang2023 arm is driven open loop through a spiral actuation sequence (0.05 s steps) while the
sensing pipeline runs with the given visual faults and loads (wang2023 Section IV-B/C/F):

| experiment  | what happens (times for the default 4000 steps = 200 s)            | paper        |
|-------------|---------------------------------------------------------------------|--------------|
| `clean`     | nothing                                                             | IV-C         |
| `occlusion` | moving partial occluder 100-160 s, full ~2 s covers 160-200 s       | Fig. 6       |
| `lighting`  | low light 25-75 s, darkness 75-150 s, moving LED glare 150-200 s    | Fig. 7       |
| `push`      | slow push on the tip cap 40-70 s, then on the fiber-covered body 110-140 s | Table III |
| `flick`     | a fast flick on the tip every 10 s                                  | Table IV     |
| `init`      | flicks, with F-emp initialised from 450 / 900 / 1800 samples        | Table VI     |

The two pushes each displace the resting tip by ~15 mm, as the paper's did ("undesired
displacements (~15 mm) were induced by the push", Fig. 13): 0.07 N on the tip cap (15.8 mm) and
0.3 N on the second link of the fiber-covered body (14.3 mm), where it also strains the gratings
under it (:mod:`soft_gym.sensors.fbg`, contact strain).

For `init`, each run explores 1800 steps and F-emp is labelled by the last 450 / 900 / 1800 of
them, and F-emp does not guide the vision tracker, so the three share the same camera estimates
and differ only in F-emp's initialisation.

Each run writes a per-step CSV and an error-vs-time PNG (and with ``video=True`` an MP4 of the
scene beside the faulted eye-in-hand frame with the estimates and ``e_S`` written on it,
:mod:`eval.video`); the Markdown table lists mean, max, std and RMSE (mm) of each estimator per
phase; ``estimation.json`` holds the same rows with the soft-arm-gym version that made them.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import soft_gym  # noqa: F401
from eval.metrics import estimation_errors
from eval.report import markdown_table, plot_estimation, write_records_csv, write_results_json
from eval.video import VideoWriter
from soft_gym.envs.rendering import default_panels, render_frame
from soft_gym.robots.actuation import Actuation, pressure_at_fraction
from soft_gym.papers.wang2023.exploration import spiral_fractions

EXPERIMENTS = ("clean", "occlusion", "lighting", "push", "flick", "init")
INIT_SAMPLES = (450, 900, 1800)
"""F-emp initialisation sizes of the ``init`` experiment (wang2023 Table VI)."""
ESTIMATORS = ("camera", "femp", "fused")
ESTIMATION_SPIRAL = {"turn_s": 10.0, "breath_s": 80.0, "low": 0.05, "high": 0.45}
"""The estimation sequence (:func:`spiral_fractions` keywords; wang2023 Section IV-B: "a
trajectory that spreads out from the initial position"). The bending direction turns every 10 s
while the amplitude breathes between 5 % and 45 % of the pressure range every 80 s, so the tip
spreads out to the outer trajectory (~13 mm from the rest position) at 40, 120 and 200 s and
comes back in between. The full covers of ``occlusion`` (160-200 s) thus fall on the way out,
where the steps are longest, as the paper's did (its outer trajectory was in the last 175-200 s).
With a 60 s breath the covers fell around the innermost turn (180 s) and the held camera pose
was at most 11 mm off."""


def _phases(experiment: str, duration_s: float) -> list[tuple[str, float, float]]:
    s = duration_s / 200.0
    table = {
        "clean": [("all", 0.0, duration_s)],
        "occlusion": [("undisturbed", 0.0, 100 * s), ("partial occluder", 100 * s, 160 * s),
                      ("full covers", 160 * s, 200 * s)],
        "lighting": [("ordinary light", 0.0, 25 * s), ("weak light", 25 * s, 75 * s),
                     ("darkness", 75 * s, 150 * s), ("LED glare", 150 * s, 200 * s)],
        "push": [("free", 0.0, 40 * s), ("push on tip cap", 40 * s, 70 * s),
                 ("push on body", 110 * s, 140 * s)],
        "flick": [("all", 0.0, duration_s)],
        # F-emp's initialisation shows most before the online updates take over
        "init": [("all", 0.0, duration_s), ("first 20 s", 0.0, 20 * s)],
    }
    return table[experiment]


def _conditions(experiment: str, duration_s: float) -> tuple[object, object]:
    """(faults, scenario) of an experiment."""
    s = duration_s / 200.0
    if experiment == "occlusion":
        return {"name": "wang2023_occlusion", "time_scale": s}, None
    if experiment == "lighting":
        return {"name": "wang2023_lighting", "time_scale": s}, None
    if experiment == "push":
        return None, [
            {"name": "push", "force_n": (0.07, 0.0, 0.0), "on_tip_cap": True, "start_s": 40 * s,
             "end_s": 70 * s, "ramp_s": 10 * s},
            {"name": "push", "force_n": (0.3, 0.0, 0.0), "link": 1, "start_s": 110 * s,
             "end_s": 140 * s, "ramp_s": 10 * s}]
    if experiment in ("flick", "init"):
        return None, [{"name": "flick", "impulse_ns": (0.003 * np.cos(k), 0.003 * np.sin(k), 0.0),
                       "start_s": 10.0 * (k + 1)} for k in range(int(duration_s // 10) - 1)]
    return None, None


def _sensing(experiment: str, n_init: int, explore_steps: int = max(INIT_SAMPLES)) -> dict:
    """Sensing-pipeline options of an experiment: F-emp initialised from ``n_init`` samples.

    ``init`` explores ``explore_steps`` steps (the largest initialisation size of its ladder)
    whatever ``n_init`` and labels F-emp with the last ``n_init`` of them, and keeps F-emp out
    of the vision tracker's matching, so every ``n_init`` sees the same camera estimates."""
    if experiment != "init":
        return {"n_init": n_init}
    if not isinstance(n_init, int) or isinstance(n_init, bool) \
            or not 10 <= n_init <= explore_steps:
        raise ValueError(f"n_init must be an integer in [10, {explore_steps}] for the init "
                         f"experiment, got {n_init!r}")
    return {"n_init": n_init, "map_steps": explore_steps - n_init, "femp_prior": False}


def run_estimation(experiment: str, steps: int = 4000, n_init: int = 450, seed: int = 0,
                   progress: bool = True, video_path: str | Path | None = None,
                   init_samples: tuple[int, ...] = INIT_SAMPLES) -> dict[str, np.ndarray]:
    """One estimation run; returns the per-step record (see :mod:`eval.runner`). With
    ``video_path``, also writes its video there (one frame after reset and one per step).
    ``init_samples``: the ``init`` experiment's ladder of initialisation sizes (its largest
    sets the exploration's length, so every size sees the same camera; default the paper's)."""
    if experiment not in EXPERIMENTS:
        raise ValueError(f"experiment must be one of {list(EXPERIMENTS)}, got {experiment!r}")
    duration_s = steps * 0.05
    faults, scenario = _conditions(experiment, duration_s)
    env = gym.make("SoftArmReach-v0", preset="wang2023", feedback="fused", faults=faults,
                   scenario=scenario, episode_steps=steps,
                   sensing=_sensing(experiment, n_init, max(init_samples)))
    unwrapped = env.unwrapped
    spec = unwrapped.arm
    actuation = Actuation.of_env(env)
    video = None
    if video_path is not None:
        panels = default_panels(env)
        video = VideoWriter(video_path, unwrapped.metadata["render_fps"])
    env.reset(seed=seed)
    if video is not None:
        video.append(render_frame(env, panels))
    columns: dict[str, list] = {key: [] for key in (
        "time_s", "tip_m", "target_m", "camera_m", "femp_m", "fused_m", "reprojection_error_px",
        "lost", "femp_weight", "femp_updated")}
    for k in tqdm(range(steps), desc=experiment, disable=not progress, leave=False):
        fraction = spiral_fractions(k * spec.control_period_s, **ESTIMATION_SPIRAL)
        _, _, _, _, info = env.step(actuation.action(pressure_at_fraction(spec, fraction)))
        estimates = info["estimates"]
        columns["time_s"].append(info["time_s"])
        columns["tip_m"].append(info["tip_position_m"])
        columns["target_m"].append(info["target_m"])
        for key in ESTIMATORS:
            columns[f"{key}_m"].append(estimates[key])
        columns["reprojection_error_px"].append(estimates["reprojection_error_px"])
        columns["lost"].append(float(estimates["lost"]))
        columns["femp_weight"].append(estimates["femp_weight"])
        columns["femp_updated"].append(float(estimates["femp_updated"]))
        if video is not None:
            video.append(render_frame(env, panels))
    if video is not None:
        video.close()
    env.close()
    return {key: np.asarray(value, dtype=float) for key, value in columns.items()}


def fusion_weights(record: dict[str, np.ndarray], start_s: float = 0.0,
                   end_s: float = np.inf) -> dict[str, float]:
    """How the fusion used the camera over ``[start_s, end_s)``: F-emp's mean weight, the share
    of frames where the camera's weight is at least one half, that share among the frames where
    the camera was the more accurate, and the share of frames F-emp learned from."""
    inside = (record["time_s"] >= start_s) & (record["time_s"] < end_s)
    weight = record["femp_weight"][inside]
    camera_error = np.linalg.norm(record["camera_m"][inside] - record["tip_m"][inside], axis=1)
    femp_error = np.linalg.norm(record["femp_m"][inside] - record["tip_m"][inside], axis=1)
    camera_better = camera_error < femp_error
    trusted = weight <= 0.5
    return {"femp_weight_mean": float(weight.mean()) if weight.size else float("nan"),
            "camera_trusted_share": float(trusted.mean()) if weight.size else float("nan"),
            "camera_trusted_when_better": (float(trusted[camera_better].mean())
                                           if camera_better.any() else float("nan")),
            "femp_updated_share": (float(record["femp_updated"][inside].mean())
                                   if weight.size else float("nan"))}


def run_experiments(experiments: list[str], out_dir: str | Path, steps: int = 4000,
                    seed: int = 0, progress: bool = True, video: bool = False) -> list[dict]:
    """Run experiments, write CSV / PNG (and with ``video`` an MP4) per run and a Markdown +
    JSON summary; return rows."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for experiment in experiments:
        inits = INIT_SAMPLES if experiment == "init" else (450,)
        for n_init in inits:
            name = experiment if experiment != "init" else f"init{n_init}"
            filming = {"video_path": out / f"{name}.mp4"} if video else {}
            record = run_estimation(experiment, steps=steps, n_init=n_init, seed=seed,
                                    progress=progress, **filming)
            phases = _phases(experiment, steps * 0.05)
            errors = estimation_errors(record, phases=phases)
            write_records_csv(out / f"{name}.csv", record)
            plot_estimation(out / f"{name}.png", record, f"wang2023 estimation: {name}",
                            phases=phases)
            for phase, start_s, end_s in phases:
                row = {"experiment": name, "phase": phase}
                for estimator in ESTIMATORS:
                    stats = errors[estimator]["phases"][phase]
                    for key in ("mean_mm", "max_mm", "std_mm", "rmse_mm"):
                        row[f"{estimator}_{key}"] = stats[key]
                row.update(fusion_weights(record, start_s, end_s))
                rows.append(row)
    write_results_json(out / "estimation.json", rows)
    (out / "estimation.md").write_text(markdown_table(rows) + "\n")
    return rows
