"""The zou2022 experiments: the DNN against constant curvature and vision, ASES under visual
faults, and control with each shape source (Zou et al. 2022, Sections 4.4 and 5, Tables 3-4,
Figs. 13, 16, 18 and 19).

``table3`` (Section 5.1 (3)): the DNN (:mod:`soft_gym.papers.zou2022.shape_dnn`: each command of the
0.1 bar grid at most once, in random order, labelled by ASES, Table 2's network; train /
validation / test split by command, so no test sample repeats a training command, which the
table reports as ``test_share_with_a_training_command``) on its test set: MAE and
RMSE per axis (mm) of the seven points against the ASES labels (the paper's Table 3: RMSE
2.56 / 2.59 / 2.61 mm) and against the simulator's true points (which the paper could not
measure), the mean per-sample RMSE (paper 2.302 mm) and the share of errors within +-2.5 mm per
axis (paper 82 / 81.4 / 73.75 %); Fig. 16's histograms.

``table4`` (Section 5.2): a continuous bend. After ``BEND_SETTLE_S`` at 1 bar in every muscle,
PMA2 (chamber 1 here) rises from 1 to 2.5 bar in 0.05 bar steps, one per second (30 s), the
others held at 1 bar (the paper names only PMA2's pressure; 1 bar for the others is our
reading: the bend starts from its 1 bar pose). Every ``BEND_SAMPLE_S`` (the paper's 105 points
in 30 s, synchronised to the camera) the encoders, the stereo pair and the simulator are read;
RSES (:func:`soft_gym.papers.zou2022.cc_shape.cc_shape_points`) and the DNN estimate the shape from the
same chamber lengths. Table 4 is the RMSE per axis of the end point ``Q_7`` ("we only exhibited
the trajectory of the end-actuator") against ASES (paper: RSES 10.9 / 6.5 / 6.6 mm, DNN 2.2 /
2.1 / 2.3 mm) and against the true tip; the same over all seven points is reported beside it.
The ratio RSES/DNN is that of the 3-D RMSEs (the root of the summed per-axis mean squares).
Figs. 18-19: the tip trajectories of the three methods and the truth, and the absolute error
curves per axis.

``faults`` (Section 4.4, Fig. 13): ASES on ``n_poses`` random settled poses of the grid, clean
and under each of ``FAULT_CONDITIONS`` (poor light, glare, a plate in front of the pair); per
condition the share of frames ASES reports lost and, on the others, the mean point error and tip
error against the truth (mm). Self-occlusion (Fig. 13b) is no fault here: it happens, when it
does, in the clean poses.

``control``: ``cc_model``, ``hybrid_gpr`` and ``lwpr_rwr`` tracking on zou2022 with each shape
source as feedback, nominal and with the stereo pair faulted
(:mod:`eval.papers.zou2022.control`). The paper has no closed-loop experiment; this is the
project's own comparison.

Where the simulation differs from the paper (docs/architecture.md, "zou2022 experiments"): the
simulated arm bends by pressure moments on a Cosserat-like chain, so the shape departs from
constant curvature only through gravity, the tip mass and the muscles' braid twist
(``SegmentSpec.braid_twist_m``; the paper: the arm "twists into complex 3D curves", "the
torsional effect is also ignored"), not hysteresis or cable friction; ASES's reference is a
320 x 180 render, whose depth resolution limits the labels.
"""

from __future__ import annotations

import copy
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from tqdm import tqdm

from eval.papers.zou2022.control import control_table, plot_control, run_control, strip_records
from eval.report import package_version, save_figure, write_json
from soft_gym.robots.presets import get_preset
from soft_gym.papers.zou2022.cc_shape import cc_shape_points
from soft_gym.papers.zou2022.dataset import cached_shape_dnn
from soft_gym.papers.zou2022.shape_dnn import (N_POINTS, STEREO_INTRINSICS, ShapeDNNConfig,
                                                axis_errors_mm, default_stereo,
                                                true_shape_points)
from soft_gym.papers.zou2022.stereo_shape import estimate_stereo_shape
from soft_gym.sensors.encoder import ChamberEncoders
from soft_gym.sensors.stereo import StereoCamera
from soft_gym.engines import make_simulator

EXPERIMENTS = ("table3", "table4", "faults", "control", "levers")
DEFAULT_EXPERIMENTS = ("table3", "table4", "faults", "control")
"""What ``python -m eval zou2022`` runs unless told: ``levers`` (Table 4 over the braid twist's
lever, :mod:`eval.papers.zou2022.levers`) trains a DNN per lever, so it runs when asked."""
PRESET = "zou2022"
BAR_PA = 1e5

