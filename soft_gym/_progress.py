"""Progress bars that keep moving through a long step: the elapsed time redrawn every second
while one step of the bar runs (a bootstrap, a plot, a calibration), so a wait never looks like
a hang, also when the output is a pipe or a log file."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

HEARTBEAT_S = 1.0
"""How often a bar is redrawn while a step runs (s)."""


@contextmanager
def heartbeat(bar: Any, period_s: float = HEARTBEAT_S) -> Iterator[Any]:
    """Redraw ``bar`` (a ``tqdm`` bar) every ``period_s`` seconds until the block ends.

    A disabled bar is left alone. The redraw runs on a daemon thread and takes the bar's own
    lock (``tqdm.refresh``), so the block may ``update`` the bar as usual.

    Raises:
        ValueError: ``period_s`` that is not a positive number.
    """
    if not period_s > 0:
        raise ValueError(f"period_s must be a positive number of seconds, got {period_s!r}")
    if getattr(bar, "disable", True):
        yield bar
        return
    stop = threading.Event()

    def redraw() -> None:
        while not stop.wait(period_s):
            bar.refresh()

    thread = threading.Thread(target=redraw, name="progress-heartbeat", daemon=True)
    thread.start()
    try:
        yield bar
    finally:
        stop.set()
        thread.join()
