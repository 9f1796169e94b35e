"""The sections of ``docs/results.md`` that are read off the repository's own records.

* the default suite's last run, ``docs/leaderboard/runs.csv`` (``python -m eval suite default``):
  the best agent against the best baseline per arm and condition, and every policy's
  last-cycle tracking error per condition (seed 0, and the mean over the suite's seeds);
* the shipped agents, ``agents/trained/<name>/``: ``training.yaml`` (each training segment),
  ``eval/tracking_curve.csv`` (the tracking curve) and ``evaluation.yaml`` (the nominal error
  when shipped, per engine);
* the claims ledger, ``docs/claims/claims.json`` (``python -m eval claims ... --docs``).

Each section is a list of Markdown lines whose links are relative to ``docs/``, where the page
lives. Errors are millimetres (mm) written with two decimals, times minutes, rates env steps
per second.
"""

from __future__ import annotations

import csv
import json
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from agents.policies.sb3 import (shipped_agents, training_budget, training_feedbacks,
                                 training_segments)
from eval.claims.ledger import NOT_RUN, VERDICTS
from eval.claims.report import summary_line
from eval.report import markdown_table
from eval.suite.report import (ENV_DEFAULT_FEEDBACK, SCORE, agent_budgets,
                               agents_against_baselines, budget_text, leaderboards)
from eval.suite.spec import SuiteSpec, load_suite
from soft_gym.engines import ENGINES, REFERENCE_ENGINE

SUITE_NAME = "default"
"""The bundled suite whose last run ``docs/leaderboard/`` keeps."""

RUNS_CSV = Path("docs") / "leaderboard" / "runs.csv"
"""The default suite's runs, relative to the repository's root."""

CLAIMS_JSON = Path("docs") / "claims" / "claims.json"
"""The claims ledger's record, relative to the repository's root."""

NUMERIC_COLUMNS = ("last_cycle_error_mm", "mean_error_mm", "max_error_mm", "final_error_mm",
                   "path_deviation_mm", "last_cycle_path_deviation_mm", "feedback_error_mm",
                   "n_steps", "wall_s")
"""The columns of ``runs.csv`` that hold numbers (an empty cell is NaN)."""


def mm(value: float | None) -> str:
    """A distance in millimetres as the page writes it (two decimals; ``—`` for none)."""
    if value is None or not math.isfinite(value):
        return "—"
    return f"{value:.2f}"


def code(name: str | None) -> str:
    """A policy, agent or file name in backquotes (``—`` for none)."""
    return "—" if not name else f"`{name}`"


def read_runs(root: Path) -> list[dict[str, Any]]:
    """The rows of the default suite's ``runs.csv`` under ``root``, numbers as floats (NaN for
    an empty cell) and the seed as an int."""
    path = root / RUNS_CSV
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for column in NUMERIC_COLUMNS:
            row[column] = float(row[column]) if row.get(column) else math.nan
        row["seed"] = int(row["seed"])
    return rows


# ------------------------------------------------------------------------ the default suite
def leaderboard_section(root: Path, spec: SuiteSpec | None = None) -> list[str]:
    """The best agent against the best baseline per arm and condition (mean last-cycle error
    over paths and seeds, mm), each agent with its training budget, and the conditions where
    no agent beats every baseline."""
    spec = load_suite(SUITE_NAME) if spec is None else spec
    rows = read_runs(root)
    table = agents_against_baselines(spec, leaderboards(rows))
    budgets = agent_budgets(spec)
    seeds = sorted({row["seed"] for row in rows})
    shown, behind = [], []
    for arm, arm_rows in table.items():
        for row in arm_rows:
            beats = row["agent_beats_every_baseline"]
            shown.append({
                "arm": arm, "condition": row["condition"], "kind": row["kind"],
                "best baseline (mm)": f"{code(row['best_baseline'])} {mm(row['best_baseline_mm'])}",
                "best agent (mm)": f"{code(row['best_agent'])} {mm(row['best_agent_mm'])}",
                "agent / baseline": mm(row["ratio"]),
                "agent beats every baseline": {True: "yes", False: "no", None: "—"}[beats],
                "agent's training": budget_text(budgets[arm].get(row["best_agent"]))
                if row["best_agent"] else "—"})
            if beats is False:
                behind.append(f"{arm} {row['condition']} ({code(row['best_baseline'])} "
                              f"{mm(row['best_baseline_mm'])} mm against "
                              f"{code(row['best_agent'])} {mm(row['best_agent_mm'])} mm)")
    done = sum(row["status"] == "done" for row in rows)
    summary = (f"An agent beats every baseline on {len(shown) - len(behind)} of {len(shown)} "
               f"conditions" + (f"; not on {', '.join(behind)}." if behind else "."))
    return ["## The leaderboard: the default suite", "",
            f"`python -m eval suite {SUITE_NAME}`: every arm under its paper's conditions and "
            f"feedback, every baseline that can drive it and its shipped agents, seeds "
            f"{', '.join(str(seed) for seed in seeds)}, the last of two path cycles scored "
            f"(PyBullet; {done} of {len(rows)} runs done). From its last run, "
            f"[`leaderboard/runs.csv`](leaderboard/runs.csv) (the full report: "
            f"[`leaderboard/leaderboard.md`](leaderboard/leaderboard.md)), the best agent "
            f"against the best baseline (mean last-cycle error over paths and seeds, mm; the "
            f"agent's training budget from its `training.yaml`):", "",
            markdown_table(shown).rstrip("\n"), "", summary, ""]


