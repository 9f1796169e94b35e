"""The part of an arm simulator that does not depend on the engine (docs/architecture.md, "The
simulator interface"): both :class:`~soft_gym.engines.pybullet.ArmSimulator` and
:class:`~soft_gym.engines.mujoco.MujocoArmSimulator` inherit it.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import as_finite_array
from soft_gym.engines.held_loads import require_load_capacity


class CommonArm:
    """What every engine's simulator does the same way: the pneumatic supply's commands and
    pressures, the scenario elements, the clock and the links' rest lengths.

    The engine sets ``spec``, ``chain``, ``supply``, ``gravity``, ``loads`` and ``time_s``, and
    defines ``_restart_substeps`` (count substeps from 0, drop its per-substep read-out
    caches).
    """

    def set_pressures(self, pressures_pa: np.ndarray) -> None:
        """Command chamber pressures (Pa, gauge), shape (n_chambers,), each in [0, p_max]."""
        self.supply.command(pressures_pa)

    def set_time_constant_scale(self, scale: float) -> None:
        """Multiply the pneumatic supply's time constants by ``scale`` (domain randomisation)."""
        self.supply.set_time_constant_scale(scale)

    @property
    def pressures_pa(self) -> np.ndarray:
        """Current chamber pressures (Pa)."""
        return self.supply.pressure_pa.copy()

    @property
    def n_links(self) -> int:
        """Links of the discretised backbone (the arm's links, base to tip)."""
        return len(self.chain.station_link)

    @property
    def link_rest_lengths_m(self) -> np.ndarray:
        """Every link's rest length (m), base to tip, shape (n_links,)."""
        return self.chain.station_rest_length.copy()

    def apply_tip_force(self, force_n: np.ndarray) -> None:
        """Apply a force (N, base frame) at the tip, held until changed (zeros removes it)."""
        force = as_finite_array("force_n", force_n, shape=(3,))
        if np.linalg.norm(force) > self.spec.max_load_n:
            raise ValueError(f"force_n must be at most {self.spec.max_load_n:.3g} N in magnitude "
                             f"on the {self.spec.name} arm (max_load_n), got {force.tolist()}")
        self.set_external_force("tip", -1, force,
                                local_point_m=(0.0, 0.0, self.chain.station_rest_length[-1]),
                                on_body=False)

    def add_load(self, load) -> None:
        """Attach a scenario element; it is updated at the actuation rate.

        Raises:
            ValueError: if the loads together would weigh or push more than the arm bears
                (:attr:`~soft_gym.robots.spec.ArmSpec.max_load_n`).
        """
        require_load_capacity(self.spec, self.loads, load, self.gravity)
        load.attach(self)
        self.loads.append(load)

    def restart_loads(self) -> None:
        """Put every load back to its state at the start of an episode (time 0)."""
        for load in self.loads:
            load.reset(self)
            load.update(self, 0.0)

    def restart_clock(self) -> None:
        """Set the simulated time back to 0 where the arm is (after a settle or a set-up
        motion), so that timed loads and faults count from here."""
        self.time_s = 0.0
        self._restart_substeps()

    def _start_episode(self, settle_s: float) -> None:
        """The end of a reset: the clock and the loads at time 0, then ``settle_s`` (s) of rest
        with the clock restarted after it."""
        self.time_s = 0.0
        self._restart_substeps()
        self.restart_loads()
        if settle_s > 0:
            self.step_physics(settle_s)
            self.restart_clock()

    def _restart_substeps(self) -> None:
        """Count substeps from 0 again and drop the per-substep read-out caches."""
        raise NotImplementedError