TABLE3_PAPER = {"mae_mm": (1.7601, 1.8049, 2.0677), "rmse_mm": (2.5563, 2.5850, 2.6141),
                "mean_sample_rmse_mm": 2.302, "within_2_5_mm": (0.82, 0.814, 0.7375)}
"""zou2022 Table 3 and Section 5.1 (3): the DNN on its test set, against ASES."""
TABLE4_PAPER_RMSE_MM = {"RSES": (10.8861, 6.5395, 6.5560), "DNN": (2.2124, 2.1071, 2.2998)}
"""zou2022 Table 4: RMSE per axis (mm) of the end point over the bend, against ASES."""
TABLE4_PAPER_RATIO = (float(np.linalg.norm(TABLE4_PAPER_RMSE_MM["RSES"]))
                      / float(np.linalg.norm(TABLE4_PAPER_RMSE_MM["DNN"])))
"""RSES / DNN on Table 4, of the 3-D RMSEs (root of the summed per-axis mean squares): 3.74
(on the x axis alone 10.89 / 2.21 = 4.92)."""

BEND_CHAMBER = 1
"""PMA2 of the paper: chamber 1 here (chamber ``i`` at ``2 pi i / 3``)."""
BEND_HOLD_BAR = 1.0
BEND_FROM_BAR, BEND_TO_BAR, BEND_STEP_BAR = 1.0, 2.5, 0.05
BEND_STEP_S = 1.0
"""One 0.05 bar step per second: 30 steps in the paper's 30 s."""
BEND_SETTLE_S = 3.0
BEND_SAMPLE_S = 0.3
"""Sampling period (s): ~the paper's 105 points in 30 s; 101 samples here."""

_GREY = (0.45, 0.45, 0.5, 1.0)
_PLATE = {"name": "moving_occluder", "mode": "full", "start_s": 0.0, "cover_s": 1e4,
          "period_s": 1e4 + 1.0, "jitter_s": 0.0, "rgba": _GREY}
FAULT_CONDITIONS: dict[str, Any] = {
    "clean": None,
    "low light 0.5": {"name": "low_light", "strength": 0.5},
    "low light 0.7": {"name": "low_light", "strength": 0.7},
    "darkness": {"name": "low_light", "strength": 1.0},
    "LED glare 0.6": {"name": "led_glare", "strength": 0.6},
    "LED glare 1.0": {"name": "led_glare", "strength": 1.0},
    "plate over 60 %": {**_PLATE, "strength": 0.6},
    "plate over the pair": {**_PLATE, "strength": 1.0},
}
"""Fig. 13a's poor light and obstacles in front of the pair (:mod:`soft_gym.sensors.faults`;
a partial plate comes in from a side drawn per pose). The plate is grey: the default skin colour
lies inside ASES's orange threshold."""


# ---------------------------------------------------------------------------------- helpers
def _points_rmse(estimate_m: np.ndarray, reference_m: np.ndarray) -> np.ndarray:
    """Per-axis RMSE (mm) over the rows where both are finite."""
    difference = (np.asarray(estimate_m) - np.asarray(reference_m)) * 1e3
    flat = difference.reshape(-1, 3)
    flat = flat[np.isfinite(flat).all(axis=1)]
    return np.sqrt((flat ** 2).mean(axis=0)) if len(flat) else np.full(3, np.nan)


def _norm(rmse_axes_mm: np.ndarray) -> float:
    """3-D RMSE from per-axis RMSEs: the root of the summed mean squares."""
    return float(np.sqrt(np.sum(np.square(rmse_axes_mm))))


def _private_stereo(sim, seed: int, faults: Any = None) -> StereoCamera:
    camera = StereoCamera(intrinsics=dict(STEREO_INTRINSICS), faults=faults)
    camera.reset(sim, np.random.default_rng([seed, 7]))
    return camera


def _ases(camera: StereoCamera, sim):
    reading = camera.sample(sim)
    return estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                 reading["P_right"])


def shape_dnn(config: ShapeDNNConfig, progress: bool = True):
    """The zou2022 DNN for ``config`` (from the calibration cache where built before) and its
    training report; the encoders and stereo pair are the env's defaults."""
    return cached_shape_dnn(get_preset(PRESET), ChamberEncoders(), default_stereo(), config,
                            progress=progress)


