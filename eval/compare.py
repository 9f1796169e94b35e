"""RL agents against the baselines on the wang2023 paths, nominal and out of distribution.

Every policy (baseline names or ``sb3:PATH``/shipped agent names) runs every path under every
condition for every seed, with the same feedback source. The conditions:

* ``nominal``: no load, no visual fault;
* ``heavy_load``: a 40 g tip mass, 1.7 times the heaviest load of the shipped agents' training
  randomisation (a 14 g container filled with up to 10 g; its static tip masses reach 10 g,
  ``soft_gym.scenarios.randomization``): out of the training distribution;
* ``occlusion``: a hand covering the whole camera view for 2 s out of every 6 s from 5 s on
  (wang2023 Fig. 6 ④), never seen in training (the agents trained with EM feedback).

Outputs: ``compare.md`` (seed mean +- std of the tracking error over all cycles and over the last
cycle, path deviation, max, and the improvement over ``cc_model``), ``compare.csv`` /
``compare.json`` (every run, with the soft-arm-gym version), ``compare_<path>.png`` (bars per
condition), and error-against-time plots of the first seed. With ``video=True`` every run also
writes ``runs/<policy>_<path>_<condition>_seed<seed>.mp4`` next to its CSV (:mod:`eval.video`).
"""

from __future__ import annotations

import csv
import itertools
from pathlib import Path
from typing import Any, Sequence

import matplotlib
import numpy as np

from eval import runner  # runner.run_many, looked up at each call (tests stand in for it)
from eval.metrics import add_improvement, aggregate_seeds, summarize, summary_table
from eval.palette import policy_color, policy_label
from eval.report import (error_peaks_mm, markdown_table, plot_error_time, with_mean_std,
                         write_records_csv, write_results_json)
from eval.runner import RunConfig, check_configs
from soft_gym.papers import DEFAULT_PRESET

CONDITIONS: dict[str, dict[str, Any]] = {
    "nominal": {},
    "heavy_load": {"scenario": {"name": "tip_mass", "mass_kg": 0.04}},
    "occlusion": {"faults": {"name": "moving_occluder", "mode": "full", "start_s": 5.0,
                             "cover_s": 2.0, "period_s": 6.0}},
}
"""Condition name -> env keyword arguments."""


