"""Fixtures shared by the physics and sensor tests."""

from __future__ import annotations

import pytest

from soft_gym.engines import make_simulator
from soft_gym.simulator import Simulator


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
