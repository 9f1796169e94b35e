"""The ``"ray"`` backend of the benchmark suite: each cell a Ray task, on a local Ray or a cluster.

Importing this module registers the backend (:func:`eval.suite.register_backend`)::

    import eval.suite.ray_backend  # noqa: F401
    from eval import suite
    suite.run_suite("small", "results/suite_small", workers=2, backend="ray")

or from the command line, ``python -m eval suite small --backend ray [--address ADDR]``.

Ray is an optional extra: ``pip install "soft-arm-gym[ray]"`` (``ray[tune]``); this module
imports without it and :func:`ray_map` then raises an ``ImportError`` naming the extra.

Where the tasks run
-------------------
* No ``address`` and no Ray running in this process: a local Ray is started with
  ``num_cpus=workers`` (the process pool's parallelism) and shut down when the map ends.
* ``address`` (``"auto"`` for the cluster this machine belongs to, ``"ray://host:10001"``
  through Ray Client, or ``host:6379``): this process connects to that cluster, which schedules
  the cells on all its CPUs (``workers`` is then not a limit), and disconnects at the end, leaving
  the cluster running.
* Ray already initialised in this process (``ray.init`` called by the caller, e.g. a test or a
  ``ray job submit`` entry point): that Ray is used and left running.

Each cell asks for one CPU (``num_cpus=1``); results are yielded as the tasks complete
(``ray.wait``), and the records are written by this process, so the output directory need only
exist here, not on the workers.

The workers import :func:`eval.suite.run_cell` (passed by reference), so the package must be
importable on every node: install it there (the same version: ``pip install
"soft-arm-gym[ray]"``, or ``pip install -e .`` of the same checkout), or ship the checkout with
the job, e.g. ``ray job submit --working-dir . -- python -m eval suite small --backend ray
--address auto`` (Ray honours ``.gitignore`` when it uploads the working directory), or pass
``runtime_env={"working_dir": "."}`` to :func:`make_ray_map`. The calibration and pre-training
caches are per node (each node fills its own).

Records equal the process backend's for the same cells: the same ``run_cell`` runs on the same
config and seed; only ``wall_s`` differs.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from eval.suite.run import MapFunction, register_backend

BACKEND_NAME = "ray"
INSTALL_HINT = 'pip install "soft-arm-gym[ray]"'
"""The install command of the optional extra (``ray[tune]``)."""


def require_ray():
    """The ``ray`` module.

    Raises:
        ImportError: Ray is not installed (one line naming the extra to install).
    """
    try:
        import ray  # here: an optional extra; the ImportError below names it
    except ImportError as error:
        raise ImportError(f"the ray backend needs Ray, an optional extra: {INSTALL_HINT}") \
            from error
    return ray


def _apply(fn: Callable[[Any], Any], item: Any) -> Any:
    """A Ray task's body: ``fn(item)`` (``fn`` travels by reference, so it must be importable)."""
    return fn(item)


def _check_workers(workers: Any) -> int:
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    return workers


def ray_map(fn: Callable[[Any], Any], items: Sequence[Any], workers: int = 1, *,
            address: str | None = None,
            runtime_env: Mapping[str, Any] | None = None) -> Iterator[Any]:
    """Run ``fn`` on every item as Ray tasks (one CPU each), yielding results as they complete.

    Args:
        fn: a picklable, importable function of one item (e.g. :func:`eval.suite.run_cell`).
        items: the items (picklable).
        workers: CPUs of the local Ray this starts (>= 1); ignored on an existing cluster.
        address: an existing cluster (``"auto"``, ``"ray://host:10001"``, ``"host:6379"``);
            ``None``: a local Ray (or the one already initialised in this process).
        runtime_env: Ray's runtime environment of the tasks (e.g. ``{"working_dir": "."}`` to
            ship the checkout), used when this call initialises Ray.

    Stopping the iteration early cancels the tasks not yet finished. A Ray this call started
    (or connected to) is shut down (disconnected) at the end; one initialised before is left.

    Raises:
        ImportError: Ray is not installed.
        ValueError: ``workers`` is not an integer >= 1, or ``address`` is not non-empty text.
    """
    _check_workers(workers)
    _check_address(address)
    ray = require_ray()
    return _ray_results(ray, fn, list(items), workers, address, runtime_env)


def _check_address(address: Any) -> None:
    if address is not None and (not isinstance(address, str) or not address.strip()):
        raise ValueError(f"address must be non-empty text (e.g. 'auto', 'ray://host:10001') or "
                         f"None, got {address!r}")


def _ray_results(ray, fn: Callable[[Any], Any], items: list[Any], workers: int,
                 address: str | None, runtime_env: Mapping[str, Any] | None) -> Iterator[Any]:
    """The generator of :func:`ray_map` (its arguments already checked)."""
    if not items:
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
    try:
        task = ray.remote(num_cpus=1)(_apply)
        pending = [task.remote(fn, item) for item in items]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        for ref in pending:
            ray.cancel(ref)
        if started:
            ray.shutdown()


def make_ray_map(address: str | None = None,
                 runtime_env: Mapping[str, Any] | None = None) -> MapFunction:
    """A :data:`eval.suite.MapFunction` on the cluster at ``address`` (see :func:`ray_map`),
    for ``run_suite(..., backend=make_ray_map("auto"))``.

    Raises:
        ValueError: ``address`` is not non-empty text or ``None``.
    """
    _check_address(address)

    def map_function(fn: Callable[[Any], Any], items: Sequence[Any],
                     workers: int = 1) -> Iterator[Any]:
        return ray_map(fn, items, workers, address=address, runtime_env=runtime_env)

    return map_function


register_backend(BACKEND_NAME, ray_map)

__all__ = ["BACKEND_NAME", "INSTALL_HINT", "make_ray_map", "ray_map", "require_ray"]
