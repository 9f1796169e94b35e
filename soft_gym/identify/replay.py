"""A log's commands replayed on a simulated arm: the tip positions the simulator predicts at the
log's sample times."""

from __future__ import annotations

import numpy as np

from soft_gym.engines import FAST_ENGINE, make_simulator
from soft_gym.identify.log import ArmLog
from soft_gym.robots.spec import ArmSpec

SETTLE_S = 1.0
"""How long the simulated arm settles under the log's first command before the first sample (s)."""


def replay(spec: ArmSpec, log: ArmLog, engine: str = FAST_ENGINE) -> np.ndarray:
    """Simulate ``log``'s commands on a fresh simulator of ``spec`` and read the tip at its times.

    The arm starts at rest under the first row's command (``sim.reset(pressure_pa=...,
    settle_s=SETTLE_S)``), as a log that starts from a held command does. Row ``i``'s tip is read
    at ``t[i] - t[0]``, then its command is sent and held until the next row's time (stepped to
    the whole physics step nearest that time, so the clock does not drift on uneven logs).

    Args:
        spec: the arm to simulate.
        log: the commands and times to replay.
        engine: an engine name (:data:`soft_gym.engines.ENGINES`).

    Returns:
        simulated tip positions (m, (n_samples, 3)) in the base frame.
    """
    sim = make_simulator(spec, engine)
    try:
        sim.reset(pressure_pa=log.commands_pa[0], settle_s=SETTLE_S)
        sim.restart_clock()
        times = log.times_s - log.times_s[0]
        tips = np.empty((log.n_samples, 3))
        for row in range(log.n_samples):
            tips[row] = sim.tip_pose()[0]
            if row + 1 < log.n_samples:
                sim.set_pressures(log.commands_pa[row])
                remaining = times[row + 1] - sim.time_s
                if remaining > 0.5 * sim.physics_dt_s:
                    sim.step_physics(remaining)
        return tips
    finally:
        sim.close()