def run_comparison(policies: Sequence[str], paths: Sequence[str], conditions: Sequence[str],
                   seeds: Sequence[int], out: str | Path, cycles: int = 2,
                   feedback: str = "fused", kp: float = 0.06, preset: str = DEFAULT_PRESET,
                   progress: bool = True, workers: int = 1,
                   video: bool = False, check: bool = True) -> list[dict[str, Any]]:
    """Run the comparison grid and write its outputs; returns the seed-aggregated rows
    (``video``: a video of every run beside its CSV).

    With ``check`` every run's configuration is checked before the first run starts
    (:func:`eval.runner.check_configs`: an unknown path or feedback source, a policy that
    cannot drive the arm, an agent of another observation or action space); each run's CSV is
    written as soon as it finishes, so a run failing later keeps the finished ones.

    Raises:
        eval.runner.ConfigError: (with ``check``) a configuration refused, before any run.
        ValueError: unknown conditions, ``cycles`` < 1.
    """
    unknown = [c for c in conditions if c not in CONDITIONS]
    if unknown:
        raise ValueError(f"conditions must be among {sorted(CONDITIONS)}, got {unknown}")
    if cycles < 1:
        raise ValueError(f"cycles must be >= 1, got {cycles!r}")
    out = Path(out)
    rows, first_seed_records = [], {}
    grid = list(itertools.product(paths, conditions, seeds, policies))
    configs = [RunConfig(
        policy=policy, policy_params={} if policy.startswith("sb3:") else {"kp": kp}, seed=seed,
        env_kwargs={"preset": preset, "path": path, "cycles": cycles, "feedback": feedback,
                    **CONDITIONS[condition]}, labels={"condition": condition},
        video_path=str(out / "runs" / f"{_run_name(policy, path, condition, seed)}.mp4")
        if video else None) for path, condition, seed, policy in grid]
    if check:
        check_configs(configs)
    out.mkdir(parents=True, exist_ok=True)

    def keep(index: int, record: dict) -> None:  # on disk as soon as the run finishes
        path, condition, seed, policy = grid[index]
        write_records_csv(out / "runs" / f"{_run_name(policy, path, condition, seed)}.csv",
                          record)

    print(f"{len(configs)} runs on {workers} worker(s)", flush=True)
    records = runner.run_many(configs, workers=workers, progress=progress, on_result=keep)
    for (path, condition, seed, policy), record in zip(grid, records):
        label = policy_label(policy)
        summary = summarize(record)
        identity = {"policy": label, "path": path, "condition": condition, "seed": seed}
        rows.append((identity, summary))
        if seed == seeds[0]:
            first_seed_records.setdefault((path, condition), {})[label] = record
    table = summary_table(rows)
    last = f"track_mean_mm_cycle{cycles}"
    for row in table:
        row["track_last_cycle_mm"] = row.get(last, np.nan)
    table = add_improvement(table, baseline={"policy": "cc_model"},
                            match=["path", "condition", "seed"])
    write_results_json(out / "compare.json", table)
    _write_csv(out / "compare.csv", table)
    aggregated = aggregate_seeds(table, by=["policy", "path", "condition"])
    # one y-scale for every error plot (one arm), so the conditions compare by eye
    peaks = error_peaks_mm([record for records in first_seed_records.values()
                            for record in records.values()])
    for (path, condition), records in first_seed_records.items():
        plot_error_time(out / f"error_{path}_{condition}.png", records,
                        f"{preset} {path}, {condition}, {feedback} feedback (seed {seeds[0]})",
                        ymax_mm=peaks)
    for path in paths:
        _plot_bars(out / f"compare_{path}.png",
                   [row for row in aggregated if row["path"] == path], conditions,
                   f"{preset} {path}: tracking error, last cycle ({feedback} feedback)")
    for metric in ("track_mean_mm", "track_last_cycle_mm", "dev_mean_mm"):
        aggregated = with_mean_std(aggregated, metric, f"{metric}_seed_std", float_format="{:.2f}")
    shown = [{
        "policy": row["policy"], "path": row["path"], "condition": row["condition"],
        "seeds": row["n_seeds"],
        "track (mm)": row["track_mean_mm_pm"],
        "last cycle (mm)": row["track_last_cycle_mm_pm"],
        "deviation (mm)": row["dev_mean_mm_pm"],
        "max (mm)": row["track_max_mm"],
        "vs cc_model (%)": row["improvement_%"],
    } for row in aggregated]
    text = markdown_table(shown, float_format="{:.2f}")
    (out / "compare.md").write_text(
        f"# {preset}: agents against baselines ({feedback} feedback, {cycles} cycles, "
        f"seeds {list(seeds)})\n\n" + text)
    return shown


def _run_name(policy: str, path: str, condition: str, seed: int) -> str:
    """File stem of one run's CSV (and video)."""
    return f"{policy_label(policy)}_{path}_{condition}_seed{seed}"


def _write_csv(path: Path, rows: list[dict]) -> None:
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def _plot_bars(path: Path, rows: list[dict], conditions: Sequence[str], title: str) -> None:
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # here: +0.4 s for every python -m eval command

    policies = list(dict.fromkeys(row["policy"] for row in rows))
    width = 0.8 / max(len(policies), 1)
    fig, ax = plt.subplots(figsize=(7.0, 3.6), constrained_layout=True)
    x = np.arange(len(conditions))
    for k, policy in enumerate(policies):
        by_condition = {row["condition"]: row for row in rows if row["policy"] == policy}
        means = [by_condition.get(c, {}).get("track_last_cycle_mm", np.nan) for c in conditions]
        stds = [by_condition.get(c, {}).get("track_last_cycle_mm_seed_std", np.nan)
                for c in conditions]
        stds = [0.0 if not np.isfinite(s) else s for s in stds]
        ax.bar(x + (k - (len(policies) - 1) / 2) * width, means, width, yerr=stds, capsize=3,
               label=policy, color=policy_color(policy))
    ax.set_xticks(x, conditions)
    ax.set_ylabel("tracking error, last cycle (mm)")
    ax.set_title(title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
