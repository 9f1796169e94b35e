"""Learning curves of a run directory: training episodes (monitor CSVs) and evaluations."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np


def training_episodes(run_dir: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Timesteps at episode end, episode return and episode length from ``monitor/*.csv``.

    Episodes of all envs are merged in order of wall time; the timestep is the running total of
    episode lengths.
    """
    rows = []
    for path in sorted(Path(run_dir, "monitor").glob("*.monitor.csv")):
        with open(path) as handle:
            handle.readline()  # the JSON header line
            for row in csv.DictReader(handle):
                rows.append((float(row["t"]), float(row["r"]), int(row["l"])))
    if not rows:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int)
    rows.sort()
    _, returns, lengths = (np.array(column) for column in zip(*rows))
    return np.cumsum(lengths), returns, lengths


def evaluations(run_dir: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Timesteps, mean and std of the evaluation returns (``eval/evaluations.npz``)."""
    path = Path(run_dir, "eval", "evaluations.npz")
    if not path.exists():
        return np.zeros(0), np.zeros(0), np.zeros(0)
    data = np.load(path)
    results = np.asarray(data["results"], dtype=float)
    return np.asarray(data["timesteps"]), results.mean(axis=1), results.std(axis=1)


def plot_learning_curve(run_dir: str | Path, title: str = "") -> Path:
    """Write ``learning_curve.png``: mean reward per step (-mean tip error in mm for tracking,
    up to the small action-rate term) of training episodes and of evaluations."""
    # lazy: pyplot costs 0.33 s (-X importtime) that reading the curves skips; Agg is set first
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps, returns, lengths = training_episodes(run_dir)
    eval_steps, eval_mean, eval_std = evaluations(run_dir)
    eval_length = _eval_length(run_dir)
    fig, ax = plt.subplots(figsize=(6.4, 3.6), constrained_layout=True)
    if len(steps):
        per_step_mm = 1000.0 * returns / lengths
        ax.plot(steps, per_step_mm, ".", ms=3, alpha=0.35, color="tab:blue", label="training episodes")
        window = max(1, len(per_step_mm) // 20)
        smooth = np.convolve(per_step_mm, np.ones(window) / window, mode="valid")
        ax.plot(steps[window - 1:], smooth, color="tab:blue", label=f"training (mean of {window})")
    if len(eval_steps) and eval_length:
        ax.errorbar(eval_steps, 1000.0 * eval_mean / eval_length,
                    yerr=1000.0 * eval_std / eval_length, color="tab:red", marker="o", ms=3,
                    capsize=2, label="evaluation (deterministic)")
    ax.set_xlabel("env steps")
    ax.set_ylabel("reward per step x 1000 (~ -tip error, mm)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize=8)
    out = Path(run_dir, "learning_curve.png")
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def _eval_length(run_dir: str | Path) -> float:
    path = Path(run_dir, "eval", "evaluations.npz")
    if not path.exists():
        return 0.0
    data = np.load(path)
    return float(np.mean(data["ep_lengths"])) if "ep_lengths" in data else 0.0


def plot_tracking_curve(run_dir: str | Path, title: str = "") -> Path:
    """Write ``tracking_curve.png``: the mean last-cycle tracking error (mm) of every evaluation
    in ``eval/tracking_curve.csv`` (:mod:`train.tracking_curve`) against env steps, each case
    faint behind it, the best so far marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(run_dir, "eval", "tracking_curve.csv")
    with open(path) as handle:
        rows = list(csv.DictReader(handle))
    steps = np.array([int(row["timesteps"]) for row in rows])
    fig, ax = plt.subplots(figsize=(6.4, 3.6), constrained_layout=True)
    for name in [key for key in rows[0] if key.endswith("(mm)")]:
        ax.plot(steps, [float(row[name]) for row in rows], lw=0.8, alpha=0.4,
                label=name.replace(" (mm)", ""))
    mean = np.array([float(row["mean_last_cycle_mm"]) for row in rows])
    ax.plot(steps, mean, "o-", color="black", ms=3, label="mean of the cases")
    ax.plot(steps, np.minimum.accumulate(mean), "--", color="tab:red", lw=1,
            label="best so far")
    ax.set_xlabel("env steps")
    ax.set_ylabel("last-cycle tracking error (mm)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    out = Path(run_dir, "tracking_curve.png")
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
