"""The ``"ray"`` backend of the claims ledger: each job a Ray task, on a local Ray or a cluster::

    from eval.claims.run import run_ledger
    from eval.claims.ray_backend import make_ray_map
    run_ledger(["ho2018"], out="results/claims", workers=2, backend="ray")
    run_ledger(["ho2018"], out="/shared/claims", backend=make_ray_map("auto"))

or from the command line, ``python -m eval claims --backend ray [--address ADDR]``.

Ray is an optional extra (``pip install "soft-arm-gym[ray]"``): this module imports without it,
and :func:`backend_map` / :func:`ray_map` then raise an ``ImportError`` naming the extra.

Where the tasks run is as for the suite's cells (:mod:`eval.suite.ray_backend`): without
``address`` and with no Ray running in this process, a local Ray of ``workers`` CPUs, started and
shut down by the run; with ``address`` (``"auto"``, ``"ray://host:10001"``, ``"host:6379"``) that
cluster, connected to and left running; a Ray already initialised in this process is used and
left running.

A job (:func:`eval.claims.run._jobs`: one experiment and seed, or several of one paper that
share a build) is one Ray task on one CPU running :func:`eval.claims.run._run_job`, as a
process-pool worker does: its experiments in order, on one compute thread, each record written by
:func:`eval.claims.run.run_record` as soon as that experiment is done. So the records are the
local run's (only the times differ), and ``resume=True`` after an interrupted run reads those
already written and runs the rest. The tasks write under ``out`` made absolute: on a cluster of
several machines it must be a directory every node sees at that path (a shared file system),
else each record stays on the node that ran its job (the ledger of that run is whole: the
records also come back with the tasks). The package must be importable on every node, as for
the suite.

A task lost with its worker or node (killed, out of memory) is run again, up to
:data:`MAX_RETRIES` times (Ray's ``max_retries``; the suite's cells get Ray's default, the same
3). An experiment that raises is not run again: the other jobs run to their end, then the first
error is raised (a resume runs the failed jobs again).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.claims.ledger import ClaimExperiment
from eval.suite.ray_backend import INSTALL_HINT, _check_address, require_ray

BACKEND_NAME = "ray"
MAX_RETRIES = 3
"""How often a task lost with its worker or node is run again (Ray's ``max_retries``)."""

Job = tuple[list[ClaimExperiment], int, bool, str, bool]
"""A job as :func:`eval.claims.run._run_job` takes it: ``(experiments, seed, quick, out,
progress)``."""
Records = dict[tuple[str, int], dict]
"""A job's records by ``(experiment, seed)``, as :func:`eval.claims.run.read_record` reads them."""
JobMap = Callable[[Callable[[Job], Records], Sequence[Job], int], Iterator[Records]]
"""``map(run_job, jobs, workers)`` yields ``run_job(job)`` for every job as it completes (in any
order), as :data:`eval.suite.MapFunction` does for cells."""


def _apply(run_job: Callable[[Job], Records], task: Job) -> Records:
    """A Ray task's body: ``run_job(task)`` (``run_job`` travels by reference, so it must be
    importable: :func:`eval.claims.run._run_job`)."""
    return run_job(task)


def ray_map(run_job: Callable[[Job], Records], tasks: Sequence[Job], workers: int = 1, *,
            address: str | None = None,
            runtime_env: Mapping[str, Any] | None = None) -> Iterator[Records]:
    """Run every job as a Ray task (one CPU, retried :data:`MAX_RETRIES` times when lost),
    yielding each job's records as it completes; the tasks write the records.

    Args:
        run_job: :func:`eval.claims.run._run_job` (importable on every node).
        tasks: jobs as it takes them; their ``out`` is made absolute for the tasks.
        workers: CPUs of the local Ray this starts (>= 1); ignored on an existing cluster.
        address: an existing cluster (``"auto"``, ``"ray://host:10001"``, ``"host:6379"``);
            ``None``: a local Ray (or the one already initialised in this process).
        runtime_env: Ray's runtime environment of the tasks (e.g. ``{"working_dir": "."}`` to
            ship the checkout), used when this call initialises Ray.

    Stopping the iteration early (an interrupt too) cancels the tasks not yet finished; a Ray
    this call started (or connected to) is shut down (disconnected) at the end, one initialised
    before is left running.

    Raises:
        ImportError: Ray is not installed (before any task).
        ValueError: ``workers`` or ``address`` is bad (before any task).
        Exception: the first failed job's error (Ray's ``RayTaskError``, also an instance of
            the experiment's exception class), once the other jobs have ended.
    """
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    _check_address(address)
    ray = require_ray()
    tasks = [(list(experiments), seed, quick, str(Path(out).resolve()), progress)
             for experiments, seed, quick, out, progress in tasks]
    return _job_results(ray, run_job, tasks, workers, address, runtime_env)


def _job_results(ray, run_job: Callable[[Job], Records], tasks: list[Job], workers: int,
                 address: str | None,
                 runtime_env: Mapping[str, Any] | None) -> Iterator[Records]:
    """The generator of :func:`ray_map` (its arguments already checked)."""
    if not tasks:
        return
    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {"include_dashboard": False}
        if runtime_env is not None:
            options["runtime_env"] = dict(runtime_env)
        if address is None:
            ray.init(num_cpus=workers, **options)
        else:
            ray.init(address=address, **options)
    pending: list[Any] = []
    failures: list[Exception] = []
    try:
        remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(_apply)
        job_of: dict[Any, Job] = {}
        for task in tasks:
            ref = remote.remote(run_job, task)
            job_of[ref] = task
            pending.append(ref)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            experiments, seed = job_of.pop(done[0])[:2]
            try:
                records = ray.get(done[0])
            except Exception as error:  # noqa: BLE001 - the other jobs go on; raised below
                failures.append(error)
                first_line = (str(error).strip().splitlines() or [type(error).__name__])[0]
                print(f"claims job {', '.join(e.name for e in experiments)}, seed {seed} "
                      f"failed: {first_line}", file=sys.stderr, flush=True)
                continue
            yield records
        if failures:
            raise failures[0]
    finally:
        for ref in pending:
            ray.cancel(ref)
        if started:
            ray.shutdown()


def make_ray_map(address: str | None = None,
                 runtime_env: Mapping[str, Any] | None = None) -> JobMap:
    """A :data:`JobMap` on the cluster at ``address`` (see :func:`ray_map`), for
    ``run_ledger(..., backend=make_ray_map("auto"))``.

    Raises:
        ValueError: ``address`` is not non-empty text or ``None``.
    """
    _check_address(address)

    def map_function(run_job: Callable[[Job], Records], tasks: Sequence[Job],
                     workers: int = 1) -> Iterator[Records]:
        return ray_map(run_job, tasks, workers, address=address, runtime_env=runtime_env)

    return map_function


def backend_map(backend: str | JobMap) -> JobMap:
    """The map of :func:`eval.claims.run.run_ledger`'s ``backend`` other than ``"local"``:
    ``"ray"`` (:func:`ray_map` on a local Ray, or the Ray initialised in this process) or a
    :data:`JobMap` (:func:`make_ray_map`'s).

    Raises:
        ValueError: another ``backend``.
        ImportError: ``"ray"`` without Ray installed.
    """
    if isinstance(backend, str) and backend == BACKEND_NAME:
        require_ray()
        return ray_map
    if callable(backend):
        return backend
    raise ValueError(f"backend must be 'local', 'ray' or a map function "
                     f"(eval.claims.ray_backend.make_ray_map), got {backend!r}")


__all__ = ["BACKEND_NAME", "INSTALL_HINT", "MAX_RETRIES", "JobMap", "backend_map",
           "make_ray_map", "ray_map"]
