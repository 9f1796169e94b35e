"""Per-preset sets of reachable tip positions, found by forward-simulating random pressures.

Built once per process and arm (keyed by the ArmSpec) on a private simulator and reused by every
environment: the reach task draws its targets from them and the track task places its paths.
"""

from __future__ import annotations

import numpy as np

from soft_gym.engines import make_simulator
from soft_gym.robots.spec import ArmSpec

_CACHE: dict[ArmSpec, np.ndarray] = {}


def reachable_tips(spec: ArmSpec, n_samples: int = 96, hold_s: float = 0.4,
                   seed: int = 12345) -> np.ndarray:
    """Tip positions (m, base frame), shape (n_samples, 3), reached under random pressures.

    The arm walks through ``n_samples`` uniform random pressure commands, holding each for
    ``hold_s``; the tip position at the end of each hold is recorded. The walk is seeded, so the
    set is the same in every process.
    """
    key = spec
    if key not in _CACHE:
        sim = make_simulator(spec)
        rng = np.random.default_rng(seed)
        sim.reset(settle_s=0.3)
        low, high = spec.p_pre_pa, spec.p_max_pa
        tips = np.empty((n_samples, 3))
        for i in range(n_samples):
            sim.set_pressures(low + rng.uniform(0, 1, spec.n_chambers) * (high - low))
            sim.step_physics(hold_s)
            tips[i] = sim.tip_pose()[0]
        sim.close()
        _CACHE[key] = tips
    return _CACHE[key].copy()
