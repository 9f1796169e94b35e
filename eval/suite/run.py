"""Running a suite: one cell in a worker (:func:`run_cell`), the backends that spread the cells
over processes or a cluster (:data:`BACKENDS`), and :func:`run_suite`, which runs the cells not
finished yet and writes each record as its run ends (:mod:`eval.suite`, "Running")."""

from __future__ import annotations

import copy
import os
import sys
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from agents.policies import PolicyRefusal
from agents.rollout import run_episode
from eval.pool import WorkerDeathError, process_map, serial_map
from eval.runner import RunConfig, build
from eval.suite.check import check_suite
from eval.suite.locks import LOCKS_DIR, claim, release, remove_locks_dir
from eval.suite.grid import Cell, expand, label_text
from eval.suite.spec import SuiteSpec, load_suite
from eval.suite.store import (cell_metrics, check_records_dir, git_revision, is_finished,
                              library_versions, record_problem, records_dir, write_record)
from soft_gym._progress import heartbeat
from soft_gym._threads import one_compute_thread
from soft_gym.datasets.episodes import EpisodeRecorder
from soft_gym.sensing.calibration_cache import disk_cache_enabled


class SuiteRunError(RuntimeError):
    """Runs that failed with an error other than a refusal (no record was written for them)."""

    def __init__(self, failures: list[dict[str, Any]]) -> None:
        self.failures = failures
        names = ", ".join(f"{f['key']} ({label_text(f['labels'])}: {f['error']})"
                          for f in failures[:5])
        more = f" and {len(failures) - 5} more" if len(failures) > 5 else ""
        super().__init__(f"{len(failures)} run(s) failed: {names}{more}; tracebacks in "
                         f"errors/<key>.txt; run again with resume to retry them")


def run_cell(task: Mapping[str, Any]) -> dict[str, Any]:
    """Run one cell (a worker's job; picklable): ``task`` holds ``key``, ``suite``, ``labels``,
    ``config``, ``versions`` and ``git_revision``.

    Returns the JSON record (see the module docstring) with the per-step arrays under
    ``"steps"`` (``None`` when n/a: the policy raised :class:`~agents.policies.PolicyRefusal`),
    or, for any other error (a ``ValueError`` of the env or the policy too), ``status``
    ``"error"`` with the ``error`` and its ``traceback``.
    """
    start = time.perf_counter()
    config = task["config"]
    result = {"key": task["key"], "suite": task["suite"], "labels": dict(task["labels"]),
              "config": config, "status": "done", "reason": None, "metrics": None,
              "wall_s": None, "versions": task["versions"],
              "git_revision": task["git_revision"], "steps": None}
    run_config = RunConfig(policy=config["policy"], env_kwargs=copy.deepcopy(config["env_kwargs"]),
                           policy_params=copy.deepcopy(config["policy_params"]),
                           env_id=config["env_id"], seed=config["seed"])
    try:
        with one_compute_thread():
            try:
                env, policy = build(run_config)
            except PolicyRefusal as error:  # the policy declines this arm or env: n/a
                result.update(status="n/a", reason=" ".join(str(error).split()))
            else:
                if task.get("record_episode"):  # changes nothing the env returns
                    env = EpisodeRecorder(env)
                try:
                    steps = run_episode(env, policy, seed=config["seed"], progress=False)
                finally:
                    env.close()
                result.update(metrics=cell_metrics(steps), steps=steps)
                if isinstance(env, EpisodeRecorder):
                    result["episode"] = recorded_episode(env)
    except Exception as error:  # noqa: BLE001 - reported, the other runs go on
        result.update(status="error", error=f"{type(error).__name__}: {error}",
                      traceback=traceback.format_exc())
    result["wall_s"] = time.perf_counter() - start
    return result


def recorded_episode(recorder: EpisodeRecorder) -> dict[str, Any]:
    """The run's episode with what a dataset needs of its env: ``env_id``, ``env_kwargs``,
    ``obs_parts``, ``obs_format``, ``action_mode`` and the two spaces."""
    spec, unwrapped = recorder.env.spec, recorder.unwrapped
    return {**recorder.episode_arrays(0), "env_id": spec.id, "env_kwargs": dict(spec.kwargs),
            "obs_parts": list(unwrapped.obs_parts),
            "obs_format": unwrapped.config.obs_format,
            "action_mode": unwrapped.config.action_mode,
            "observation_space": recorder.observation_space,
            "action_space": recorder.action_space}


MapFunction = Callable[[Callable[[Any], Any], Sequence[Any], int], Iterator[Any]]
"""A backend: ``map(fn, items, workers)`` yields ``fn(item)`` for every item, as each completes
(in any order); it may end by raising :class:`eval.pool.WorkerDeathError` for the items whose
worker process died (:func:`run_suite` fails those runs)."""


BACKENDS: dict[str, MapFunction] = {"process": process_map, "serial": serial_map}
"""Backend name -> map function (see :data:`MapFunction`)."""


def register_backend(name: str, map_function: MapFunction) -> None:
    """Make ``map_function`` available as ``run_suite(..., backend=name)``."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"backend name must be non-empty text, got {name!r}")
    if not callable(map_function):
        raise ValueError(f"map_function must be callable, got {map_function!r}")
    BACKENDS[name] = map_function


def died(task: Mapping[str, Any], cause: str) -> dict[str, Any]:
    """The failed result of a run whose worker process died running it (twice: in the pool,
    then in a process of its own), with the ``cause`` as its error."""
    return {"key": task["key"], "labels": dict(task["labels"]), "status": "error",
            "error": cause, "traceback": f"{cause}: the run was tried twice and no result came "
                                         "back (see eval.pool)\n"}


def write_error(out: str | os.PathLike, result: Mapping[str, Any]) -> None:
    """Write a failed run's labels and traceback to ``out/errors/<key>.txt``."""
    errors = Path(out) / "errors"
    errors.mkdir(parents=True, exist_ok=True)
    (errors / f"{result['key']}.txt").write_text(
        f"{label_text(result['labels'])}\n{result['traceback']}", encoding="utf-8")