# ---------------------------------------------------------------------------------- Table 3
def run_table3(dnn, report: dict) -> dict:
    """Table 3 and Fig. 16: the DNN on its test set against the ASES labels and the truth."""
    data = report["data"]
    test = data.test
    predicted = dnn.predict(data.lengths_m[test])
    result: dict[str, Any] = {"n_samples": len(data), "n_lost": data.n_lost,
                              "n_test": int(len(test)), "best_epoch": report["best_epoch"]}
    for reference, points in (("ases", data.labels_m[test]), ("truth", data.truth_m[test])):
        errors = axis_errors_mm(predicted, points)
        difference = (predicted - points) * 1e3
        per_sample = np.sqrt((difference ** 2).reshape(len(test), -1).mean(axis=1))
        result[reference] = {
            "mae_mm": errors["mae_mm"], "rmse_mm": errors["rmse_mm"],
            "mean_sample_rmse_mm": float(per_sample.mean()),
            "within_2_5_mm": (np.abs(difference.reshape(-1, 3)) <= 2.5).mean(axis=0),
            "_errors_mm": difference.reshape(-1, 3)}
    result["ases_vs_truth_rmse_mm"] = _points_rmse(data.labels_m[test], data.truth_m[test])
    result["test_share_with_a_training_command"] = shared_command_share(
        data.pressures_pa[data.train], data.pressures_pa[test])
    return result


def shared_command_share(train_pa: np.ndarray, test_pa: np.ndarray) -> float:
    """The share of the test samples whose exact command is also a training sample's (the
    leak that makes a test set optimistic); 0 for the data sets of
    :func:`soft_gym.papers.zou2022.dataset.collect_dataset`."""
    if len(test_pa) == 0:
        return 0.0
    seen = {tuple(row) for row in np.asarray(train_pa).tolist()}
    return float(np.mean([tuple(row) in seen for row in np.asarray(test_pa).tolist()]))


# ---------------------------------------------------------------------------------- Table 4
def bend_pressures_pa(time_s: float) -> np.ndarray:
    """Commanded pressures (Pa) ``time_s`` into the bend: PMA2 one 0.05 bar step per second."""
    steps = min(int(np.floor(time_s / BEND_STEP_S + 1e-9)),
                int(round((BEND_TO_BAR - BEND_FROM_BAR) / BEND_STEP_BAR)))
    pressures = np.full(3, BEND_HOLD_BAR)
    pressures[BEND_CHAMBER] = BEND_FROM_BAR + steps * BEND_STEP_BAR
    return pressures * BAR_PA


def run_table4(dnn, seed: int = 0, progress: bool = True, spec=None) -> dict:
    """Table 4 and Figs. 18-19: RSES and the DNN along the continuous bend, against ASES and the
    true shape.

    :param dnn: the shape DNN; ``None``: RSES only (the DNN's fields and ratios left out).
    :param seed: sensor noise.
    :param progress: a progress bar.
    :param spec: the arm (default: the zou2022 preset; :mod:`eval.papers.zou2022.levers` varies
        its braid twist).
    """
    spec = get_preset(PRESET) if spec is None else spec
    d_m = spec.segments[0].chamber_offset_m
    sim = make_simulator(spec)
    try:
        sim.reset(settle_s=0.5)  # then through the supply's lag: a step reset would jolt it
        sim.set_pressures(bend_pressures_pa(0.0))
        sim.step_physics(BEND_SETTLE_S)
        encoders = ChamberEncoders()
        encoders.reset(sim, np.random.default_rng([seed, 8]))
        camera = _private_stereo(sim, seed)
        duration_s = (BEND_TO_BAR - BEND_FROM_BAR) / BEND_STEP_BAR * BEND_STEP_S
        n_samples = int(round(duration_s / BEND_SAMPLE_S)) + 1
        series: dict[str, list] = {k: [] for k in ("time_s", "pressure_pa", "lengths_m", "rses",
                                                   "dnn", "ases", "truth")}
        lost = 0
        t0 = sim.time_s
        for k in tqdm(range(n_samples), desc="zou2022 bend", disable=not progress, leave=False):
            t = k * BEND_SAMPLE_S
            # advance to t in one-second pressure steps
            while sim.time_s - t0 < t - 1e-9:
                elapsed = sim.time_s - t0
                sim.set_pressures(bend_pressures_pa(elapsed))
                next_step = (np.floor(elapsed / BEND_STEP_S + 1e-9) + 1) * BEND_STEP_S
                sim.step_physics(min(t, next_step) - elapsed)
            sim.set_pressures(bend_pressures_pa(t))
            lengths = encoders.sample(sim)
            shape = _ases(camera, sim)
            lost += bool(shape.lost)
            series["time_s"].append(t)
            series["pressure_pa"].append(bend_pressures_pa(t))
            series["lengths_m"].append(lengths)
            series["rses"].append(cc_shape_points(lengths, d_m))
            series["dnn"].append(np.full((N_POINTS, 3), np.nan) if dnn is None
                                 else dnn.predict(lengths))
            series["ases"].append(shape.points_m)
            series["truth"].append(true_shape_points(spec, sim.backbone()))
    finally:
        sim.close()
    arrays = {k: np.asarray(v, dtype=float) for k, v in series.items()}
    result: dict[str, Any] = {"n_samples": n_samples, "ases_lost": lost,
                              "_series": arrays}
    methods = ("rses",) if dnn is None else ("rses", "dnn")
    for method in methods:
        for reference in ("ases", "truth"):
            tip = _points_rmse(arrays[method][:, -1], arrays[reference][:, -1])
            every = _points_rmse(arrays[method], arrays[reference])
            result[f"{method}_vs_{reference}"] = {"tip_rmse_mm": tip, "points_rmse_mm": every}
    result["ases_vs_truth"] = {"tip_rmse_mm": _points_rmse(arrays["ases"][:, -1],
                                                           arrays["truth"][:, -1]),
                               "points_rmse_mm": _points_rmse(arrays["ases"], arrays["truth"])}
    for reference in ("ases", "truth") if dnn is not None else ():
        for which in ("tip", "points"):
            rses = _norm(result[f"rses_vs_{reference}"][f"{which}_rmse_mm"])
            dnn_error = _norm(result[f"dnn_vs_{reference}"][f"{which}_rmse_mm"])
            result[f"ratio_{which}_vs_{reference}"] = rses / dnn_error
    return result


