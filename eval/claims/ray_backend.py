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

The tasks are the suite's (:func:`eval.suite.ray_backend.ray_map` runs them): a task lost with
its worker or node (killed, out of memory) is run again, up to Ray's default ``max_retries``
(3). An experiment that raises stops the run, as a failed task stops that map: the first error
is raised and the jobs not finished are cancelled; the records already written stay, and a
resume runs the rest.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.claims.ledger import ClaimExperiment
from eval.suite import ray_backend as suite_ray
from eval.suite.ray_backend import INSTALL_HINT, _check_address, require_ray

BACKEND_NAME = "ray"

Job = tuple[list[ClaimExperiment], int, bool, str, bool]
"""A job as :func:`eval.claims.run._run_job` takes it: ``(experiments, seed, quick, out,
progress)``."""
Records = dict[tuple[str, int], dict]
"""A job's records by ``(experiment, seed)``, as :func:`eval.claims.run.read_record` reads them."""
JobMap = Callable[[Callable[[Job], Records], Sequence[Job], int], Iterator[Records]]
"""``map(run_job, jobs, workers)`` yields ``run_job(job)`` for every job as it completes (in any
order), as :data:`eval.suite.MapFunction` does for cells."""


def ray_map(run_job: Callable[[Job], Records], tasks: Sequence[Job], workers: int = 1, *,
            address: str | None = None,
            runtime_env: Mapping[str, Any] | None = None) -> Iterator[Records]:
    """Run every job as a Ray task by :func:`eval.suite.ray_backend.ray_map` (one CPU each; where
    Ray runs, its arguments and the end of the run are as there), yielding each job's records as
    it completes; the tasks write the records.

    Args:
        run_job: :func:`eval.claims.run._run_job` (importable on every node).
        tasks: jobs as it takes them; their ``out`` is made absolute for the tasks.
        workers, address, runtime_env: as for :func:`eval.suite.ray_backend.ray_map`.

    Raises:
        ImportError: Ray is not installed (before any task).
        ValueError: ``workers`` or ``address`` is bad (before any task).
        Exception: the first failed job's error (Ray's ``RayTaskError``, also an instance of
            the experiment's exception class); the jobs not finished are cancelled.
    """
    tasks = [(list(experiments), seed, quick, str(Path(out).resolve()), progress)
             for experiments, seed, quick, out, progress in tasks]
    return suite_ray.ray_map(run_job, tasks, workers, address=address, runtime_env=runtime_env)


def make_ray_map(address: str | None = None,
                 runtime_env: Mapping[str, Any] | None = None) -> JobMap:
    """A :data:`JobMap` on the cluster at ``address`` (see :func:`ray_map`), for
    ``run_ledger(..., backend=make_ray_map("auto"))``.

    Raises:
        ValueError: ``address`` is not non-empty text or ``None``.
    """
    _check_address(address)
    return functools.partial(ray_map, address=address, runtime_env=runtime_env)


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


__all__ = ["BACKEND_NAME", "INSTALL_HINT", "JobMap", "backend_map", "make_ray_map",
           "ray_map"]