def _cell(runs: Sequence[Mapping[str, Any]], paths: Sequence[str]) -> tuple[str, float]:
    """A table cell: the mean last-cycle error of ``runs`` per path, ``" / "``-joined, and
    their mean over paths (NaN where a path has no finished run)."""
    means = []
    for path in paths:
        scores = [run[SCORE] for run in runs if run["path"] == path and run["status"] == "done"]
        means.append(sum(scores) / len(scores) if scores else math.nan)
    overall = sum(means) / len(means) if means else math.nan
    return " / ".join(mm(value) for value in means), overall


def _arm_table(rows: Sequence[Mapping[str, Any]], arm: Any, seeds: Sequence[int]) -> str:
    """One arm's conditions x policies on ``seeds`` (the lowest of each row in bold)."""
    paths = list(arm.paths)
    labels = [policy.label for policy in arm.policies]
    table = []
    for condition in arm.conditions:
        cells = {label: _cell([row for row in rows if row["condition"] == condition
                               and row["policy"] == label and row["seed"] in seeds], paths)
                 for label in labels}
        finite = [value for _, value in cells.values() if math.isfinite(value)]
        best = min(finite) if finite else math.nan
        table.append({"condition": condition, **{
            code(label): f"**{text}**" if value == best else text
            for label, (text, value) in cells.items()}})
    return markdown_table(table).rstrip("\n")


def arm_tables_section(root: Path, spec: SuiteSpec | None = None) -> list[str]:
    """Per arm, every policy's last-cycle error per condition: on the first seed, then the
    mean over the suite's seeds (mm; one column per path where the arm has several)."""
    spec = load_suite(SUITE_NAME) if spec is None else spec
    rows = read_runs(root)
    seeds = sorted({row["seed"] for row in rows})
    lines = ["## Every policy on every condition of the default suite", "",
             "From the same runs: each policy's last-cycle error (mm) per condition, on seed "
             f"{seeds[0]} and as the mean over seeds {', '.join(str(s) for s in seeds)}; an arm "
             "with several paths gives one number per path, in the order its heading names "
             "them; the lowest of each row is in bold.", ""]
    for arm in spec.arms:
        arm_rows = [row for row in rows if row["preset"] == arm.preset]
        paths = " / ".join(arm.paths)
        lines += [f"### {arm.preset} ({paths})", "", f"Seed {seeds[0]}:", "",
                  _arm_table(arm_rows, arm, seeds[:1]), "",
                  f"Mean over seeds {', '.join(str(s) for s in seeds)}:", "",
                  _arm_table(arm_rows, arm, seeds), ""]
    return lines


# ------------------------------------------------------------------------ the shipped agents
def _minutes(seconds: float | None) -> str:
    """Seconds as whole minutes (``—`` for none)."""
    return "—" if seconds is None else f"{seconds / 60:.0f}"


def _evaluations(segment: Mapping[str, Any]) -> str:
    """A training segment's tracking-curve evaluations and the seconds they took."""
    if "curve_evaluations" not in segment:
        return "—"
    seconds = segment.get("curve_evaluation_s")
    return str(segment["curve_evaluations"]) + ("" if seconds is None else f" ({seconds:.0f})")


def _feedbacks(name: str) -> str:
    """The feedback sources an agent trained on, ``+``-joined (``—`` where unknown; ``None`` is
    the env's default)."""
    feedbacks = training_feedbacks(name)
    return "—" if not feedbacks else " + ".join(f or ENV_DEFAULT_FEEDBACK for f in feedbacks)


def _curve_points(directory: Path) -> dict[str, str]:
    """The first and best points of an agent's tracking curve (``eval/tracking_curve.csv``:
    env steps and mean last-cycle error, mm); ``—`` without a curve."""
    path = directory / "eval" / "tracking_curve.csv"
    if not path.is_file():
        return {"curve's first point": "—", "curve's best point": "—"}
    with path.open(newline="", encoding="utf-8") as handle:
        points = [(int(row["timesteps"]), float(row["mean_last_cycle_mm"]))
                  for row in csv.DictReader(handle)]
    first = points[0]
    best = min(points, key=lambda point: point[1])
    return {"curve's first point": f"{mm(first[1])} mm at {first[0]:,}",
            "curve's best point": f"{mm(best[1])} mm at {best[0]:,}"}


