"""Run the claims' experiments for every seed and judge each claim (:func:`run_ledger`).

Each experiment's summary for one seed is written to ``<out>/records/<experiment>_seed<N>.json``
(``..._quick.json`` for ``quick``) as soon as it is done, with the time it took, the revision and
versions that made it, and a SHA-256 digest of all of it (:func:`record_digest`), so a record
edited by hand or cut short is caught when read (:func:`read_record`, a
:class:`~eval.suite.store.RecordError` naming its path). ``resume=True`` reads the records
already there instead of running them again, so an interrupted full run continues where it
stopped; a bad record is named and run again. ``report_only=True`` runs nothing and leaves a
bad record out of the verdicts, naming it in the ledger's ``bad_records``.

With ``workers > 1`` the experiments run side by side in ``workers`` processes, each on one
compute thread, so a record is the same whichever process or worker count made it. A job is one
experiment and seed, or several of one paper that share a build (``ClaimExperiment.shares``: run
in order, so the calibration, data set or model they share is built once and then read from the
cache); the longest jobs start first (``ClaimExperiment.cpu_minutes``). With
``backend="ray"`` each job is a Ray task instead, on a local Ray or a cluster, writing the
same records (:mod:`eval.claims.ray_backend`).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

from eval.claims import CLAIMS, EXPERIMENTS, claim_papers
from eval.claims.ledger import NOT_RUN, Claim, ClaimExperiment, Outcome, combine
from eval.report import to_jsonable, write_json
from eval.suite.grid import canonical_json
from eval.suite.run import one_compute_thread, process_map
from eval.suite.store import RecordError, git_revision, library_versions, read_json_object

RECORD_FORMAT = 2
"""The layout of a record file (2: with its ``sha256`` digest and the experiment's summary
``version``); a record of another format is bad, and run again by ``resume``."""


def select_claims(papers: Sequence[str] | None = None,
                  claims: Sequence[str] | None = None) -> list[Claim]:
    """The claims of ``papers`` (default: every paper's), or only those named in ``claims``;
    an unknown paper or claim is a ``ValueError`` naming it and the known ones."""
    known = claim_papers()
    papers = list(known) if papers is None else list(papers)
    unknown = [paper for paper in papers if paper not in known]
    if unknown:
        raise ValueError(f"papers must be among {list(known)}, got {unknown}")
    chosen = [claim for claim in CLAIMS.values() if claim.paper in papers]
    if claims is not None:
        missing = [key for key in claims if key not in CLAIMS]
        if missing:
            raise ValueError(f"claims must be among {list(CLAIMS)}, got {missing}")
        chosen = [claim for claim in chosen if claim.key in claims]
        if not chosen:
            raise ValueError(f"none of the claims {list(claims)} is a claim of the papers "
                             f"{papers}")
    return chosen


def record_file(out: str | Path, experiment: str, seed: int, quick: bool) -> Path:
    """Where one experiment's summary for one seed is kept under ``out``."""
    return Path(out) / "records" / f"{experiment}_seed{seed}{'_quick' if quick else ''}.json"


def record_digest(record: dict[str, Any]) -> str:
    """SHA-256 (hex) of a record's canonical JSON without its own ``sha256`` field: the
    summary, the experiment, seed and mode, the times, the revision and the versions."""
    content = {key: value for key, value in record.items() if key != "sha256"}
    return hashlib.sha256(canonical_json(content).encode("utf-8")).hexdigest()


def read_record(path: Path, experiment: str, seed: int, quick: bool,
                version: int | None = None) -> dict | None:
    """The verified record at ``path`` of this experiment, seed and mode; ``None`` when there
    is none.

    Verified: readable UTF-8 JSON holding an object of :data:`RECORD_FORMAT`, of this
    experiment, seed and mode and of the experiment's present summary ``version``, with a
    summary, versions and a revision, whose ``sha256`` is its content's (:func:`record_digest`).
    ``version``: the summary version expected (default: the registered experiment's).

    Raises:
        RecordError: (a ``ValueError``) naming the path and what is wrong.
    """
    path = Path(path)
    if not os.path.lexists(path):
        return None
    record = read_json_object(path)
    if record.get("format") != RECORD_FORMAT:
        raise RecordError(path, f"format {record.get('format')!r}, not {RECORD_FORMAT} (written "
                                "before records carried a digest)")
    found = (record.get("experiment"), record.get("seed"), record.get("quick"))
    if found != (experiment, seed, quick):
        raise RecordError(path, f"holds experiment, seed and quick {list(found)}, not "
                                f"{[experiment, seed, quick]} (copied from another record?)")
    digest = record.get("sha256")
    if not isinstance(digest, str) or digest != record_digest(record):
        raise RecordError(path, "its content does not match its sha256 digest (edited by hand "
                                "or damaged)" if isinstance(digest, str) else "no sha256 digest")
    if version is None:
        version = EXPERIMENTS[experiment].version if experiment in EXPERIMENTS else 1
    if record.get("version") != version:
        raise RecordError(path, f"summary version {record.get('version')!r}, the experiment's "
                                f"is now {version!r} (run again for its present fields)")
    if not isinstance(record.get("summary"), dict):
        raise RecordError(path, "no summary object")
    versions = record.get("versions")
    if not (isinstance(versions, dict) and all(isinstance(v, str) for v in versions.values())):
        raise RecordError(path, "versions must map library names to version text")
    if not isinstance(record.get("git_revision"), (str, type(None))):
        raise RecordError(path, "git_revision must be text or null")
    return record


def run_ledger(papers: Sequence[str] | None = None, seeds: Sequence[int] = (0, 1, 2),
               quick: bool = False, out: str | Path = "results/claims", resume: bool = False,
               workers: int = 1, progress: bool = True,
               claims: Sequence[str] | None = None, report_only: bool = False,
               backend: str | Callable[..., Any] = "local") -> dict[str, Any]:
    """Run the experiments the chosen claims read, for every seed, and judge the claims.

    Args:
        papers: paper keys (default: all).
        seeds: episode / training seeds; each claim is judged on every one.
        quick: the small version of every experiment (verdicts marked quick).
        out: output directory (``records/`` of the experiments' summaries).
        resume: read the records already under ``out`` instead of running them again.
        workers: processes: the experiments side by side (jobs as in the module docstring),
            or, where there is one job, the episodes of the experiments that run several
            independent ones.
        progress: progress bars.
        claims: only these claim keys.
        report_only: run nothing: judge each claim on the seeds whose records are under
            ``out`` (a claim with none is ``"not run"``).
        backend: ``"local"`` (this process or ``workers`` processes), or ``"ray"``: each job
            a Ray task on a local Ray of ``workers`` CPUs, writing the same records (or a
            map of :func:`eval.claims.ray_backend.make_ray_map`, for a cluster).

    Returns:
        The ledger: ``{"quick", "seeds", "versions", "git_revision", "bad_records" (with
        ``report_only``: the bad records left out, each ``"bad record PATH: problem"``),
        "record_revisions" (the revisions that made the records read), "experiments": {name:
        {"seconds": [...], "cpu_seconds": [...]}}, "claims": [{key, paper, where, statement,
        paper_figures, criterion, experiment, cause, verdict, seeds: [{seed, verdict,
        measured}]}]}``.
    """
    chosen = select_claims(papers, claims)
    seeds = list(seeds)
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct and at least one, got {seeds}")
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    run_jobs = None
    if backend != "local":  # refused now (ValueError, ImportError), not after any run
        from eval.claims.ray_backend import backend_map  # Ray, an optional extra

        run_jobs = backend_map(backend)
    names = list(dict.fromkeys(claim.experiment for claim in chosen
                               if claim.experiment is not None))
    records: dict[tuple[str, int], dict] = {}
    missing: list[tuple[str, int]] = []
    bad: list[str] = []
    for seed in seeds:
        for name in names:
            path = record_file(out, name, seed, quick)
            try:
                record = read_record(path, name, seed, quick) if resume or report_only else None
            except RecordError as error:
                record = None
                bad.append(str(error))
                if progress or not report_only:
                    print(f"{error}{'' if report_only else '; running it again'}",
                          file=sys.stderr, flush=True)
            if record is not None:
                records[name, seed] = record
            elif not report_only:
                missing.append((name, seed))
    jobs = _jobs(missing, quick)
    if run_jobs is not None:  # each job a Ray task, writing its records as a pool worker does
        tasks = [(experiments, seed, quick, str(out), progress) for seed, experiments in jobs]
        for done in run_jobs(_run_job, tasks, workers):
            records.update(done)
    elif workers == 1 or len(jobs) <= 1:
        for name, seed in missing:  # seed by seed: an interrupted run leaves whole seeds
            records[name, seed] = run_record(EXPERIMENTS[name], seed, quick, out, workers,
                                             progress)
    else:
        tasks = [(experiments, seed, quick, str(out), progress) for seed, experiments in jobs]
        for done in process_map(_run_job, tasks, workers):
            records.update(done)
    summaries = {key: record["summary"] for key, record in records.items()}
    def per_seed(name: str, field: str) -> list[float | None]:  # in seed order
        return [None if records[name, seed].get(field) is None
                else float(records[name, seed][field]) for seed in seeds
                if (name, seed) in records]
    entries = []
    for claim in chosen:
        if claim.experiment is None:
            entries.append(_entry(claim, [], []))
            continue
        judged = [seed for seed in seeds if (claim.experiment, seed) in summaries]
        outcomes = [claim.judge(summaries[claim.experiment, seed]) for seed in judged]
        entries.append(_entry(claim, judged, outcomes))
    return {"quick": quick, "seeds": seeds, "versions": library_versions(),
            "git_revision": git_revision(),
            "bad_records": bad if report_only else [],
            "record_revisions": sorted({str(record.get("git_revision"))
                                        for record in records.values()}),
            "experiments": {name: {"paper": EXPERIMENTS[name].paper,
                                   "description": EXPERIMENTS[name].description,
                                   "quick_description": EXPERIMENTS[name].quick_description,
                                   "seconds": per_seed(name, "seconds"),
                                   "cpu_seconds": per_seed(name, "cpu_seconds")}
                           for name in names},
            "claims": entries}


def run_record(experiment: ClaimExperiment, seed: int, quick: bool, out: str | Path,
               workers: int = 1, progress: bool = True) -> dict[str, Any]:
    """Run one experiment for one seed and write its record under ``out`` (as soon as it is
    done); returns the record as a resume reads it back."""
    if progress:
        print(f"{experiment.name}, seed {seed}{' (quick)' if quick else ''}", flush=True)
    start, cpu_start = time.perf_counter(), time.process_time()
    summary = experiment.run(seed, quick, workers, progress)
    path = record_file(out, experiment.name, seed, quick)
    record = json.loads(json.dumps(
        {"format": RECORD_FORMAT, "experiment": experiment.name, "version": experiment.version,
         "seed": seed, "quick": quick, "seconds": time.perf_counter() - start,
         "cpu_seconds": time.process_time() - cpu_start, "versions": library_versions(),
         "git_revision": git_revision(), "summary": to_jsonable(summary)}))
    write_json(path, {**record, "sha256": record_digest(record)})
    return read_record(path, experiment.name, seed, quick, experiment.version)


def _jobs(missing: list[tuple[str, int]], quick: bool
          ) -> list[tuple[int, list[ClaimExperiment]]]:
    """The missing (experiment, seed) records as jobs: per seed, one job for each group of a
    paper's experiments that share a build (``ClaimExperiment.shares``; the others one job
    each), its experiments in registry order; seed by seed, and within a seed the longest job
    (``ClaimExperiment.cpu_minutes``, summed) first, so the pool's workers end close together."""
    grouped: dict[tuple[int, str, str], list[ClaimExperiment]] = {}
    for name, seed in missing:
        experiment = EXPERIMENTS[name]
        group = experiment.shares or experiment.name
        grouped.setdefault((seed, experiment.paper, group), []).append(experiment)
    which = 0 if quick else 1

    def minutes(key: tuple[int, str, str]) -> float:
        return sum(experiment.cpu_minutes[which] for experiment in grouped[key])
    order = sorted(grouped, key=lambda key: (key[0], -minutes(key)))
    return [(key[0], grouped[key]) for key in order]


def _run_job(task: tuple[list[ClaimExperiment], int, bool, str, bool],
             ) -> dict[tuple[str, int], dict]:
    """A pool worker's job: experiments that share a build, for one seed, in order, on one compute
    thread (so the numbers do not depend on the worker count)."""
    experiments, seed, quick, out, progress = task
    with one_compute_thread():
        return {(experiment.name, seed): run_record(experiment, seed, quick, out, 1, progress)
                for experiment in experiments}

def _entry(claim: Claim, seeds: list[int], outcomes: list[Outcome]) -> dict[str, Any]:
    if claim.experiment is None:
        verdict = "not reproduced"  # the simulation cannot run it: the cause says why
    else:
        verdict = combine(outcomes) if outcomes else NOT_RUN
    return {"key": claim.key, "paper": claim.paper, "where": claim.where,
            "statement": claim.statement, "paper_figures": claim.paper_figures,
            "criterion": claim.criterion, "experiment": claim.experiment,
            "cause": claim.cause, "verdict": verdict,
            "seeds": [{"seed": seed, "verdict": outcome.verdict, "measured": outcome.measured}
                      for seed, outcome in zip(seeds, outcomes)]}
