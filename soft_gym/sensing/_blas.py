"""One BLAS thread for the sensing pipeline's small matrices.

The sensing pipeline's linear algebra is small: F-emp's OS-ELM (:mod:`soft_gym.papers.wang2023.elm`)
updates a 200 x 200 information matrix every step and refactors it by Cholesky every 50.
OpenBLAS (bundled with numpy, SciPy and OpenCV) splits even these over all its threads, and on a
busy machine (several simulators, a learner, the environment workers of a vectorised env) a split
call waits for a thread that has no core: a 200 x 200 Cholesky, 0.5 ms on one thread, was seen
to take 160-780 ms with two threads on two busy cores, and the fused env ran about 20 % slower
for it. One thread also makes the results independent of the machine's core count (the same
numbers as a single-threaded run).

:func:`one_blas_thread` decorates a function so that it runs with every BLAS loaded in the
process on one thread (``threadpoolctl``, about 8 us a call), each library's own setting
restored afterwards (``OSELM.fit`` and ``OSELM.update``).
"""

from __future__ import annotations

import functools
from typing import Callable, TypeVar

from threadpoolctl import ThreadpoolController

_F = TypeVar("_F", bound=Callable)

_controller: ThreadpoolController | None = None


def _blas_controller() -> ThreadpoolController:
    """The process's thread-pool controller, made on first use (when numpy's and SciPy's BLAS
    are loaded)."""
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller


def one_blas_thread(function: _F) -> _F:
    """Decorator: ``function`` runs with every loaded BLAS on one thread."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with _blas_controller().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


__all__ = ["one_blas_thread"]
