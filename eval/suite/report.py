"""Report of a benchmark suite (:mod:`eval.suite`) from its records.

Score
-----
A run's score is its **last-cycle tracking error** ``e`` (mm): the mean, over the last path
cycle, of the distance from the target presented at each step to the ground-truth tip after it
(:func:`eval.metrics.tracking_error_mm`); the settled tracking after the first cycle's start-up
and online learning. **Lower is better**; no normalisation, so scores compare only within one
arm (the arms differ in size and the policies that can drive them): every aggregate is per arm.

Outputs (under the suite's output directory)
--------------------------------------------
* ``leaderboard.md``: per arm, the aggregate table (below), then one leaderboard per condition:
  the policies ranked by the mean of ``e`` over their runs (seeds, and paths when the arm has
  several, each path's mean in its own column), with the mean, max and path deviation (mean
  distance from the tip to the path, mm); ``n/a`` rows give the policy's refusal, and runs not
  made yet are counted in the note. Each trained agent (``sb3:`` policies) carries its training
  budget (steps, wall time, engine and envs, feedback, whether its tracking curve reached a
  plateau: :func:`agents.policies.sb3.training_budget`), and each arm a table of its best agent
  against its best baseline per condition (nominal, load, visual fault) with the verdict
  whether an agent beats every baseline under a load or a visual fault. An agent judged on a
  feedback source it was not trained on (its run's ``config.yaml``:
  :func:`agents.policies.sb3.training_feedbacks`) is marked plainly: a "Feedback mismatch"
  paragraph under its arm's heading, ``FEEDBACK MISMATCH: judged on X, trained on Y`` in its
  rows' note and "(feedback mismatch)" beside it in the best-agent table
  (:func:`feedback_mismatches`; also ``feedback_mismatches`` in ``suite.json``).
* ``runs.csv``: one row per cell: labels, status, metrics (mm), wall time (s), reason.
* ``suite.json``: provenance (suite name, file, its text and SHA-256, seeds, cycles, the
  versions and git revisions of the records, the report's bootstrap settings), counts, the
  leaderboards, the aggregates and the performance profiles.
* ``aggregate_iqm.png``: per arm and policy, the IQM of ``e`` with its 95 % CI and the mean
  (with one seed there is no interval: the plot and tables say "1 seed: no interval").
* ``performance_profiles.png``: per arm, the fraction of runs with ``e <= tau`` over a grid of
  ``tau``, the error threshold (mm), with 95 % CI bands; only for the policies with at least
  :data:`PROFILE_MIN_RUNS` scores (runs x tasks) on the arm: the panel and the leaderboard name
  the others and say why (``profiles_left_out`` in ``suite.json``).
* ``plots/error_<arm>_<path>_<condition>.png``: tracking error and path deviation against time
  of every policy, first seed, on one y-scale per arm;
  ``plots/trajectory_<arm>_<path>_<condition>.png``: their tips over
  the path in the x-y plane (mm).

Aggregates (per arm)
--------------------
A policy's scores on an arm form a matrix ``(runs = seeds) x (tasks = path x condition)``; only
policies with a finite score in every cell of the arm enter (the others are listed with the
reason). With ``rliable`` (Agarwal et al. 2021): the interquartile mean (IQM: the mean of the
middle 50 % of all ``runs x tasks`` scores, ``scipy.stats.trim_mean(.., 0.25)``), the mean of
the task means and the median of the task means, each with a 95 % percentile confidence
interval from the stratified bootstrap (runs resampled with replacement within each task,
``reps`` resamples); performance profiles ``P(e <= tau)`` over all runs and tasks, their CIs
from the same bootstrap. With one seed every resample is the data and the CIs collapse to the
point, so the tables and the plot say "1 seed: no interval" instead. Every plot draws a policy in
its own colour, keyed by its name (:mod:`eval.palette`). The bootstrap draws from numpy's
global generator (as ``rliable`` does), seeded with
``seed`` and restored afterwards, so a report is reproducible.

``rliable`` is needed for the report (``pip install rliable``); without it :func:`write_report`
raises an ``ImportError`` saying so.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import re
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from agents.policies.sb3 import training_budget, training_feedbacks
from eval.metrics import MM_PER_M
from eval.palette import policy_colors
from eval.report import (error_peaks_mm, markdown_table, package_version, plot_error_time,
                         save_figure, write_json)
from eval.suite.grid import Cell, expand
from eval.suite.spec import SuiteSpec
from eval.suite.store import (RecordError, git_revision, library_versions, read_record,
                              read_steps)
from soft_gym._progress import heartbeat
from soft_gym.envs.config import EnvConfig

SCORE = "last_cycle_error_mm"
"""The metric of a run that the leaderboard ranks and the aggregates summarise (mm)."""

DEFAULT_REPS = 10_000
"""Bootstrap resamples of the aggregate CIs."""

PROFILE_REPS = 2_000
"""Bootstrap resamples of the performance-profile CIs."""

PROFILE_POINTS = 101
"""Thresholds ``tau`` of a performance profile: ``linspace(0, 1.05 max e, PROFILE_POINTS)``."""

PROFILE_MIN_RUNS = 10
"""The fewest scores (runs x tasks) of a policy on an arm for its performance profile to be drawn:
with fewer the profile is a staircase of a few steps (two runs: 0, 1/2, 1) and its bootstrap band
says nothing, so the policy is left out of the plot and the report says why."""

PROFILE_AXIS = "tau: error threshold (mm)"
"""The x axis of a performance profile, in words: a run counts at ``tau`` when its last-cycle
error is at most ``tau`` millimetres."""

_CSV_METRICS = ("last_cycle_error_mm", "mean_error_mm", "max_error_mm", "final_error_mm",
                "path_deviation_mm", "last_cycle_path_deviation_mm", "feedback_error_mm",
                "n_steps")
_REASON_CHARS = 160


def require_rliable():
    """``(rliable.library, rliable.metrics)``, or an ``ImportError`` saying how to install it."""
    try:
        from rliable import library, metrics  # here: +1.2 s for every python -m eval command
    except ImportError as error:
        raise ImportError("the suite report needs the rliable package (aggregate IQM, "
                          "stratified-bootstrap CIs, performance profiles): pip install "
                          f"rliable ({error})") from None
    return library, metrics


@contextlib.contextmanager
def _global_seed(seed: int) -> Iterator[None]:
    """Seed numpy's global generator (rliable's bootstrap draws from it), then restore it."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)