# ---------------------------------------------------------------------------------- faults
def run_faults(n_poses: int = 20, seed: int = 0, progress: bool = True,
               conditions: dict[str, Any] | None = None) -> dict:
    """ASES against the truth on ``n_poses`` random settled poses, clean and under each visual
    fault: lost share, mean point error and tip error (mm) of the frames not lost."""
    conditions = FAULT_CONDITIONS if conditions is None else conditions
    spec = get_preset(PRESET)
    rng = np.random.default_rng([seed, 9])
    step_pa = 1e4  # the data set's 0.1 bar grid
    levels = np.floor((spec.p_max_pa - spec.p_pre_pa) / step_pa + 1e-9).astype(int) + 1
    sim = make_simulator(spec)
    errors: dict[str, list] = {name: [] for name in conditions}
    try:
        sim.reset(settle_s=1.0)
        cameras = {name: _private_stereo(sim, seed, copy.deepcopy(faults))
                   for name, faults in conditions.items()}
        for _ in tqdm(range(n_poses), desc="zou2022 ASES poses", disable=not progress,
                      leave=False):
            sim.set_pressures(spec.p_pre_pa + step_pa * rng.integers(0, levels))
            sim.step_physics(2.0)
            truth = true_shape_points(spec, sim.backbone())
            for name, camera in cameras.items():
                shape = _ases(camera, sim)
                errors[name].append(None if shape.lost
                                    else np.linalg.norm(shape.points_m - truth, axis=1) * 1e3)
    finally:
        sim.close()
    result = {}
    for name, rows in errors.items():
        good = np.array([row for row in rows if row is not None])
        result[name] = {"lost_share": float(np.mean([row is None for row in rows])),
                        "mean_point_error_mm": float(good.mean()) if len(good) else None,
                        "tip_error_mm": float(good[:, -1].mean()) if len(good) else None,
                        "max_point_error_mm": float(good.max()) if len(good) else None}
    return result


# ---------------------------------------------------------------------------------- report
def _axes(values, digits: int = 2) -> str:
    return " / ".join(f"{v:.{digits}f}" for v in values)


