"""Advancing MuJoCo arms: one arm (:meth:`MujocoArmSimulator.step_physics
<soft_gym.engines.mujoco.simulator.MujocoArmSimulator.step_physics>`) or a batch of them in
lockstep (:func:`step_arms`), by the same code, so that an arm stepped in a batch moves bit for bit
as it does alone.

Every ``actuation_update_s`` (10 ms) the loads are updated (arms that carry any), the pneumatic
lag advances and the pressure moments are formed for all arms at once (NumPy over the batch);
then each arm's substeps until the next update run in C (``mj_step`` with ``nstep``), the first
with the mean of the old and the new applied forces (see :func:`write_forces`). With an
``executor`` (a thread pool), the arms' substeps run on its threads: ``mj_step`` releases the
GIL (docs/architecture.md, "The MuJoCo engine").
"""

from __future__ import annotations

from concurrent.futures import Executor
from typing import Protocol, Sequence

import mujoco
import numpy as np

from soft_gym.robots.pneumatics import BoreGrowth, PneumaticSupply, VolumeSupply
from soft_gym.robots.spec import ArmSpec


class MujocoArm(Protocol):
    """What :func:`step_arms` reads and writes of an arm
    (:class:`~soft_gym.engines.mujoco.simulator.MujocoArmSimulator`)."""

    spec: ArmSpec
    model: mujoco.MjModel
    data: mujoco.MjData
    supply: PneumaticSupply | VolumeSupply
    loads: list
    physics_dt_s: float
    per_actuation: int      # substeps per actuation update
    actuation_interval_s: float  # per_actuation * physics_dt_s
    substep: int            # substeps since the reset (or the clock's restart)
    time_s: float
    moments: np.ndarray     # (n_chambers, n_dofs) joint force per unit effective pressure
    bore: BoreGrowth        # the chambers' bore growth (effective pressures)
    joint_force: np.ndarray
    joint_force_previous: np.ndarray
    wrench: np.ndarray | None
    wrench_previous: np.ndarray | None
    forces_started: bool
    with_stops: bool
    lockstep_key: tuple     # equal keys: one actuation update serves the arms

    def choose_model(self, lookahead: bool = False, force_stops: bool = False) -> None: ...

    def stop_proximity(self) -> tuple[bool, bool]: ...

    def note_stops_ahead(self, ahead: bool) -> None: ...

    def save_state(self) -> tuple: ...

    def restore_state(self, state: tuple) -> None: ...

    def held_wrench(self) -> np.ndarray | None: ...

    def forget_reads(self) -> None: ...

    def check_within_stops(self) -> None: ...

    def chamber_lengths(self) -> np.ndarray: ...


STOP_LOOKAHEAD_UPDATES = 4
"""An arm moves to its model with the end stops once a joint, at its present speed, could reach
a stop's band within this many actuation updates (see :meth:`MujocoArmSimulator.choose_model
<soft_gym.engines.mujoco.simulator.MujocoArmSimulator.choose_model>`)."""


def pressure_moments(moments: np.ndarray, effective_pa: np.ndarray) -> np.ndarray:
    """Joint forces of the chamber pressures (N m or N per dof): ``sum_c effective_c
    moments[c]``, summed chamber by chamber in a fixed order (so one arm and a batch of arms get
    the same bits).

    Args:
        moments: (n_chambers, n_dofs) joint force per unit effective pressure (N m/Pa or N/Pa).
        effective_pa: (..., n_chambers) effective chamber pressures (Pa).
    """
    # NumPy reduces over an outer axis row by row, in order: the same bits as a loop over the
    # chambers, whatever the batch's shape
    return np.add.reduce(effective_pa[..., :, None] * moments, axis=-2)


def write_forces(sim: MujocoArm, midpoint: bool) -> None:
    """Write ``sim``'s applied forces into its data: the mean of the previous and the current
    ones (``midpoint``, for the first substep after an update), else the current ones.

    Why the mean: MuJoCo's semi-implicit Euler step is the leapfrog scheme with the velocities at
    half steps, so the velocity kick of the substep that starts at an update spans half a substep
    of the old forces and half of the new. Kicking with the new forces alone makes every 10 ms
    change of the pressure moments a first-order error: with the mean, the tip's deviation from a
    4x finer step halves (wang2023 0.29 -> 0.16 mm, zou2022 0.45 -> 0.09 mm at 2.5 and 1.25 ms).
    """
    data = sim.data
    if midpoint:
        data.qfrc_applied[:] = 0.5 * (sim.joint_force_previous + sim.joint_force)
        if sim.wrench is not None or sim.wrench_previous is not None:
            data.xfrc_applied[:] = 0.5 * (_or_zero(sim.wrench_previous, data)
                                          + _or_zero(sim.wrench, data))
        return
    data.qfrc_applied[:] = sim.joint_force
    if sim.wrench is not None or sim.wrench_previous is not None:
        data.xfrc_applied[:] = _or_zero(sim.wrench, data)


def _or_zero(wrench: np.ndarray | None, data: mujoco.MjData) -> np.ndarray:
    return np.zeros_like(data.xfrc_applied) if wrench is None else wrench


