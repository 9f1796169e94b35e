"""Fixtures shared by the physics and sensor tests."""

from __future__ import annotations

import pytest

from soft_gym.sim import ArmSimulator


@pytest.fixture
def make_sim():
    """Factory of simulators (``gravity=False`` switches gravity off), all closed after the test."""
    made = []

    def factory(spec, gravity: bool = True) -> ArmSimulator:
        sim = ArmSimulator(spec)
        if not gravity:
            sim.set_gravity([0.0, 0.0, 0.0])
        made.append(sim)
        return sim

    yield factory
    for sim in made:
        sim.close()
