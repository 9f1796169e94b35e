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

An arm whose forces are known before its substeps run (``forces_known_ahead``: pressure
actuation, no loads, no held forces, far from its stops) is stepped open loop instead: the lag
and the moments of every update of the call are formed first, and all its substeps run in one
call of MuJoCo's ``rollout`` with the applied forces of each substep (:func:`_step_open_loop`);
the same arithmetic in the same order, so the same trajectory bit for bit. Should a joint enter
a stop's band on the way, the arm is put back and stepped the ordinary way.
"""

from __future__ import annotations

import os
from concurrent.futures import Executor
from typing import Protocol, Sequence

import mujoco
import numpy as np
from mujoco import rollout

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
    forces_known_ahead: bool  # the open-loop stepping applies

    def in_stop_band(self, positions: np.ndarray) -> bool: ...

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


_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
"""The state ``rollout`` starts each arm from and returns after every substep (time first, then
the joint positions)."""
_APPLIED = int(mujoco.mjtState.mjSTATE_QFRC_APPLIED)
"""What ``rollout``'s control rows set before each substep: the applied joint forces."""
_ROLLOUTS: dict[tuple[int, int], rollout.Rollout] = {}
"""One MuJoCo rollout pool per process and thread count (0: on the calling thread), kept: a
forked process (a subprocess env worker) makes its own, as threads do not survive a fork."""


_SCHEDULES: dict[tuple[int, int, int], tuple[int, np.ndarray, np.ndarray, np.ndarray]] = {}
""":func:`_schedule` by (phase of the actuation update, substeps per update, substeps)."""


def _schedule(phase: int, per_actuation: int, total: int
              ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """How ``total`` substeps starting ``phase`` substeps after an actuation update meet the
    updates: (updates, each substep's row of the force table, the substeps that start an
    update, the updates they start). Row 0 of the force table is the force applied before the
    first update, row ``k + 1`` the force of update ``k``."""
    key = (phase, per_actuation, total)
    if key not in _SCHEDULES:
        since_start = np.arange(total) + phase
        rows = since_start // per_actuation + (1 if phase == 0 else 0)
        starts = np.flatnonzero(since_start % per_actuation == 0)
        _SCHEDULES[key] = (len(starts), rows, starts, rows[starts] - 1)
    return _SCHEDULES[key]


def _step_open_loop(sims: Sequence[MujocoArm], total: int, n_threads: int) -> list[MujocoArm]:
    """Run ``total`` substeps of lockstep arms whose forces are known ahead in one ``rollout``
    call: every update's lag and moments first (as :func:`_advance_actuation`), then each
    substep's applied forces (as :func:`write_forces`: the mean of the old and the new forces on
    the first substep after an update, once forces have been applied since the reset). Returns
    the arms in which a joint entered a stop's band, put back as they were, for the ordinary
    stepping."""
    first = sims[0]
    updates, rows, starts, started_updates = _schedule(first.substep % first.per_actuation,
                                                       first.per_actuation, total)
    model = first.model
    start = np.empty((len(sims), mujoco.mj_stateSize(model, _STATE)))
    for i, sim in enumerate(sims):
        mujoco.mj_getState(sim.model, sim.data, start[i], _STATE)
    kept = [(sim.supply.pressure_pa, sim.joint_force, sim.joint_force_previous,
             sim.forces_started) for sim in sims]
    # the force table (arms, 1 + updates, dofs): what is applied now, then each update's moments
    table = np.empty((len(sims), 1 + updates, model.nv))
    for i, sim in enumerate(sims):
        table[i, 0] = sim.data.qfrc_applied
    if updates:
        pressure = np.stack([sim.supply.advance_many(first.actuation_interval_s, updates)
                             for sim in sims], axis=1)        # (updates, arms, chambers)
        effective = first.bore.effective(pressure) if first.bore.grows else pressure
        table[:, 1:] = np.swapaxes(pressure_moments(first.moments, effective), 0, 1)
    forces = table[:, rows]
    if updates:
        # the first substep of each update: the mean of the forces before and after it (the
        # forces before the first update of the call: the arm's last update's)
        before = table[:, started_updates]
        before[:, 0] = [sim.joint_force for sim in sims]
        midpoint = 0.5 * (before + table[:, started_updates + 1])
        for i, sim in enumerate(sims):
            mean_from = 0 if sim.forces_started else 1
            forces[i, starts[mean_from:]] = midpoint[i, mean_from:]
            sim.joint_force_previous = before[i, -1]
            sim.joint_force, sim.forces_started = table[i, -1], True
    states = np.empty((len(sims), total, start.shape[1]))
    threads = min(n_threads, len(sims)) if n_threads > 1 and len(sims) > 1 else 0
    key = (os.getpid(), threads)
    pool = _ROLLOUTS.get(key)
    if pool is None:
        pool = _ROLLOUTS[key] = rollout.Rollout(nthread=threads)
    # the arms' own data serve as the pool's scratch (one per thread); each arm is given its
    # last state afterwards (alone, its data ends there already)
    pool.rollout([sim.model for sim in sims], [sim.data for sim in sims[:max(threads, 1)]],
                 start, forces, control_spec=_APPLIED, skip_checks=True, nstep=total,
                 state=states, sensordata=np.empty((len(sims), total, 0)))
    nq, nv = model.nq, model.nv
    back = []
    for i, sim in enumerate(sims):
        if len(sims) > 1:
            mujoco.mj_setState(sim.model, sim.data, states[i, -1], _STATE)
        # as after update by update: the latest update's force (not a first substep's mean)
        sim.data.qfrc_applied[:] = table[i, rows[-1]]
        if sim.in_stop_band(states[i, :, 1:1 + nq]):
            pressure_pa, force, force_previous, started = kept[i]
            sim.restore_state((start[i, 0], start[i, 1:1 + nq], start[i, 1 + nq:1 + nq + nv]))
            sim.data.qfrc_applied[:] = table[i, 0]
            sim.supply.pressure_pa = pressure_pa
            sim.joint_force, sim.joint_force_previous = force, force_previous
            sim.forces_started = started
            back.append(sim)
        else:
            sim.substep += total
    return back


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
    total = int(round(seconds / sims[0].physics_dt_s))
    ahead = [sim for sim in sims if total and sim.forces_known_ahead]
    others = [sim for sim in sims if not (total and sim.forces_known_ahead)]
    if ahead:  # the arms a stop's band turned back join the others
        others += _step_open_loop(ahead, total, n_threads if executor is not None else 1)
    _step_blocks(others, total, executor, n_threads)
    for sim in sims:
        sim.time_s = sim.substep * sim.physics_dt_s
        sim.forget_reads()
        sim.check_within_stops()


def _step_blocks(sims: Sequence[MujocoArm], total: int, executor: Executor | None,
                 n_threads: int) -> None:
    """Run ``total`` substeps of lockstep arms block by block, an actuation update (in Python)
    before each block that starts at one."""
    if not sims:
        return
    first = sims[0]
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
