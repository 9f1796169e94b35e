"""Fixtures shared by the physics and sensor tests, and one thread per numerical library.

The test process and the processes it starts (spawned run workers, the zoo's trainer) run
OpenMP, OpenBLAS, MKL and torch on one thread each unless the environment says otherwise: the
tests' matrices and networks are small, and on two busy cores a call split over two threads
waits for a thread that has no core (the ho2018 varying-load experiment took 44 s with two
threads, 27.5 s with one, the same numbers; soft_gym/sensing/_blas.py does the same for
the sensing pipeline).
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from soft_gym.engines import make_simulator  # noqa: E402
from soft_gym.simulator import Simulator  # noqa: E402

if os.environ["OMP_NUM_THREADS"] == "1":
    threadpool_limits(1)  # a library loaded before the variables were read


@pytest.fixture
def engine() -> str:
    """The engine :func:`make_sim` builds (a module may parametrise it over several)."""
    return "pybullet"


@pytest.fixture
def make_sim(engine):
    """Factory of simulators in ``engine`` (``gravity=False`` switches gravity off), all closed
    after the test."""
    made = []

    def factory(spec, gravity: bool = True) -> Simulator:
        sim = make_simulator(spec, engine)
        if not gravity:
            sim.set_gravity([0.0, 0.0, 0.0])
        made.append(sim)
        return sim

    yield factory
    for sim in made:
        sim.close()


RAY_REASON = 'Ray (with Tune) is an optional extra: pip install "soft-arm-gym[ray]"'


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray with two CPUs for a test module (started once, shut down after; one started
    by someone else is left running)."""
    ray = pytest.importorskip("ray", reason=RAY_REASON)
    pytest.importorskip("ray.tune", reason=RAY_REASON)
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False)
    yield ray
    if started:
        ray.shutdown()
