"""The process pool behind the suite and the claims ledger (:func:`process_map`), and what it
does when a worker dies mid-run (killed, out of memory, a crash in native code).

A dead worker breaks a :class:`~concurrent.futures.ProcessPoolExecutor`: every item not finished
yet fails with it, the one the dead worker ran and the innocent ones alike. :func:`process_map`
then runs each of those items once more in a process of its own (:func:`run_isolated`), where a
death names its item and its exit code, and the items not started yet in a fresh pool. An item
whose own process dies too is reported at the end (:class:`WorkerDeathError`), after every other
item's result.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Generator, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as wait_connections
from multiprocessing.context import BaseContext
from multiprocessing.process import BaseProcess
from typing import Any

from tqdm import tqdm

PARENT_POLL_S = 0.5
"""How often a pool worker checks that the process that started it is alive (s)."""


@dataclass(frozen=True)
class WorkerDeath:
    """An item whose worker process died running it, twice: in the pool, then in its own."""

    item: Any
    cause: str


class WorkerDeathError(RuntimeError):
    """Items whose worker process died running them, twice (raised after every other item's
    result); ``deaths`` holds each item and the cause (:func:`death_cause`)."""

    def __init__(self, deaths: list[WorkerDeath]) -> None:
        self.deaths = deaths
        causes = "; ".join(death.cause for death in deaths[:5])
        super().__init__(f"{len(deaths)} item(s) lost their worker process twice: {causes}")


def death_cause(exitcode: int | None) -> str:
    """What ended a worker process that gave no result, from its exit code (a negative one is
    the signal that killed it, as :attr:`multiprocessing.Process.exitcode` has it)."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"worker process died (exit code {exitcode} / signal {name})"
    return f"worker process died (exit code {exitcode}) without a result"


def exit_with_parent(parent_pid: int, poll_s: float = PARENT_POLL_S) -> None:
    """A pool worker's initializer: a daemon thread that ends this process (exit status 1) as
    soon as its parent ``parent_pid`` is gone (this process handed to another parent).

    Without it a ``kill -9`` of the suite leaves its workers blocked on the pool's pipe for
    good: each worker holds the pipe's writing end too, so it never reads end-of-file.
    """
    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(poll_s)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def serial_map(fn: Callable[[Any], Any], items: Sequence[Any], workers: int = 1) -> Iterator[Any]:
    """Run ``fn`` on every item in this process, in order."""
    for item in items:
        yield fn(item)


def process_map(fn: Callable[[Any], Any], items: Sequence[Any],
                workers: int = 1) -> Iterator[Any]:
    """Run ``fn`` on every item in ``workers`` spawned processes (in this process when
    ``workers == 1`` or there is one item), yielding results as they complete.

    At most ``2 * workers`` items are submitted ahead, so a stopped iteration leaves little
    work behind, which is cancelled. Each worker ends itself when this process dies (killed
    too: :func:`exit_with_parent`), and the pool's resource tracker with them. A worker that
    dies breaks the pool: the items it left unfinished run once more, each in its own process
    (:func:`run_isolated`), and the rest in a fresh pool.

    Raises:
        WorkerDeathError: after every other result, naming the items whose own process died
            too (with its exit code).
        Exception: what ``fn`` raised, as it raised it (the iteration stops there).
    """
    if workers == 1 or len(items) <= 1:
        yield from serial_map(fn, items)
        return
    context = multiprocessing.get_context("spawn")
    deaths: list[WorkerDeath] = []
    remaining = list(items)
    while remaining:
        unfinished, remaining = yield from _pool_round(fn, remaining, workers, context)
        if unfinished:
            tqdm.write(f"a pool worker died with {len(unfinished)} item(s) unfinished: running "
                       "each once more in its own process", file=sys.stderr)
        for outcome in run_isolated(fn, unfinished, workers, context):
            if isinstance(outcome, WorkerDeath):
                deaths.append(outcome)
            else:
                yield outcome
    if deaths:
        raise WorkerDeathError(deaths)


def _pool_round(fn: Callable[[Any], Any], items: list[Any], workers: int,
                context: BaseContext) -> Generator[Any, None, tuple[list[Any], list[Any]]]:
    """Run ``items`` in one pool until they are done or a worker dies, yielding results as they
    complete; returns (as the generator's value) the items the broken pool left unfinished and
    those it never took, both lists empty when none broke."""
    pending = iter(range(len(items)))
    unfinished: list[Any] = []
    broken = False
    with ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=context,
                             initializer=exit_with_parent, initargs=(os.getpid(),)) as pool:
        running: dict[Future, int] = {}

        def submit_next() -> bool:
            """Submit the next item; ``False`` when there is none or the pool is broken."""
            nonlocal broken
            index = next(pending, None)
            if index is None:
                return False
            try:
                running[pool.submit(fn, items[index])] = index
            except BrokenProcessPool:
                broken = True
                unfinished.append(items[index])
            return not broken

        try:
            while len(running) < 2 * workers and submit_next():
                pass
            while running:
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    index = running.pop(future)
                    if isinstance(future.exception(), BrokenProcessPool):
                        broken = True
                        unfinished.append(items[index])
                        continue
                    if not broken:
                        submit_next()
                    yield future.result()
        finally:
            for future in running:
                future.cancel()
    if not broken:
        return [], []
    return unfinished, [items[index] for index in pending]


def run_isolated(fn: Callable[[Any], Any], items: Sequence[Any], workers: int,
                 context: BaseContext) -> Iterator[Any]:
    """Run ``fn`` on each item in a spawned process of its own, ``workers`` at a time, yielding
    each result as its process ends, or a :class:`WorkerDeath` where the process died without
    one.

    Raises:
        Exception: what ``fn`` raised (the processes still running are ended).
    """
    queue = list(items)
    active: dict[Connection, tuple[BaseProcess, Any]] = {}
    try:
        while queue or active:
            while queue and len(active) < workers:
                item = queue.pop(0)
                receiver, sender = context.Pipe(duplex=False)
                process = context.Process(target=_call_into, args=(fn, item, sender, os.getpid()),
                                          name="process-map-retry")
                process.start()
                sender.close()  # the child's copy alone: its death reads as end-of-file
                active[receiver] = (process, item)
            for receiver in wait_connections(list(active)):
                process, item = active.pop(receiver)
                try:
                    kind, value = receiver.recv()
                except EOFError:
                    kind, value = None, None
                receiver.close()
                process.join()
                if kind is None:
                    yield WorkerDeath(item, death_cause(process.exitcode))
                elif kind == "raised":
                    raise value
                else:
                    yield value
    finally:
        for receiver, (process, _) in active.items():
            process.terminate()
            process.join()
            receiver.close()


def _call_into(fn: Callable[[Any], Any], item: Any, sender: Connection, parent_pid: int) -> None:
    """A retry process's body: send ``("done", fn(item))``, or ``("raised", error)`` with the
    error's traceback as a note, through ``sender``."""
    exit_with_parent(parent_pid)
    try:
        result = fn(item)
    except Exception as error:  # noqa: BLE001 - raised again in the parent
        error.add_note(traceback.format_exc())
        try:
            sender.send(("raised", error))
        except Exception:  # noqa: BLE001 - an error that does not pickle
            sender.send(("raised", RuntimeError(traceback.format_exc())))
        return
    sender.send(("done", result))
