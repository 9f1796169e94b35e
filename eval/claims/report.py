"""The ledger as Markdown (``claims.md``) and JSON (``claims.json``)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

from eval.claims.ledger import NOT_RUN, VERDICTS
from eval.report import write_json

MARK = {"reproduced": "reproduced", "partly": "partly", "not reproduced": "NOT reproduced",
        NOT_RUN: NOT_RUN}


def summary_line(ledger: dict[str, Any]) -> str:
    """``"20 claims on seeds 0, 1, 2 (full): 9 reproduced, 6 partly, 5 not reproduced"``."""
    counts = Counter(entry["verdict"] for entry in ledger["claims"])
    seeds = ", ".join(str(seed) for seed in ledger["seeds"])
    mode = "quick" if ledger["quick"] else "full"
    verdicts = list(VERDICTS) + ([NOT_RUN] if counts.get(NOT_RUN) else [])
    return (f"{len(ledger['claims'])} claims on seeds {seeds} ({mode}): "
            + ", ".join(f"{counts.get(verdict, 0)} {verdict}" for verdict in verdicts))


def ledger_table(ledger: dict[str, Any]) -> str:
    """One row per claim: the claim, the paper, ours per seed (the numbers that decided), the
    verdict."""
    quick = " (quick)" if ledger["quick"] else ""
    every = list(ledger["seeds"])
    lines = ["| claim | paper | ours, per seed | verdict |", "|---|---|---|---|"]
    for entry in ledger["claims"]:
        ours = "<br>".join(f"seed {s['seed']}: {s['measured']} ({s['verdict']})"
                           for s in entry["seeds"]) or (
            "cannot be run in simulation" if entry["experiment"] is None else "")
        verdict = MARK[entry["verdict"]] + quick
        judged = [s["seed"] for s in entry["seeds"]]
        if entry["seeds"] and judged != every:
            verdict += (f" (seed{'s' if len(judged) > 1 else ''} "
                        f"{', '.join(str(s) for s in judged)} only)")
        if entry["verdict"] != "reproduced" and entry["cause"]:
            verdict += f"<br>why: {entry['cause']}"
        lines.append(f"| **{entry['key']}** ({entry['where']}): {entry['statement']} | "
                     f"{entry['paper_figures']} | {ours} | {verdict} |")
    return "\n".join(lines)


def markdown(ledger: dict[str, Any], command: str) -> str:
    """``claims.md``: how it was made, the summary, the table, the criteria and the
    experiments with their times."""
    versions = ", ".join(f"{k} {v}" for k, v in ledger["versions"].items())
    made = ", ".join(ledger.get("record_revisions", [])) or "none"
    lines = ["# The papers' claims: reproduced or not", "",
             f"Made by `{command}` (git {ledger['git_revision'] or 'unknown'}; {versions}); "
             f"the records it judged were made at revision(s) {made}.",
             "Each claim's criterion states the paper's effect as a number and was written "
             "before any run: on one seed, *reproduced* within a band around the paper's size "
             "(0.8-1.25 x unless the criterion says otherwise), *partly* with at least half the "
             "paper's effect in its direction, *not reproduced* below that, judged per path, "
             "load or configuration where the paper reports them apart, and a disturbance "
             "first judged on the source it hurts. Over seeds: *reproduced* when every seed "
             "is, *not reproduced* when most seeds are not even partly, *partly* otherwise. A "
             "claim the simulation cannot run is *not reproduced*, with why.",
             "", f"**{summary_line(ledger)}**",
             "", ledger_table(ledger), "", "## Criteria", ""]
    for entry in ledger["claims"]:
        where = (f"experiment `{entry['experiment']}`" if entry["experiment"] is not None
                 else "no experiment: the simulation cannot run it")
        lines.append(f"- **{entry['key']}**: {entry['criterion']} ({where})")
    lines += ["", "## Experiments", "",
              "| experiment | what runs | seconds per seed | CPU seconds per seed |",
              "|---|---|---|---|"]
    for name, experiment in ledger["experiments"].items():
        what = experiment["description"]
        if ledger["quick"]:
            what += f"; quick: {experiment['quick_description']}"
        seconds = ", ".join(f"{s:.0f}" for s in experiment["seconds"]) or NOT_RUN
        cpu = ", ".join("-" if s is None else f"{s:.0f}"
                        for s in experiment.get("cpu_seconds", [])) or NOT_RUN
        lines.append(f"| `{name}` | {what} | {seconds} | {cpu} |")
    total = sum(sum(e["seconds"]) for e in ledger["experiments"].values())
    lines += ["", f"Total experiment time: {total / 60:.1f} minutes (each experiment's wall "
              "time; CPU seconds are its own process's, where recorded: '-' is a record "
              "written before they were)."]
    return "\n".join(lines) + "\n"


def write_ledger(ledger: dict[str, Any], out: str | Path, command: str) -> tuple[Path, Path]:
    """Write ``claims.md`` and ``claims.json`` under ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / "claims.md"
    md.write_text(markdown(ledger, command), encoding="utf-8")
    return md, write_json(out / "claims.json", {**ledger, "command": command})