def agents_section() -> list[str]:
    """The shipped agents: their budgets, every training segment, their tracking curves and
    their nominal error when shipped, per engine."""
    agents = shipped_agents()
    budgets, segments, evaluations = [], [], []
    for name, directory in agents.items():
        budget = training_budget(name)
        budgets.append({"agent": code(name), "training budget (all segments)": budget_text(budget),
                        **_curve_points(directory)})
        for number, segment in enumerate(training_segments(name) or [], start=1):
            own = not segment.get("trained_agent")  # a marked segment is an earlier agent's
            segments.append({
                "agent": code(name), "segment": str(number),
                "trained as": "this agent" if own else code(segment["trained_agent"]),
                "engine x envs": f"{budget['engine'] if own else segment.get('engine', '—')} "
                                 f"x{segment.get('n_envs', 1)}",
                "feedback": _feedbacks(name) if own else str(segment.get("feedback") or "—"),
                "steps": f"{segment['timesteps']:,}", "minutes": _minutes(segment.get("wall_s")),
                "training env steps/s": f"{segment.get('training_env_steps_per_s', math.nan):.0f}",
                "curve evaluations (s)": _evaluations(segment),
                "best curve error (mm)": mm(segment.get("best_tracking_mm")),
                "stopped at plateau": "yes" if segment.get("stopped_at_plateau") else "no"})
        evaluations.append(_evaluation_row(name, directory))
    return ["## The shipped agents", "",
            "From each shipped agent's records in [`agents/trained/`](../agents/trained/): its "
            "training budget (every segment of its `training.yaml`, the agents it was "
            "fine-tuned from included) and its tracking curve (`eval/tracking_curve.csv`: "
            "mean last-cycle error over the curve's evaluation set, mm, at env steps):", "",
            markdown_table(budgets).rstrip("\n"), "",
            "Each training segment (minutes of wall time on 2-core machines, some shared with "
            "other jobs, the curve's evaluations included; training env steps/s without them; "
            "the curve's evaluations with their seconds); a fine-tuned agent's first segments "
            "are the training of the agents it started from:", "",
            markdown_table(segments).rstrip("\n"), "",
            "The nominal error when shipped (`evaluation.yaml`, written by `python -m "
            "train.ship`: one episode of the recipe's env without randomisation, reset seed "
            "123, mean error after the first quarter, mm) on each engine it was run on; "
            "`tests/agents/policies/test_shipped_agents.py` holds each agent within 20 % of "
            "its training engine's:", "",
            markdown_table(evaluations).rstrip("\n"), ""]


def _evaluation_row(name: str, directory: Path) -> dict[str, str]:
    """An agent's ``evaluation.yaml`` as a table row."""
    record = yaml.safe_load((directory / "evaluation.yaml").read_text(encoding="utf-8"))
    engines = record.get("engines") or {}
    per_engine = engines.get("settled_error_mm") or {}
    feedback = (record.get("env_kwargs") or {}).get("feedback", "the env's default")
    return {"agent": code(name), "env": f"`{record['env_id']}`", "feedback": str(feedback),
            "trained on": str(engines.get("training_engine", REFERENCE_ENGINE)),
            **{f"{engine} (mm)": mm(per_engine.get(engine)) for engine in ENGINES}}


# ------------------------------------------------------------------------ the claims ledger
def _short_revision(revision: str) -> str:
    """A git revision's first seven digits, keeping a ``-dirty`` mark (uncommitted changes)."""
    return revision[:7] + ("-dirty" if revision.endswith("-dirty") else "")


def claims_section(root: Path) -> list[str]:
    """The claims ledger's verdict counts, overall and per paper, with the experiments' runs
    and time per paper (``docs/claims/claims.json``)."""
    ledger = json.loads((root / CLAIMS_JSON).read_text(encoding="utf-8"))
    verdicts = list(VERDICTS) + [NOT_RUN]
    per_paper: dict[str, Counter] = {}
    for entry in ledger["claims"]:
        per_paper.setdefault(entry["paper"], Counter())[entry["verdict"]] += 1
    seconds: dict[str, list[float]] = {}
    for experiment in ledger["experiments"].values():
        seconds.setdefault(experiment["paper"], []).extend(experiment["seconds"])
    table = [{"paper": paper, "claims": str(sum(counts.values())),
              **{verdict: str(counts.get(verdict, 0)) for verdict in verdicts},
              "experiment records": str(len(seconds.get(paper, []))),
              "experiment time (min)": f"{sum(seconds.get(paper, [])) / 60:.0f}"}
             for paper, counts in per_paper.items()]
    return ["## The claims ledger", "",
            f"From [`claims/claims.json`](claims/claims.json), the record of "
            f"[`claims.md`](claims.md) (`{ledger['command']}`, git "
            f"{ledger['git_revision'][:7]}; its records made at "
            f"{', '.join(_short_revision(r) for r in ledger['record_revisions'])}):", "",
            f"**{summary_line(ledger)}**", "",
            "Per paper (the experiments' records and their wall time in minutes, summed over "
            "seeds):", "",
            markdown_table(table).rstrip("\n"), ""]