def report_tables(results: dict) -> str:
    """Markdown tables of every experiment run."""
    lines: list[str] = []
    t3 = results.get("table3")
    if t3:
        shared = t3.get("test_share_with_a_training_command", 0.0)
        lines += [f"Table 3: the DNN on its test set ({t3['n_test']} of {t3['n_samples']} samples, "
                  f"{t3['n_lost']} lost by ASES and replaced by rotated copies; "
                  f"{100 * shared:.1f} % of the test samples share a training command; best "
                  f"epoch {t3['best_epoch']}), x / y / z (mm)", "",
                  "| reference | MAE | RMSE | mean per-sample RMSE | within +-2.5 mm (%) |",
                  "|---|---|---|---|---|"]
        for reference, label in (("ases", "ASES labels"), ("truth", "true points")):
            row = t3[reference]
            lines.append(f"| {label} | {_axes(row['mae_mm'])} | {_axes(row['rmse_mm'])} | "
                         f"{row['mean_sample_rmse_mm']:.2f} | "
                         f"{_axes(100 * np.asarray(row['within_2_5_mm']), 1)} |")
        paper = TABLE3_PAPER
        lines += [f"| paper (ASES) | {_axes(paper['mae_mm'])} | {_axes(paper['rmse_mm'])} | "
                  f"{paper['mean_sample_rmse_mm']:.2f} | "
                  f"{_axes(100 * np.asarray(paper['within_2_5_mm']), 1)} |", "",
                  f"ASES labels against the true points on the test set, RMSE: "
                  f"{_axes(t3['ases_vs_truth_rmse_mm'])} mm"]
    t4 = results.get("table4")
    if t4:
        lines += ["", f"Table 4: continuous bend, PMA2 1 -> 2.5 bar in 30 s, {t4['n_samples']} "
                      f"samples (ASES lost on {t4['ases_lost']}); RMSE x / y / z (mm)", "",
                  "| method | end point vs ASES | end point vs truth | 7 points vs ASES | "
                  "7 points vs truth | paper, end point vs ASES |", "|---|---|---|---|---|---|"]
        for method, label in (("rses", "RSES"), ("dnn", "DNN")):
            a, t = t4[f"{method}_vs_ases"], t4[f"{method}_vs_truth"]
            lines.append(f"| {label} | {_axes(a['tip_rmse_mm'])} | {_axes(t['tip_rmse_mm'])} | "
                         f"{_axes(a['points_rmse_mm'])} | {_axes(t['points_rmse_mm'])} | "
                         f"{_axes(TABLE4_PAPER_RMSE_MM[label])} |")
        ases = t4["ases_vs_truth"]
        lines += [f"| ASES | | {_axes(ases['tip_rmse_mm'])} | | {_axes(ases['points_rmse_mm'])} "
                  "| |", "",
                  f"RSES/DNN 3-D RMSE ratio: end point {t4['ratio_tip_vs_ases']:.2f} vs ASES, "
                  f"{t4['ratio_tip_vs_truth']:.2f} vs truth; 7 points "
                  f"{t4['ratio_points_vs_ases']:.2f} vs ASES, {t4['ratio_points_vs_truth']:.2f} "
                  f"vs truth (paper, end point vs ASES: {TABLE4_PAPER_RATIO:.2f})"]
    faults = results.get("faults")
    if faults:
        lines += ["", "ASES against the truth under visual faults (random settled poses)", "",
                  "| condition | lost | mean point error (mm) | tip error (mm) | "
                  "largest point error (mm) |", "|---|---|---|---|---|"]
        for name, row in faults.items():
            cells = [("" if row[k] is None else f"{row[k]:.1f}")
                     for k in ("mean_point_error_mm", "tip_error_mm", "max_point_error_mm")]
            lines.append(f"| {name} | {100 * row['lost_share']:.0f} % | " + " | ".join(cells)
                         + " |")
    if results.get("control"):
        lines += ["", "Control on zou2022 with each shape source", "",
                  control_table(results["control"]["rows"])]
    return "\n".join(lines)


def plot_table3(path: str | Path, table3: dict) -> Path:
    """Fig. 16: histograms of the DNN's test-set errors per axis, against ASES and the truth."""
    fig = Figure(figsize=(13, 3.8))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 3)
    bins = np.linspace(-10, 10, 41)
    for i, axis in enumerate("xyz"):
        for reference, colour in (("ases", "tab:blue"), ("truth", "tab:orange")):
            errors = table3[reference]["_errors_mm"][:, i]
            axes[i].hist(np.clip(errors, -10, 10), bins=bins, alpha=0.55, color=colour,
                         label=f"against {'ASES' if reference == 'ases' else 'truth'}")
        axes[i].set(xlabel=f"DNN error in {axis} (mm)", ylabel="count", title=f"{axis} axis")
    axes[0].legend(fontsize=8)
    return save_figure(fig, path)


