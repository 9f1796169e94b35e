"""One compute thread per numerical library, for results that do not depend on where they run.

A sum split over threads rounds differently from the same sum on one thread: a network trained,
or a least-squares fit solved, with two BLAS or torch threads ends a few ulps away from the
one-thread result, and a closed loop driven by it drifts further from there (lwpr_rwr and
hybrid_gpr suite records differed in the tenth digit between a pool worker with every core and a
Ray task started with ``OMP_NUM_THREADS=1``). :func:`one_compute_thread` runs a block with BLAS,
OpenMP and torch on one thread each and restores them after; the suite runs every cell in it
(:mod:`eval.suite`), and the calibration cache computes every value in it
(:func:`soft_gym.sensing.calibration_cache.cached`), so a cached calibration is the same whoever
builds it first: a test, a suite worker or a multi-threaded training process.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from threadpoolctl import threadpool_limits


@contextlib.contextmanager
def one_compute_thread() -> Iterator[None]:
    """Run the block with BLAS, OpenMP and torch on one thread each, restoring them after."""
    import torch  # not at the top: +1.6 s for every command that never needs it (-X importtime)

    torch_threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        torch.set_num_threads(torch_threads)


__all__ = ["one_compute_thread"]
