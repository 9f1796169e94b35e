"""Jobs for the pool tests that kill their own worker process (``SIGKILL``), importable by a
spawned worker: on one chosen job, either every time or the first time only (a marker file
records that it died once)."""

from __future__ import annotations

import functools
import os
import signal
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.pool import process_map


def _die_here(job: Any, victim: Any, marker: str | None) -> None:
    """Kill this process when ``job`` is ``victim``: every time (``marker`` ``None``) or only
    when the file ``marker`` is not there yet (it is made first)."""
    if job != victim:
        return
    if marker is not None:
        if Path(marker).exists():
            return
        Path(marker).touch()
    os.kill(os.getpid(), signal.SIGKILL)


def square_or_die(value: int, victim: int, marker: str | None = None) -> int:
    """``value ** 2``, after killing this process on ``victim`` (see :func:`_die_here`)."""
    _die_here(value, victim, marker)
    return value * value


def fake_run_cell(task: Mapping[str, Any], victim: str, marker: str | None = None
                  ) -> dict[str, Any]:
    """A quick stand-in for :func:`eval.suite.run_cell`: an n/a result for the task's cell,
    after killing this process on the cell ``victim`` (a key; see :func:`_die_here`)."""
    _die_here(task["key"], victim, marker)
    return {"key": task["key"], "suite": task["suite"], "labels": dict(task["labels"]),
            "config": task["config"], "status": "n/a", "reason": "a stand-in run",
            "metrics": None, "wall_s": 0.0, "versions": task["versions"],
            "git_revision": task["git_revision"], "steps": None}


def dying_backend(victim: str, marker: str | None = None
                  ) -> Callable[[Callable, Sequence[Any], int], Iterator[Any]]:
    """A suite backend: :func:`process_map` over :func:`fake_run_cell` in place of the real
    run (the suite's own ``fn`` is not called)."""
    def map_function(fn: Callable, items: Sequence[Any], workers: int) -> Iterator[Any]:
        run = functools.partial(fake_run_cell, victim=victim, marker=marker)
        return process_map(run, items, workers)
    return map_function