# ------------------------------------------------------------------------------ the rows
def collect_rows(cells: Sequence[Cell], out: str | os.PathLike) -> list[dict[str, Any]]:
    """One flat row per cell: labels, ``key``, ``status`` (``done``, ``n/a``, ``missing`` or
    ``bad``: a record that fails verification, :func:`eval.suite.store.read_record`, whose
    ``reason`` names its path and problem), ``reason``, the metrics (mm) and ``wall_s``; plus
    the record's versions and git revision."""
    rows = []
    for cell in cells:
        row: dict[str, Any] = {"key": cell.key, **cell.labels}
        try:
            record, problem = read_record(out, cell.key), None
        except RecordError as error:
            record, problem = None, str(error)
        if record is None:
            row.update(status="missing" if problem is None else "bad", reason=problem,
                       wall_s=None)
            row.update({name: math.nan for name in _CSV_METRICS})
        else:
            metrics = record.get("metrics") or {}
            row.update(status=record["status"], reason=record.get("reason"),
                       wall_s=record.get("wall_s"))
            row.update({name: _number(metrics.get(name)) for name in _CSV_METRICS})
            row["versions"] = record.get("versions")
            row["git_revision"] = record.get("git_revision")
        rows.append(row)
    return rows


def _number(value: Any) -> float:
    """A metric as a float; NaN for anything but a number (a verified record's optional
    metrics may be null)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return math.nan
    return float(value)


def _mean(values: Sequence[float]) -> float:
    array = np.asarray(values, dtype=float)
    return float(np.mean(array)) if array.size else math.nan


def _std(values: Sequence[float]) -> float:
    array = np.asarray(values, dtype=float)
    return float(np.std(array, ddof=1)) if array.size > 1 else math.nan


def leaderboards(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str], list[dict]]:
    """``(arm, condition)`` -> the policies ranked by the mean last-cycle error of their runs.

    Each entry: ``rank`` (None for a policy without a finished run), ``policy``, ``runs``
    (finished), ``of`` (cells), ``last_cycle_error_mm`` (mean over runs), its sample std
    ``last_cycle_error_std_mm``, ``mean_error_mm``, ``max_error_mm`` (the largest),
    ``path_deviation_mm``, ``per_path`` (path -> mean last-cycle error), ``status`` (``done``,
    ``n/a`` or ``missing``) and ``note`` (a refusal's reason, missing runs).
    """
    groups: dict[tuple[str, str], dict[str, list[Mapping[str, Any]]]] = {}
    for row in rows:
        groups.setdefault((row["preset"], row["condition"]), {}).setdefault(
            row["policy"], []).append(row)
    boards = {}
    for group, by_policy in groups.items():
        entries = []
        for policy, runs in by_policy.items():
            done = [r for r in runs if r["status"] == "done"]
            refused = [r for r in runs if r["status"] == "n/a"]
            missing = [r for r in runs if r["status"] == "missing"]
            bad = [r for r in runs if r["status"] == "bad"]
            notes = []
            if refused:
                reason = str(refused[0]["reason"] or "")
                short = reason if len(reason) <= _REASON_CHARS else \
                    reason[:_REASON_CHARS - 1].rstrip() + "…"
                prefix = "" if len(refused) == len(runs) else f"{len(refused)} run(s) n/a: "
                notes.append(prefix + short)
            if missing:
                notes.append(f"{len(missing)} of {len(runs)} run(s) not made yet")
            if bad:
                notes.append(f"{len(bad)} of {len(runs)} record(s) bad (not trusted; redo "
                             f"with --resume)")
            paths = list(dict.fromkeys(r["path"] for r in runs))
            entry = {
                "policy": policy, "runs": len(done), "of": len(runs),
                "last_cycle_error_mm": _mean([r[SCORE] for r in done]),
                "last_cycle_error_std_mm": _std([r[SCORE] for r in done]),
                "mean_error_mm": _mean([r["mean_error_mm"] for r in done]),
                "max_error_mm": float(np.max([r["max_error_mm"] for r in done]))
                if done else math.nan,
                "path_deviation_mm": _mean([r["path_deviation_mm"] for r in done]),
                "per_path": {path: _mean([r[SCORE] for r in done if r["path"] == path])
                             for path in paths},
                "status": "done" if done else ("n/a" if refused else
                                               "bad" if bad else "missing"),
                "note": "; ".join(notes),
            }
            entries.append(entry)
        ranked = sorted([e for e in entries if e["runs"]],
                        key=lambda e: (not math.isfinite(e["last_cycle_error_mm"]),
                                       e["last_cycle_error_mm"]))
        for rank, entry in enumerate(ranked, start=1):
            entry["rank"] = rank
        rest = [dict(e, rank=None) for e in entries if not e["runs"]]
        boards[group] = ranked + rest
    return boards


# ---------------------------------------------------------------------------- agents vs baselines
def agent_budgets(spec: SuiteSpec) -> dict[str, dict[str, dict[str, Any] | None]]:
    """Per arm, each trained agent's table label -> its training budget
    (:func:`agents.policies.sb3.training_budget`; ``None`` where it has no readable record).
    Every policy of an arm not listed is a baseline."""
    budgets: dict[str, dict[str, dict[str, Any] | None]] = {}
    for arm in spec.arms:
        arm_budgets = budgets.setdefault(arm.preset, {})
        for policy in arm.policies:
            if policy.is_agent:
                try:
                    arm_budgets[policy.label] = training_budget(policy.name[len("sb3:"):])
                except ValueError:
                    arm_budgets[policy.label] = None
    return budgets


ENV_DEFAULT_FEEDBACK: str = EnvConfig.feedback
"""The feedback source of an env that sets none (the env's default)."""


def feedback_mismatches(spec: SuiteSpec, cells: Sequence[Cell] | None = None
                        ) -> list[dict[str, Any]]:
    """The trained agents a suite judges on a feedback source they were not trained on: one
    entry per arm, condition and agent (``preset``, ``condition``, ``policy``: its label,
    ``judged``: the feedback of its runs, ``trained``: those of its training,
    :func:`agents.policies.sb3.training_feedbacks`), in the suite's order. An agent without a
    readable run config is left out (its training feedback is unknown)."""
    cells = list(expand(spec) if cells is None else cells)
    trained_by_name: dict[str, tuple[str, ...] | None] = {}
    found: dict[tuple[str, str, str], dict[str, Any]] = {}
    for cell in cells:
        name = cell.config["policy"]
        if not name.startswith("sb3:"):
            continue
        if name not in trained_by_name:
            try:
                feedbacks = training_feedbacks(name[len("sb3:"):])
            except ValueError:
                feedbacks = None
            trained_by_name[name] = None if feedbacks is None else tuple(
                ENV_DEFAULT_FEEDBACK if f is None else f for f in feedbacks)
        trained = trained_by_name[name]
        judged = cell.config["env_kwargs"].get("feedback") or ENV_DEFAULT_FEEDBACK
        if trained is None or judged in trained:
            continue
        labels = cell.labels
        found.setdefault((labels["preset"], labels["condition"], labels["policy"]), {
            "preset": labels["preset"], "condition": labels["condition"],
            "policy": labels["policy"], "judged": judged, "trained": list(trained)})
    return list(found.values())


def mismatch_text(mismatch: Mapping[str, Any]) -> str:
    """A mismatch (:func:`feedback_mismatches`) in a few words, for the leaderboard's note."""
    return (f"FEEDBACK MISMATCH: judged on {mismatch['judged']}, trained on "
            f"{' + '.join(mismatch['trained'])}")


def budget_text(budget: Mapping[str, Any] | None) -> str:
    """A budget in a few words: ``70k steps, 8 min, mujoco x4, encoder_cc, plateau``."""
    if budget is None:
        return "no training record"
    parts = [f"{budget['timesteps'] / 1000:g}k steps", f"{budget['wall_s'] / 60:.0f} min",
             f"{budget['engine']} x{budget['n_envs']}"]
    if budget.get("feedback"):
        parts.append(str(budget["feedback"]))
    parts.append("plateau" if budget["plateau"] else
                 "stopped by hand, no plateau" if budget.get("interrupted") else "no plateau")
    if budget.get("demonstrations"):
        parts.append("from demonstrations")
    if budget.get("trained_agent"):
        parts.append(f"fine-tuned from {budget['trained_agent']}")
    return ", ".join(parts)


def condition_kind(kwargs: Mapping[str, Any]) -> str:
    """``nominal``, ``load``, ``visual fault`` or ``load + visual fault``: what a suite condition
    (its env keyword arguments) puts on the arm."""
    kinds = [kind for key, kind in (("scenario", "load"), ("faults", "visual fault"))
             if kwargs.get(key)]
    return " + ".join(kinds) if kinds else "nominal"


def agents_against_baselines(spec: SuiteSpec, boards: Mapping[tuple[str, str], list[dict]]
                             ) -> dict[str, list[dict[str, Any]]]:
    """Per arm, one row per condition: the best baseline and the best agent by mean last-cycle
    error (mm), their ratio (agent / baseline) and whether the agent beats every baseline
    (``None`` where either side has no finished run)."""
    table: dict[str, list[dict[str, Any]]] = {}
    mismatched = {(m["preset"], m["condition"], m["policy"]) for m in feedback_mismatches(spec)}
    for arm in spec.arms:
        agent_labels = {policy.label for policy in arm.policies if policy.is_agent}
        rows = []
        for condition, kwargs in arm.conditions.items():
            finished = [e for e in boards.get((arm.preset, condition), [])
                        if e["runs"] and math.isfinite(e["last_cycle_error_mm"])]
            baselines = [e for e in finished if e["policy"] not in agent_labels]
            agents = [e for e in finished if e["policy"] in agent_labels]
            best_baseline = min(baselines, key=lambda e: e["last_cycle_error_mm"], default=None)
            best_agent = min(agents, key=lambda e: e["last_cycle_error_mm"], default=None)
            both = best_baseline is not None and best_agent is not None
            rows.append({
                "condition": condition, "kind": condition_kind(kwargs),
                "best_baseline": best_baseline and best_baseline["policy"],
                "best_baseline_mm": best_baseline["last_cycle_error_mm"] if best_baseline
                else math.nan,
                "best_agent": best_agent and best_agent["policy"],
                "best_agent_mm": best_agent["last_cycle_error_mm"] if best_agent else math.nan,
                "best_agent_feedback_mismatch": bool(best_agent) and (
                    arm.preset, condition, best_agent["policy"]) in mismatched,
                "ratio": (best_agent["last_cycle_error_mm"] / best_baseline["last_cycle_error_mm"]
                          if both and best_baseline["last_cycle_error_mm"] > 0 else math.nan),
                "agent_beats_every_baseline": (best_agent["last_cycle_error_mm"]
                                               < best_baseline["last_cycle_error_mm"])
                if both else None})
        table[arm.preset] = rows
    return table


def _agents_section(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The leaderboard's lines comparing an arm's best agent with its best baseline."""
    if not any(row["best_agent"] for row in rows):
        return []
    shown = [{"condition": row["condition"], "kind": row["kind"],
              "best baseline": row["best_baseline"] or "—",
              "baseline (mm)": _fmt(row["best_baseline_mm"]),
              "best agent": (row["best_agent"] or "—") + (
                  " (feedback mismatch)" if row.get("best_agent_feedback_mismatch") else ""),
              "agent (mm)": _fmt(row["best_agent_mm"]),
              "agent / baseline": _fmt(row["ratio"]),
              "agent beats every baseline": {True: "yes", False: "no", None: "—"}[
                  row["agent_beats_every_baseline"]]}
             for row in rows]
    disturbed = [row["condition"] for row in rows
                 if row["kind"] != "nominal" and row["agent_beats_every_baseline"]]
    verdict = (f"An agent beats every baseline under a load or visual fault: yes, on "
               f"{', '.join(disturbed)}." if disturbed else
               "An agent beats every baseline under a load or visual fault: no.")
    return ["Best agent against best baseline (mean last-cycle error):", "",
            markdown_table(shown, columns=list(shown[0])), "", verdict, ""]


# ---------------------------------------------------------------------------- aggregates
def score_matrices(rows: Sequence[Mapping[str, Any]], preset: str
                   ) -> tuple[dict[str, np.ndarray], list[tuple[str, str]], dict[str, str]]:
    """The scores of every complete policy on ``preset``.

    Returns:
        ``(matrices, tasks, excluded)``: policy -> ``(n_seeds, n_tasks)`` array of last-cycle
        errors (mm), rows in seed order and columns in the order of ``tasks``
        (``(path, condition)`` pairs); ``excluded``: policy -> why it has no matrix (a run n/a,
        not made yet or not finite).
    """
    arm_rows = [r for r in rows if r["preset"] == preset]
    tasks = list(dict.fromkeys((r["path"], r["condition"]) for r in arm_rows))
    seeds = sorted({r["seed"] for r in arm_rows})
    matrices, excluded = {}, {}
    for policy in dict.fromkeys(r["policy"] for r in arm_rows):
        runs = {(r["seed"], r["path"], r["condition"]): r for r in arm_rows
                if r["policy"] == policy}
        statuses = [r["status"] for r in runs.values()]
        if "n/a" in statuses:
            excluded[policy] = ("n/a" if statuses.count("n/a") == len(statuses)
                                else f"n/a in {statuses.count('n/a')} of {len(statuses)} runs")
            continue
        if "missing" in statuses:
            excluded[policy] = f"{statuses.count('missing')} of {len(statuses)} runs not made yet"
            continue
        if "bad" in statuses:
            excluded[policy] = f"{statuses.count('bad')} of {len(statuses)} records bad"
            continue
        matrix = np.array([[runs[(seed, path, condition)][SCORE] for path, condition in tasks]
                           for seed in seeds], dtype=float)
        if not np.all(np.isfinite(matrix)):
            excluded[policy] = "a run has no finite last-cycle error"
            continue
        matrices[policy] = matrix
    return matrices, tasks, excluded


def aggregate_scores(matrices: Mapping[str, np.ndarray], reps: int = DEFAULT_REPS,
                     seed: int = 0) -> dict[str, dict[str, Any]]:
    """IQM, mean and median of each policy's scores with 95 % stratified-bootstrap CIs (mm).

    Args:
        matrices: policy -> ``(n_runs, n_tasks)`` last-cycle errors (mm).
        reps: bootstrap resamples.
        seed: seed of the bootstrap.

    Returns:
        policy -> ``{"iqm_mm", "iqm_ci_mm": [low, high], "mean_mm", "mean_ci_mm", "median_mm",
        "median_ci_mm", "n_runs", "n_tasks"}``.
    """
    library, metrics = require_rliable()
    if not matrices:
        return {}

    def statistics(scores: np.ndarray) -> np.ndarray:
        return np.array([metrics.aggregate_iqm(scores), metrics.aggregate_mean(scores),
                         metrics.aggregate_median(scores)])

    with _global_seed(seed):
        points, intervals = library.get_interval_estimates(dict(matrices), statistics,
                                                           reps=reps)
    out = {}
    for policy, matrix in matrices.items():
        point, interval = points[policy], intervals[policy]
        out[policy] = {"n_runs": int(matrix.shape[0]), "n_tasks": int(matrix.shape[1])}
        for i, name in enumerate(("iqm", "mean", "median")):
            out[policy][f"{name}_mm"] = float(point[i])
            out[policy][f"{name}_ci_mm"] = [float(interval[0, i]), float(interval[1, i])]
    return out


def profile_taus(matrices: Mapping[str, np.ndarray], points: int = PROFILE_POINTS) -> np.ndarray:
    """The thresholds of the performance profiles (mm): 0 to 1.05 times the largest score."""
    top = max((float(np.max(m)) for m in matrices.values()), default=1.0)
    return np.linspace(0.0, 1.05 * top if top > 0 else 1.0, points)


def fraction_within(scores: np.ndarray, taus: Sequence[float]) -> np.ndarray:
    """Fraction of all ``scores`` (runs x tasks) with ``score <= tau``, for every ``tau``."""
    flat = np.asarray(scores, dtype=float).ravel()
    return np.mean(flat[None, :] <= np.asarray(taus, dtype=float)[:, None], axis=1)


def performance_profiles(matrices: Mapping[str, np.ndarray], taus: Sequence[float],
                         reps: int = PROFILE_REPS, seed: int = 0) -> dict[str, dict[str, list]]:
    """``P(e <= tau)`` over all runs and tasks of each policy, with 95 % stratified-bootstrap
    CIs: policy -> ``{"fraction", "ci_low", "ci_high"}`` (lists over ``taus``)."""
    library, _ = require_rliable()
    if not matrices:
        return {}
    taus = np.asarray(taus, dtype=float)
    with _global_seed(seed):
        profiles, intervals = library.create_performance_profile(
            dict(matrices), taus, custom_profile_func=fraction_within, reps=reps)
    return {policy: {"fraction": [float(v) for v in profiles[policy]],
                     "ci_low": [float(v) for v in intervals[policy][0]],
                     "ci_high": [float(v) for v in intervals[policy][1]]}
            for policy in matrices}


# ---------------------------------------------------------------------------- the report
def write_report(spec: SuiteSpec, out: str | os.PathLike, cells: Sequence[Cell] | None = None,
                 reps: int = DEFAULT_REPS, profile_reps: int = PROFILE_REPS, seed: int = 0,
                 plots: bool = True, progress: bool = False) -> str:
    """Write the report of ``spec``'s records under ``out`` (see the module docstring).

    Args:
        spec: the suite (its cells name the records read; other records in ``out`` are left
            out).
        out: the suite's output directory.
        cells: the cells (default: ``expand(spec)``).
        reps, profile_reps: bootstrap resamples of the aggregate and profile CIs.
        seed: bootstrap seed.
        plots: also draw the PNGs.
        progress: show a bar over the report's steps (each arm's bootstrap, each plot).

    Returns:
        The leaderboard (Markdown), as written to ``leaderboard.md``.
    """
    require_rliable()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cells = list(expand(spec) if cells is None else cells)
    rows = collect_rows(cells, out)
    arms = list(dict.fromkeys(arm.preset for arm in spec.arms))
    groups = _first_seed_groups(cells, rows, spec.seeds[0]) if plots else {}
    bar = tqdm(total=2 * len(arms) + 1 + (2 + len(groups) if plots else 0),
               desc=f"suite {spec.name} report", unit="step", disable=not progress,
               mininterval=1.0)
    with heartbeat(bar):
        text = _write_report(spec, out, cells, rows, arms, groups, bar, reps, profile_reps,
                             seed, plots)
    bar.close()
    return text


def _write_report(spec: SuiteSpec, out: Path, cells: Sequence[Cell],
                  rows: Sequence[Mapping[str, Any]], arms: Sequence[str],
                  groups: Mapping[tuple[str, str, str], Mapping[str, str]], bar: Any, reps: int,
                  profile_reps: int, seed: int, plots: bool) -> str:
    """:func:`write_report`'s work, each step counted on ``bar``."""
    boards = leaderboards(rows)
    per_arm: dict[str, dict[str, Any]] = {}
    for index, preset in enumerate(arms):
        bar.set_postfix_str(f"{preset}: bootstrap")
        matrices, tasks, excluded = score_matrices(rows, preset)
        taus = profile_taus(matrices)
        profiled = {policy: matrix for policy, matrix in matrices.items()
                    if matrix.size >= PROFILE_MIN_RUNS}
        aggregates = aggregate_scores(matrices, reps=reps, seed=seed + index)
        bar.update()
        per_arm[preset] = {
            "tasks": [list(task) for task in tasks],
            "aggregates": aggregates,
            "excluded": excluded,
            "profile_taus_mm": taus.tolist(),
            "profile_min_runs": PROFILE_MIN_RUNS,
            "profiles": performance_profiles(profiled, taus, reps=profile_reps,
                                             seed=seed + index),
            "profiles_left_out": {
                policy: f"{matrix.size} runs x tasks, fewer than {PROFILE_MIN_RUNS}"
                for policy, matrix in matrices.items() if policy not in profiled},
            "scores_mm": {policy: matrix.tolist() for policy, matrix in matrices.items()},
        }
        bar.update()
    counts = {status: sum(r["status"] == status for r in rows)
              for status in ("done", "n/a", "missing", "bad")}
    budgets = agent_budgets(spec)
    versus = agents_against_baselines(spec, boards)
    mismatches = feedback_mismatches(spec, cells)
    text = leaderboard_markdown(spec, rows, boards, per_arm, counts, budgets, versus,
                                mismatches)
    (out / "leaderboard.md").write_text(text, encoding="utf-8")
    _write_runs_csv(out / "runs.csv", rows)
    record_versions = [r["versions"] for r in rows if r.get("versions")]
    write_json(out / "suite.json", {
        "suite": spec.name,
        "description": spec.description,
        "spec_file": spec.source,
        "spec_sha256": spec.sha256,
        "spec_text": spec.text,
        "seeds": list(spec.seeds),
        "cycles": {arm.preset: arm.cycles for arm in spec.arms},
        "score": f"{SCORE}: mean tracking error over the last path cycle (mm), lower is better",
        "bootstrap": {"reps": reps, "profile_reps": profile_reps, "seed": seed,
                      "confidence": 0.95, "method": "percentile, stratified over tasks"},
        "soft_arm_gym_version": package_version(),
        "report_versions": library_versions(),
        "report_git_revision": git_revision(),
        "record_versions": _distinct(record_versions),
        "record_git_revisions": sorted({str(r["git_revision"]) for r in rows
                                        if r.get("git_revision")}),
        "counts": {"cells": len(rows), **counts},
        "missing": [r["key"] for r in rows if r["status"] == "missing"],
        "bad_records": [r["reason"] for r in rows if r["status"] == "bad"],
        "leaderboards": [{"preset": preset, "condition": condition, "entries": entries}
                         for (preset, condition), entries in boards.items()],
        "arms": per_arm,
        "agent_budgets": budgets,
        "agents_against_baselines": versus,
        "feedback_mismatches": mismatches,
    })
    bar.update()
    if plots:
        colors = suite_colors(spec)
        bar.set_postfix_str("plots")
        _plot_aggregates(out / "aggregate_iqm.png", per_arm, colors)
        bar.update()
        _plot_profiles(out / "performance_profiles.png", per_arm, colors)
        bar.update()
        _plot_first_seed(out / "plots", groups, out, spec.seeds[0], colors, tick=bar.update)
    return text


def _distinct(items: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    seen, distinct = set(), []
    for item in items:
        key = tuple(sorted(item.items()))
        if key not in seen:
            seen.add(key)
            distinct.append(item)
    return distinct


def _fmt(value: float, digits: int = 2) -> str:
    return f"{value:.{digits}f}" if isinstance(value, (int, float)) and math.isfinite(value) \
        else ""


def leaderboard_markdown(spec: SuiteSpec, rows: Sequence[Mapping[str, Any]],
                         boards: Mapping[tuple[str, str], list[dict]],
                         per_arm: Mapping[str, Mapping[str, Any]],
                         counts: Mapping[str, int],
                         budgets: Mapping[str, Mapping[str, Any]] | None = None,
                         versus: Mapping[str, Sequence[Mapping[str, Any]]] | None = None,
                         mismatches: Sequence[Mapping[str, Any]] | None = None) -> str:
    """The text of ``leaderboard.md``; ``budgets`` (:func:`agent_budgets`) fill the agents'
    training column, ``versus`` (:func:`agents_against_baselines`) each arm's comparison of its
    best agent with its best baseline, ``mismatches`` (:func:`feedback_mismatches`, default:
    the suite's) mark each agent judged on a feedback source it was not trained on, in a
    paragraph under its arm's heading and in its rows' note."""
    budgets = agent_budgets(spec) if budgets is None else budgets
    mismatches = feedback_mismatches(spec) if mismatches is None else mismatches
    mismatched = {(m["preset"], m["condition"], m["policy"]): m for m in mismatches}
    lines = [f"# Suite {spec.name}", ""]
    if spec.description:
        lines += [spec.description.strip(), ""]
    lines += [f"{len(rows)} runs: {counts['done']} done, {counts['n/a']} n/a, "
              f"{counts['missing']} not made yet"
              + (f", {counts['bad']} bad record(s) left out (listed in suite.json; redo them "
                 f"with --resume)" if counts.get("bad") else "")
              + f"; seeds {list(spec.seeds)}; suite file "
              f"`{Path(spec.source).name}` (sha256 {spec.sha256[:12]}).", "",
              "Score: the last-cycle tracking error (mm; mean distance from the target to the "
              "true tip over the last path cycle), lower is better. Aggregates per arm over "
              "paths x conditions x seeds: IQM, mean and median with 95 % stratified-bootstrap "
              "CIs.", ""]
    for arm in spec.arms:
        preset = arm.preset
        info = per_arm[preset]
        lines += [f"## {preset}", "",
                  f"{len(arm.paths)} path(s) {list(arm.paths)}, {len(arm.conditions)} "
                  f"condition(s), {arm.cycles} cycle(s) per run, feedback "
                  f"{arm.feedback or 'the env default'} unless a condition sets it"
                  + (f", engine {arm.env['engine']}" if "engine" in arm.env else "") + ".", ""]
        arm_mismatches = [m for m in mismatches if m["preset"] == preset]
        if arm_mismatches:
            by_policy: dict[str, list[Mapping[str, Any]]] = {}
            for m in arm_mismatches:
                by_policy.setdefault(m["policy"], []).append(m)
            lines += ["**Feedback mismatch**: "
                      + "; ".join(f"{policy} was trained on {' + '.join(ms[0]['trained'])} "
                                  f"feedback and is judged here on "
                                  + ", ".join(
                                      judged + " (" + ", ".join(m["condition"] for m in ms
                                                                if m["judged"] == judged) + ")"
                                      for judged in dict.fromkeys(m["judged"] for m in ms))
                                  for policy, ms in by_policy.items())
                      + ". Its scores there measure the feedback as much as the agent; they "
                        "are marked in the note.", ""]
        aggregate_rows = []
        for policy, stats in sorted(info["aggregates"].items(),
                                    key=lambda item: item[1]["iqm_mm"]):
            aggregate_rows.append({
                "policy": policy,
                "IQM (mm)": _fmt(stats["iqm_mm"]),
                "IQM 95% CI": _interval_text(stats, "iqm"),
                "mean (mm)": _fmt(stats["mean_mm"]),
                "mean 95% CI": _interval_text(stats, "mean"),
                "median (mm)": _fmt(stats["median_mm"]),
                "runs x tasks": f"{stats['n_runs']} x {stats['n_tasks']}",
            })
        for policy, reason in info["excluded"].items():
            aggregate_rows.append({"policy": policy, "IQM (mm)": "n/a" if reason == "n/a"
                                   else "", "runs x tasks": reason})
        if aggregate_rows:
            lines += ["Aggregate (last-cycle error):", "",
                      markdown_table(aggregate_rows, columns=[
                          "policy", "IQM (mm)", "IQM 95% CI", "mean (mm)", "mean 95% CI",
                          "median (mm)", "runs x tasks"])]
        if info.get("profiles_left_out"):
            left_out = info["profiles_left_out"]
            lines += [("No performance profile drawn for " if not info["profiles"] else
                       "Left out of the performance profiles: ")
                      + ", ".join(f"{policy} ({reason})" for policy, reason in left_out.items())
                      + f": a profile needs at least {PROFILE_MIN_RUNS} "
                        "scores (seeds x paths x conditions) to be more than a few steps; run "
                        "more seeds (the suite's seeds) for one.", ""]
        if versus is not None:
            lines += _agents_section(versus.get(preset, []))
        arm_budgets = budgets.get(preset, {})
        for condition in arm.conditions:
            entries = boards.get((preset, condition), [])
            table = []
            for entry in entries:
                row = {"rank": entry["rank"] if entry["rank"] is not None else "—",
                       "policy": entry["policy"],
                       "last cycle (mm)": _pm(entry["last_cycle_error_mm"],
                                              entry["last_cycle_error_std_mm"]),
                       "mean (mm)": _fmt(entry["mean_error_mm"]),
                       "max (mm)": _fmt(entry["max_error_mm"]),
                       "path dev. (mm)": _fmt(entry["path_deviation_mm"]),
                       "runs": f"{entry['runs']}/{entry['of']}",
                       "training": budget_text(arm_budgets[entry["policy"]])
                       if entry["policy"] in arm_budgets else "",
                       "note": "; ".join(filter(None, (
                           mismatch_text(mismatched[(preset, condition, entry["policy"])])
                           if (preset, condition, entry["policy"]) in mismatched else "",
                           entry["note"] or ("n/a" if entry["status"] == "n/a" else ""))))}
                if len(arm.paths) > 1:
                    for path in arm.paths:
                        row[f"{path} (mm)"] = _fmt(entry["per_path"].get(path, math.nan))
                table.append(row)
            columns = ["rank", "policy", "last cycle (mm)"]
            if len(arm.paths) > 1:
                columns += [f"{path} (mm)" for path in arm.paths]
            columns += ["mean (mm)", "max (mm)", "path dev. (mm)", "runs"]
            if any(entry["policy"] in arm_budgets for entry in entries):
                columns.append("training")
            columns.append("note")
            lines += [f"### {preset}: {condition}", "", markdown_table(table, columns=columns)]
    return "\n".join(lines).rstrip() + "\n"


def _pm(mean: float, std: float) -> str:
    if not math.isfinite(mean):
        return ""
    return f"{mean:.2f} ± {std:.2f}" if math.isfinite(std) else f"{mean:.2f}"


def _write_runs_csv(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    columns = ["key", "preset", "path", "condition", "policy", "seed", "status",
               *_CSV_METRICS, "wall_s", "reason"]
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({key: ("" if isinstance(row.get(key), float)
                                   and not math.isfinite(row[key]) else row.get(key))
                             for key in columns})


# ---------------------------------------------------------------------------------- plots
def _figure(width_in: float, height_in: float, nrows: int, ncols: int = 1):
    figure = Figure(figsize=(width_in, height_in), dpi=120, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(nrows, ncols, squeeze=False)
    return figure, axes


def _colors(policies: Iterable[str]) -> dict[str, str]:
    """The colours of policies drawn together (:func:`eval.palette.policy_colors`: each keyed by
    its name, the same in every plot and panel, distinct within the set)."""
    return policy_colors(policies)


def suite_colors(spec: SuiteSpec) -> dict[str, str]:
    """The colour of every policy label of a suite, drawn together in its report: one set, so a
    suite's own label keeps its colour in every panel and plot."""
    return _colors(policy.label for arm in spec.arms for policy in arm.policies)


NO_INTERVAL = "1 seed: no interval"
"""What the tables and the aggregate plot say instead of a confidence interval when a policy
has one run per task: every bootstrap resample is the data, so the interval is the point."""


def _has_interval(stats: Mapping[str, Any]) -> bool:
    """Whether an aggregate has a confidence interval (more than one run per task)."""
    return int(stats.get("n_runs", 0)) > 1


def _interval_text(stats: Mapping[str, Any], name: str) -> str:
    """``[low, high]`` of ``stats[name + "_ci_mm"]``, or :data:`NO_INTERVAL`."""
    if not _has_interval(stats):
        return NO_INTERVAL
    return "[" + ", ".join(_fmt(v) for v in stats[f"{name}_ci_mm"]) + "]"


def _plot_aggregates(path: Path, per_arm: Mapping[str, Mapping[str, Any]],
                     colors: Mapping[str, str] | None = None) -> None:
    """Per arm and policy: the IQM (dot) with its 95 % CI (bar) and the mean (cross)."""
    arms = [preset for preset, info in per_arm.items() if info["aggregates"]]
    if not arms:
        return
    heights = [max(1, len(per_arm[preset]["aggregates"])) for preset in arms]
    figure, axes = _figure(7.0, 0.9 + 0.38 * sum(heights) + 0.5 * len(arms), len(arms))
    for ax, preset in zip(axes[:, 0], arms):
        shown = _colors(per_arm[preset]["aggregates"]) if colors is None else colors
        stats = sorted(per_arm[preset]["aggregates"].items(), key=lambda item: item[1]["iqm_mm"])
        for y, (policy, values) in enumerate(stats):
            if _has_interval(values):
                low, high = values["iqm_ci_mm"]
                ax.plot([low, high], [y, y], "-", color=shown[policy], lw=5, alpha=0.45,
                        solid_capstyle="butt")
            ax.plot(values["iqm_mm"], y, "o", color=shown[policy], ms=6)
            ax.plot(values["mean_mm"], y, "x", color="k", ms=6)
        ax.set_yticks(range(len(stats)), [policy for policy, _ in stats])
        ax.set_ylim(len(stats) - 0.3, -0.7)  # the best on top
        ax.set_xlim(left=0.0)
        intervals = [_has_interval(values) for _, values in stats]
        interval = ("95% CI (bar)" if all(intervals) else NO_INTERVAL if not any(intervals)
                    else f"95% CI (bar; {NO_INTERVAL} where none)")
        ax.set_title(f"{preset}: IQM of the last-cycle error, {interval}; mean (x)",
                     fontsize=9)
        ax.grid(axis="x", alpha=0.3)
    axes[-1, 0].set_xlabel("last-cycle tracking error (mm), lower is better")
    save_figure(figure, path)


def _plot_profiles(path: Path, per_arm: Mapping[str, Mapping[str, Any]],
                   colors: Mapping[str, str] | None = None) -> None:
    """Per arm: the fraction of runs with last-cycle error <= tau, with 95 % CI bands, for the
    policies with at least :data:`PROFILE_MIN_RUNS` scores; a panel names those left out and
    says why (and says so in place of the curves where none has enough)."""
    arms = [preset for preset, info in per_arm.items()
            if info["profiles"] or info.get("profiles_left_out")]
    if not arms:
        return
    ncols = 2 if len(arms) > 1 else 1
    nrows = math.ceil(len(arms) / ncols)
    figure, axes = _figure(5.0 * ncols, 3.8 * nrows, nrows, ncols)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(arms):
            ax.set_visible(False)
            continue
        info = per_arm[arms[k]]
        taus = np.asarray(info["profile_taus_mm"])
        shown = _colors(info["profiles"]) if colors is None else colors
        for policy, profile in info["profiles"].items():
            color = shown[policy]
            ax.step(taus, profile["fraction"], where="post", color=color, lw=1.4, label=policy)
            ax.fill_between(taus, profile["ci_low"], profile["ci_high"], step="post",
                            color=color, alpha=0.18, lw=0)
        left_out = info.get("profiles_left_out") or {}
        minimum = info.get("profile_min_runs", PROFILE_MIN_RUNS)
        if left_out:
            runs = sorted({int(reason.split()[0]) for reason in left_out.values()
                           if reason.split()[0].isdigit()})
            counts = "/".join(str(n) for n in runs) or "too few"
            text = (f"no profile: {counts} runs x tasks per policy,\nfewer than the "
                    f"{minimum} a profile needs" if not info["profiles"] else
                    f"left out ({counts} runs x tasks, fewer than {minimum}):\n"
                    + ", ".join(left_out))
            ax.text(0.02, 0.97 if not info["profiles"] else 0.03, text,
                    transform=ax.transAxes, fontsize=7, va="top" if not info["profiles"]
                    else "bottom", ha="left", wrap=True)
        ax.set_ylim(-0.02, 1.02)
        if len(taus) > 1 and taus[-1] > taus[0]:
            ax.set_xlim(taus[0], taus[-1])
        ax.set_xlabel(PROFILE_AXIS)
        ax.set_ylabel("fraction of runs with last-cycle\nerror <= tau")
        ax.set_title(arms[k], fontsize=10)
        ax.grid(alpha=0.3)
        if info["profiles"]:
            ax.legend(fontsize=7, loc="lower right")
    save_figure(figure, path)


def _file_part(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", str(text)).strip("_") or "x"


def _first_seed_groups(cells: Sequence[Cell], rows: Sequence[Mapping[str, Any]], seed: int
                       ) -> dict[tuple[str, str, str], dict[str, str]]:
    """The finished runs of ``seed`` by (arm, path, condition): policy -> record key."""
    status = {row["key"]: row["status"] for row in rows}
    groups: dict[tuple[str, str, str], dict[str, str]] = {}
    for cell in cells:
        labels = cell.labels
        if labels["seed"] == seed and status.get(cell.key) == "done":
            groups.setdefault((labels["preset"], labels["path"], labels["condition"]),
                              {})[labels["policy"]] = cell.key
    return groups


def _plot_first_seed(directory: Path, groups: Mapping[tuple[str, str, str], Mapping[str, str]],
                     out: Path, seed: int, colors: Mapping[str, str] | None = None,
                     tick: Callable[[], Any] = lambda: None) -> None:
    """Error against time and trajectories of every policy, per arm/path/condition
    (:func:`_first_seed_groups`), one seed; ``tick()`` after each group."""
    loaded: dict[tuple[str, str, str], dict[str, Mapping[str, np.ndarray]]] = {}
    for group, keys in groups.items():
        records = {policy: _steps_or_none(out, key) for policy, key in keys.items()}
        records = {policy: record for policy, record in records.items() if record is not None}
        if records:
            loaded[group] = records
    # one y-scale for every error plot of an arm, so its conditions and paths compare by eye
    peaks: dict[str, list[float]] = {}
    for (preset, _, _), records in loaded.items():
        arm = peaks.setdefault(preset, [0.0, 0.0])
        arm[:] = np.maximum(arm, error_peaks_mm(list(records.values()))).tolist()
    for group in groups:
        if group in loaded:
            preset, path, condition = group
            records = loaded[group]
            stem = f"{_file_part(preset)}_{_file_part(path)}_{_file_part(condition)}"
            title = f"{preset} {path}, {condition} (seed {seed})"
            shown = _colors(records) if colors is None else colors
            plot_error_time(directory / f"error_{stem}.png", records, title,
                            colors={policy: shown[policy] for policy in records},
                            ymax_mm=peaks[preset])
            _plot_trajectories(directory / f"trajectory_{stem}.png", records, title, shown)
        tick()


def _steps_or_none(out: Path, key: str) -> dict[str, np.ndarray] | None:
    """The verified per-step arrays of ``key``; ``None`` when absent or bad (the rows say so)."""
    try:
        return read_steps(out, key)
    except RecordError:
        return None


def _plot_trajectories(path: Path, records: Mapping[str, Mapping[str, np.ndarray]],
                       title: str, colors: Mapping[str, str] | None = None) -> None:
    """Every policy's true tip over the path, x-y plane (mm)."""
    figure, axes = _figure(6.4, 5.4, 1)
    ax = axes[0, 0]
    first = next(iter(records.values()))
    if first.get("polyline_m") is not None:
        line = np.asarray(first["polyline_m"], dtype=float) * MM_PER_M
        closed = np.vstack((line, line[:1]))
        ax.plot(closed[:, 0], closed[:, 1], color="0.6", lw=3, alpha=0.6, label="path")
    shown = _colors(records) if colors is None else colors
    for policy, record in records.items():
        tip = np.asarray(record["tip_m"], dtype=float) * MM_PER_M
        ax.plot(tip[:, 0], tip[:, 1], "-", color=shown[policy], lw=1.1, label=policy)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    save_figure(figure, path)


__all__ = ["DEFAULT_REPS", "PROFILE_AXIS", "PROFILE_MIN_RUNS", "PROFILE_REPS", "SCORE",
           "agent_budgets", "agents_against_baselines", "aggregate_scores", "budget_text",
           "collect_rows", "condition_kind", "feedback_mismatches", "fraction_within",
           "leaderboard_markdown", "leaderboards", "mismatch_text", "performance_profiles",
           "profile_taus", "require_rliable", "score_matrices", "suite_colors", "write_report"]