def order_cells(cells: Sequence[Cell]) -> list[Cell]:
    """Cells round-robin over their (arm, policy, seed) groups, in first-seen group order."""
    groups: dict[tuple, list[Cell]] = {}
    for cell in cells:
        labels = cell.labels
        groups.setdefault((labels["preset"], labels["policy"], labels["seed"]), []).append(cell)
    ordered, depth = [], max((len(g) for g in groups.values()), default=0)
    for i in range(depth):
        ordered += [group[i] for group in groups.values() if i < len(group)]
    return ordered


def run_suite(spec: SuiteSpec | str | os.PathLike, out: str | os.PathLike, workers: int = 1,
              resume: bool = False, backend: str | MapFunction = "process",
              progress: bool = True, check: bool = True,
              record: bool = False) -> dict[str, Any]:
    """Run the suite's cells and write one record per run as it finishes.

    Args:
        spec: a loaded suite, a suite file or a bundled suite name.
        out: output directory (records under ``out/records``).
        workers: parallel runs (>= 1).
        resume: skip the cells whose record is there and sound (:func:`eval.suite.store.
            read_record`); a bad one is reported by path and run again. Without it every cell
            runs again.
        backend: a name from :data:`BACKENDS` or a map function (:data:`MapFunction`);
            ``"ray"`` is there once :mod:`eval.suite.ray_backend` is imported (it imports
            this module).
        progress: show a progress bar over the runs.
        check: run :func:`check_suite` first (the command line has already done so).
        record: also keep each run's episode (observations, actions, rewards, terminations,
            the info's ground truth and estimates) under ``out/episodes`` for
            :func:`eval.datasets.suite.write_suite_datasets`; the records are the same.

    Returns:
        ``{"cells", "skipped", "done", "n/a", "bad", "claimed_elsewhere", "wall_s"}``: counts
        (``bad``: records found bad and redone with ``resume``; ``claimed_elsewhere``: cells
        another live process is running, left to it) and the wall time (s).

    Raises:
        ValueError: a bad argument, suite or output directory (before any run).
        SuiteRunError: some runs failed with an error other than a refusal, or their worker
            process died twice (after the others).
    """
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if isinstance(backend, str):
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {sorted(BACKENDS)} or a map function, "
                             f"got {backend!r}")
        map_function = BACKENDS[backend]
    elif callable(backend):
        map_function = backend
    else:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)} or a map function, got "
                         f"{backend!r}")
    check_records_dir(out)
    disk_cache_enabled()  # SOFT_GYM_CACHE refused now, not in every run
    if not isinstance(spec, SuiteSpec):
        spec = load_suite(spec)
    cells = check_suite(spec, progress=progress) if check else expand(spec)
    start = time.perf_counter()
    bad = {cell.key: problem for cell in cells
           if (problem := record_problem(out, cell.key)) is not None} if resume else {}
    for problem in bad.values():
        tqdm.write(f"{problem}: redoing it", file=sys.stderr)
    candidates = [cell for cell in cells if not (resume and is_finished(out, cell.key))]
    records_dir(out).mkdir(parents=True, exist_ok=True)
    claimed: list[Cell] = []
    counts = {"cells": len(cells), "skipped": len(cells) - len(candidates), "done": 0, "n/a": 0,
              "bad": len(bad), "claimed_elsewhere": 0}
    try:
        for cell in candidates:
            if not claim(out, cell.key):
                counts["claimed_elsewhere"] += 1
            elif resume and is_finished(out, cell.key):  # finished by another since the scan
                release(out, cell.key)
                counts["skipped"] += 1
            else:
                claimed.append(cell)
        if counts["claimed_elsewhere"]:
            tqdm.write(f"{counts['claimed_elsewhere']} run(s) claimed by another live process "
                       f"(see {Path(out) / LOCKS_DIR}/): left to it", file=sys.stderr)
        versions, revision = library_versions(), git_revision()
        tasks = [{"key": cell.key, "suite": spec.name, "labels": cell.labels,
                  "config": cell.config, "versions": versions, "git_revision": revision,
                  "record_episode": bool(record)}
                 for cell in order_cells(claimed)]
        failures = []
        bar = tqdm(total=len(tasks), desc=f"suite {spec.name}", unit="run",
                   disable=not progress)
        try:
            with heartbeat(bar):
                for result in map_function(run_cell, tasks, workers):
                    if result["status"] == "error":
                        failures.append(result)
                        write_error(out, result)
                    else:
                        write_record(out, result)
                        counts[result["status"]] += 1
                    release(out, result["key"])
                    bar.set_postfix_str(label_text(result["labels"]), refresh=False)
                    bar.update(1)
        except WorkerDeathError as error:  # raised after every other run's result
            for death in error.deaths:
                failures.append(died(death.item, death.cause))
                write_error(out, failures[-1])
                bar.update(1)
        bar.close()
    finally:
        for cell in claimed:
            release(out, cell.key)
        remove_locks_dir(out)
    counts["wall_s"] = time.perf_counter() - start
    if failures:
        raise SuiteRunError(failures)
    return counts