def _arm_block(sim: MujocoArm, pieces: int, at_update: bool) -> None:
    """Run ``pieces`` substeps of one arm; the forces are written first at an update."""
    step = mujoco.mj_step
    remaining = pieces
    if at_update and sim.forces_started:
        write_forces(sim, midpoint=True)
        step(sim.model, sim.data)
        remaining -= 1
    if at_update:
        write_forces(sim, midpoint=False)
        sim.forces_started = True
    if remaining:
        step(sim.model, sim.data, remaining)


def _substeps(sims: Sequence[MujocoArm], pieces: int, at_update: bool) -> None:
    """Run ``pieces`` substeps of every arm (one thread's share). An arm on the model without
    the stops' tendons that ends the block near a stop runs the block again on the full model,
    from the state it started from."""
    for sim in sims:
        if sim.with_stops:
            _arm_block(sim, pieces, at_update)
            continue
        start, started = sim.save_state(), sim.forces_started
        _arm_block(sim, pieces, at_update)
        now, ahead = sim.stop_proximity()
        if now:
            sim.restore_state(start)
            sim.forces_started = started
            sim.choose_model(force_stops=True)
            _arm_block(sim, pieces, at_update)
        else:  # the next update's choice of model, from the same pass over the joints
            sim.note_stops_ahead(ahead)


def _advance_actuation(sims: Sequence[MujocoArm]) -> None:
    """One actuation update of every arm: loads, the pneumatic lag (exactly integrated over the
    update, ``p <- p + (p_cmd - p) (1 - exp(-dt / tau))``; with volume actuation the strokes'
    lag and the gas law at the chambers' present lengths,
    :class:`~soft_gym.robots.pneumatics.VolumeSupply`), the pressure moments and the held
    forces."""
    first = sims[0]
    interval_s = first.actuation_interval_s
    for sim in sims:
        if sim.loads:
            now_s = sim.substep * sim.physics_dt_s
            for load in sim.loads:
                load.update(sim, now_s)
    # each supply advances its own lag (PneumaticSupply / VolumeSupply.advance, as the PyBullet
    # arm's); lockstep arms share the rest of the update
    if first.spec.cylinders is not None:
        pressure = np.array([sim.supply.advance(interval_s, sim.chamber_lengths())
                             for sim in sims])
    else:
        pressure = np.array([sim.supply.advance(interval_s) for sim in sims])
    effective = pressure
    if first.bore.grows:
        effective = first.bore.effective(pressure)
    joint = pressure_moments(first.moments, effective)
    for i, sim in enumerate(sims):
        sim.choose_model(lookahead=True)
        sim.joint_force_previous, sim.joint_force = sim.joint_force, joint[i]
        sim.wrench_previous, sim.wrench = sim.wrench, sim.held_wrench()


def _compatible(sims: Sequence[MujocoArm]) -> bool:
    """Whether the arms can be stepped in lockstep: the same actuation (physics step, pressure
    moments, bore growth, pressure limits: ``lockstep_key``), their clocks at the same phase of
    the actuation update."""
    first = sims[0]
    key, phase = first.lockstep_key, first.substep % first.per_actuation
    return all(sim.lockstep_key == key and sim.substep % sim.per_actuation == phase
               for sim in sims)


def step_arms(sims: Sequence[MujocoArm], seconds: float,
              executor: Executor | None = None, n_threads: int = 1) -> None:
    """Advance every arm of ``sims`` by ``seconds`` (rounded to whole physics substeps).

    Arms of one spec and step whose clocks are at the same phase of the actuation update move in
    lockstep (their actuation updated together); others are stepped one after another, with the
    same result.

    Args:
        sims: the arms (:class:`~soft_gym.engines.mujoco.simulator.MujocoArmSimulator`).
        seconds: time to advance (s), finite and >= 0.
        executor: a thread pool to run the arms' substeps on, ``n_threads`` shares at once;
            ``None`` runs them on this thread.

    Raises:
        ValueError: a ``seconds`` that is not a finite number >= 0.
        PhysicsDivergedError: an arm left the physical range (a joint far past its end stop).
    """
    seconds = float(seconds)
    if not np.isfinite(seconds) or seconds < 0:
        raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
    if not sims:
        return
    if len(sims) > 1 and not _compatible(sims):
        for sim in sims:
            step_arms([sim], seconds)
        return
    first = sims[0]
    total = int(round(seconds / first.physics_dt_s))
    shares = ([sims] if executor is None or n_threads < 2 or len(sims) < 2
              else [sims[k::n_threads] for k in range(n_threads)])
    done = 0
    while done < total:
        phase = first.substep % first.per_actuation
        block = min(total - done, first.per_actuation - phase)
        at_update = phase == 0
        if at_update:
            _advance_actuation(sims)
        if len(shares) == 1:
            _substeps(shares[0], block, at_update)
        else:
            list(executor.map(_substeps, shares, [block] * len(shares),
                              [at_update] * len(shares)))
        for sim in sims:
            sim.substep += block
        done += block
    for sim in sims:
        sim.time_s = sim.substep * sim.physics_dt_s
        sim.forget_reads()
        sim.check_within_stops()