def plot_table4(path: str | Path, table4: dict) -> Path:
    """Figs. 18d-e and 19: end-point trajectories, chamber lengths, and absolute errors per axis
    against ASES."""
    series = table4["_series"]
    time = series["time_s"]
    fig = Figure(figsize=(15, 8))
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 3)
    trajectory = fig.add_subplot(grid[0, 0], projection="3d")
    styles = {"truth": ("k", "-"), "ases": ("tab:green", ":"), "rses": ("tab:red", "--"),
              "dnn": ("tab:blue", "-")}
    for key, (colour, style) in styles.items():
        tip = series[key][:, -1] * 1e3
        trajectory.plot(tip[:, 0], tip[:, 1], tip[:, 2], color=colour, linestyle=style,
                        label={"truth": "truth", "ases": "ASES", "rses": "RSES",
                               "dnn": "DNN"}[key])
    trajectory.set(xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)",
                   title="end point trajectory (Fig. 18d)")
    trajectory.legend(fontsize=7)
    lengths = fig.add_subplot(grid[0, 1])
    lengths.plot(time, series["lengths_m"] * 1e3)
    lengths.set(xlabel="time (s)", ylabel="chamber length (mm)", title="q_1 (Fig. 18e)")
    lengths.legend(["l_1", "l_2", "l_3"], fontsize=7)
    shapes = fig.add_subplot(grid[0, 2])
    for k in np.linspace(0, len(time) - 1, 5).astype(int):
        for key, (colour, style) in styles.items():
            points = series[key][k] * 1e3
            shapes.plot(points[:, 0], points[:, 2], color=colour, linestyle=style, marker=".")
    shapes.set(xlabel="x (mm)", ylabel="z (mm)", title="shapes at five times (side view)")
    shapes.invert_yaxis()
    for i, axis in enumerate("xyz"):
        ax = fig.add_subplot(grid[1, i])
        for key in ("rses", "dnn"):
            error = np.abs(series[key][:, -1, i] - series["ases"][:, -1, i]) * 1e3
            ax.plot(time, error, color=styles[key][0], label=key.upper())
        ax.set(xlabel="time (s)", ylabel=f"|error| in {axis} (mm)",
               title=f"end point against ASES, {axis} (Fig. 19)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def run_and_report(experiments: list[str], seeds: list[int], out: str | Path,
                   config: ShapeDNNConfig | None = None, n_poses: int = 20,
                   control_options: dict | None = None, progress: bool = True) -> dict:
    """Run the experiments for every seed; write ``zou2022_seed<N>.md`` and the figures under
    ``out``, and ``zou2022.json``; print the tables. ``levers`` is
    :func:`eval.papers.zou2022.levers.run_and_report`'s (the others are left to it)."""
    unknown = sorted(set(experiments) - set(EXPERIMENTS))
    if unknown:
        raise ValueError(f"experiments must be among {list(EXPERIMENTS)}, got {unknown}")
    experiments = [name for name in experiments if name != "levers"]
    if not experiments:
        return {}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    base = config or ShapeDNNConfig()
    summary: dict[str, Any] = {}
    for seed in seeds:
        seeded = ShapeDNNConfig(**{**asdict(base), "seed": seed})
        results: dict[str, Any] = {}
        if {"table3", "table4"} & set(experiments):
            dnn, report = shape_dnn(seeded, progress)
            if "table3" in experiments:
                results["table3"] = run_table3(dnn, report)
                plot_table3(out / f"zou2022_table3_seed{seed}.png", results["table3"])
            if "table4" in experiments:
                results["table4"] = run_table4(dnn, seed, progress)
                plot_table4(out / f"zou2022_bend_seed{seed}.png", results["table4"])
        if "faults" in experiments:
            results["faults"] = run_faults(n_poses, seed, progress)
        if "control" in experiments:
            dnn_options = {k: v for k, v in asdict(seeded).items()
                           if v != getattr(ShapeDNNConfig(), k) or k == "seed"}
            rows = run_control(seed, dnn_options, progress=progress, **(control_options or {}))
            results["control"] = {"rows": strip_records(rows)}
            plot_control(out / f"zou2022_control_seed{seed}.png", rows)
        table = report_tables(results)
        print(f"\nzou2022, seed {seed}\n{table}")
        (out / f"zou2022_seed{seed}.md").write_text(table + "\n")
        summary[f"seed{seed}"] = _jsonable(results)
    write_json(out / "zou2022.json", {"soft_arm_gym_version": package_version(),
                                      "dnn_config": _jsonable(asdict(base)),
                                      "results": summary})
    return summary


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items() if not str(k).startswith("_")}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value
