"""The pneumatic supply's lag: several updates at once are the updates one by one, bit for bit,
and follow the exact first-order solution."""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.robots.pneumatics import PneumaticSupply


@pytest.mark.parametrize("updates", [0, 1, 5, 13])
def test_advance_many_is_advance_one_by_one(updates: int) -> None:
    spec = get_preset("zhao2021")
    one, many = PneumaticSupply(spec), PneumaticSupply(spec)
    command = spec.p_pre_pa + np.linspace(0.1, 0.9, spec.n_chambers) * (spec.p_max_pa
                                                                          - spec.p_pre_pa)
    for supply in (one, many):
        supply.set_time_constant_scale(1.3)
        supply.command(command)
    expected = [one.advance(0.01).copy() for _ in range(updates)]
    got = many.advance_many(0.01, updates)
    assert got.shape == (updates, spec.n_chambers)
    assert np.array_equal(got, np.reshape(expected, (updates, spec.n_chambers)))
    assert np.array_equal(many.pressure_pa, one.pressure_pa)
    # the exact lag: the gap to the command shrinks by exp(-t / tau)
    tau = spec.pneumatic_time_constant_s * 1.3
    np.testing.assert_allclose(many.pressure_pa - command,
                               (spec.p_pre_pa - command) * math.exp(-0.01 * updates / tau),
                               rtol=1e-9, atol=1e-6)
