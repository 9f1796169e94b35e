"""The part of an arm simulator that does not depend on the engine (docs/architecture.md, "The
simulator interface"): both :class:`~soft_gym.engines.pybullet.ArmSimulator` and
:class:`~soft_gym.engines.mujoco.MujocoArmSimulator` inherit it.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import as_finite_array
from soft_gym.engines.held_loads import require_load_capacity
from soft_gym.robots.chain import weightless_equilibrium
from soft_gym.robots.pneumatics import effective_pressure_pa


class CommonArm:
    """What every engine's simulator does the same way: the pneumatic supply's commands and
    pressures, the scenario elements, the clock and the links' rest lengths.

    The engine sets ``spec``, ``chain``, ``supply``, ``gravity``, ``loads`` and ``time_s``
    (and, for volume actuation, ``_readout`` and ``_pressure_to_rest[_nominal]``), and defines
    ``_restart_substeps`` (count substeps from 0, drop its per-substep read-out caches).
    """

    def set_pressures(self, pressures_pa: np.ndarray) -> None:
        """Command chamber pressures (Pa, gauge), shape (n_chambers,), each in [0, p_max].

        Raises:
            ValueError: on a volume-actuated arm (``spec.cylinders`` set), which takes strokes
                (:meth:`set_cylinder_strokes`).
        """
        self.supply.command(pressures_pa)

    def set_cylinder_strokes(self, strokes_m: np.ndarray) -> None:
        """Command the cylinders' strokes (m), shape (n_chambers,), each in
        ``[0, spec.cylinders.max_stroke_m]``, on a volume-actuated arm (ho2018 Section 3.1;
        :class:`~soft_gym.robots.pneumatics.VolumeSupply`).

        Raises:
            ValueError: on a pressure-actuated arm (``spec.cylinders`` is ``None``), or strokes
                of the wrong shape, not finite or outside the cylinders' range.
        """
        if self.spec.cylinders is None:
            raise ValueError(
                f"strokes_m cannot be commanded on the pressure-actuated {self.spec.name} arm "
                f"(ArmSpec.cylinders is None): command pressures with set_pressures(pressures_pa)")
        self.supply.command_strokes(strokes_m)

    @property
    def cylinder_strokes_m(self) -> np.ndarray | None:
        """The cylinders' current strokes (m), ``None`` on a pressure-actuated arm."""
        if self.spec.cylinders is None:
            return None
        return self.supply.stroke_m.copy()

    def _rest_chamber_lengths(self) -> np.ndarray:
        """Every chamber's length (m) with the arm at rest at its pre-pressure (the weightless
        equilibrium of the nominal arm): where volume actuation's gas charge is set."""
        effective = effective_pressure_pa(self.spec, self.spec.p_pre_pa)
        q = weightless_equilibrium(self._pressure_to_rest_nominal @ effective, self.chain)
        return self._readout.chamber_lengths(q)

    def _volume_start(self, pressure_pa: np.ndarray | None) -> np.ndarray:
        """Volume actuation's reset: the joint positions to start from (the weightless
        equilibrium of ``pressure_pa``, Pa, default the pre-pressure) with the strokes that hold
        those pressures there (the rest stroke 0 by default)."""
        supply = self.supply
        pressure = (self.spec.p_pre_pa if pressure_pa is None
                    else supply.check_pressures(pressure_pa))
        effective = effective_pressure_pa(self.spec, pressure)
        start = weightless_equilibrium(self._pressure_to_rest @ effective, self.chain)
        supply.reset(pressure_pa, self._readout.chamber_lengths(start))
        return start

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
