"""Drive a simulated arm to a tip position before an episode starts (point-to-point tasks).

zhao2021's point-to-point experiments start the arm at a given tip position (Section V-B: from
(40, 20, 300) to (-50, 70, 210) mm). The env reaches such a start during ``reset``, outside the
episode's steps, by solving ``tip(p) = start`` for the chamber pressures ``p`` on the simulator
itself, with the episode's loads in place:

* ``tip(p)`` is the tip position after holding ``p`` for ``hold_s`` (a quasi-static equilibrium);
* the search starts from the closest of ``n_candidates`` fixed pressure patterns (half-way into
  every chamber's range, then a seeded uniform sample), so far-bent starts are found too;
* the Jacobian ``d tip / d p`` is estimated there once by finite differences, then updated by
  Broyden's rank-one rule after every trial;
* each trial is a damped least-squares (Levenberg-Marquardt) step of the Jacobian, clipped to the
  chambers' range ``[p_pre, p_max]``;
* it stops when the tip is within ``tolerance_m`` or after ``max_trials``.

It reads the simulator's true tip: a set-up step that no controller sees. :func:`follow_path`
continues the same search along a sequence of points (how far a path lies from the reachable
set, :func:`soft_gym.procedures.workspace.reach_distances`).
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import as_finite_array, as_points, require_integer, require_positive
from soft_gym.procedures.static_reach import closest_reach
from soft_gym.robots.statics import StaticArm
from soft_gym.scenarios.loads import SwayingMass
from soft_gym.simulator import Simulator


def drive_tip_to(sim: Simulator, start_m: np.ndarray, hold_s: float = 1.0, tolerance_m: float = 1e-3,
                 max_trials: int = 40, damping: float = 1e-3,
                 n_candidates: int = 16) -> tuple[np.ndarray, float]:
    """Find and hold chamber pressures that put the tip at ``start_m`` (m, base frame).

    Args:
        sim: the simulator (its loads stay as they are).
        start_m: wanted tip position (m).
        hold_s: time each trial pressure is held before the tip is read (s).
        tolerance_m: distance at which the search stops (m).
        max_trials: most trial pressures after the Jacobian's estimate.
        damping: Levenberg-Marquardt damping, relative to the Jacobian's largest singular
            value squared.
        n_candidates: starting patterns tried before the search (the same ones every call).

    Returns:
        ``(pressures_pa, distance_m)``: the pressures now held and the tip's distance from
        ``start_m`` (m) at the end.
    """
    start_m = as_finite_array("start_m", start_m, shape=(3,))
    hold_s = require_positive("hold_s", hold_s)
    tolerance_m = require_positive("tolerance_m", tolerance_m)
    max_trials = require_integer("max_trials", max_trials, 1)
    n_candidates = require_integer("n_candidates", n_candidates, 1)
    spec = sim.spec
    low, high = spec.p_pre_pa, spec.p_max_pa
    span = high - low

    def settle(fraction: np.ndarray) -> np.ndarray:
        sim.set_pressures(low + fraction * span)
        sim.step_physics(hold_s)
        return sim.tip_pose()[0]

    candidates = np.vstack([np.full(spec.n_chambers, 0.5),
                            np.random.default_rng(0).uniform(0.0, 1.0, (max(n_candidates, 1) - 1,
                                                                        spec.n_chambers))])
    reached = [settle(candidate) for candidate in candidates]
    closest = int(np.argmin([np.linalg.norm(tip - start_m) for tip in reached]))
    fraction, distance = _search_from(settle, start_m, candidates[closest].copy(), tolerance_m,
                                      max_trials, damping)
    if distance > tolerance_m:  # not found: search again from the static arm's answer
        static = _static_start(sim, start_m)
        if static is not None:
            second, second_distance = _search_from(settle, start_m, static, tolerance_m,
                                                   max_trials, damping)
            if second_distance < distance:
                fraction, distance = second, second_distance
            else:
                settle(fraction)
    return low + fraction * span, distance


def _search_from(settle, point: np.ndarray, fraction: np.ndarray, tolerance_m: float,
                 max_trials: int, damping: float) -> tuple[np.ndarray, float]:
    """The damped search from ``fraction``; the arm is left holding its best trial, whose
    fraction and distance from ``point`` (m) are returned."""
    jacobian, tip = _jacobian(settle, fraction, settle(fraction))
    best_fraction, _, best_distance, tip = _damped_search(settle, point, fraction, tip, jacobian,
                                                          tolerance_m, max_trials, damping)
    if np.linalg.norm(tip - point) > best_distance:  # the arm ended past its best trial
        tip = settle(best_fraction)
    return best_fraction, float(np.linalg.norm(tip - point))


def _static_start(sim: Simulator, point: np.ndarray) -> np.ndarray | None:
    """Chamber fractions (of each chamber's range) that hold the resting arm's tip nearest
    ``point`` with the weight hanging at its tip (tip masses and swaying masses), by the static
    search (:func:`~soft_gym.procedures.static_reach.closest_reach`), kept for the process;
    ``None`` for volume-actuated arms, whose pressures follow the chambers' lengths."""
    spec = sim.spec
    if spec.cylinders is not None:
        return None
    mass = sim.tip_payload_kg + sum(load.mass_kg for load in sim.loads
                                    if isinstance(load, SwayingMass))
    key = (repr(spec), tuple(np.round(point, 9)), round(float(mass), 9))
    if key not in _STATIC_STARTS:
        reach = closest_reach(StaticArm(spec), point, mass)
        low, span = spec.p_pre_pa, spec.p_max_pa - spec.p_pre_pa
        _STATIC_STARTS[key] = np.clip((reach.pressures_pa - low) / span, 0.0, 1.0)
    return _STATIC_STARTS[key].copy()


_STATIC_STARTS: dict[tuple, np.ndarray] = {}
""":func:`_static_start`'s answers in this process, by arm, point and hanging mass."""


def follow_path(sim: Simulator, points_m: np.ndarray, hold_s: float = 1.0,
                tolerance_m: float = 1e-3, max_trials: int = 8, damping: float = 1e-3,
                n_candidates: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Drive the tip through ``points_m`` in order and return, for each, the closest tip found.

    The pressure search of :func:`drive_tip_to`, continued along a path: the first point gets
    the full search (candidate patterns, a finite-difference Jacobian, damped least-squares
    trials); every next point starts from the previous point's pressures and Jacobian and takes
    at most ``max_trials`` damped least-squares trials (Broyden updates between them). A point
    left ``tolerance_m`` or more away gets the Jacobian estimated afresh there and
    ``max_trials`` more trials; if it is still that far, and farther than the previous point
    was, the continuation has lost the path and the point gets the full search afresh, keeping
    the better of the two (a path outside the reachable set, followed at a steady or shrinking
    distance, is not searched afresh at every point). Each trial holds its pressures for ``hold_s``, so
    every tip read is a quasi-static equilibrium of the arm as the simulator holds it (its loads
    stay as they are).

    Args:
        sim: the simulator (a private one: the search moves its arm).
        points_m: wanted tip positions (m, base frame), shape (n, 3), in the order to visit
            them (consecutive points close together make the continuation cheap).
        hold_s: time each trial pressure is held before the tip is read (s).
        tolerance_m: distance at which the search for a point stops (m).
        max_trials: most continuation trials per point before the full search.
        damping, n_candidates: as for :func:`drive_tip_to`.

    Returns:
        ``(pressures_pa, distances_m)``: for every point the pressures (Pa, shape (n,
        n_chambers)) whose held tip came closest to it, and that tip's distance from it (m,
        shape (n,)).

    Raises:
        ValueError: ``points_m`` not finite points of shape (n >= 1, 3), or a bad setting.
    """
    points = as_points("points_m", points_m)
    hold_s = require_positive("hold_s", hold_s)
    tolerance_m = require_positive("tolerance_m", tolerance_m)
    max_trials = require_integer("max_trials", max_trials, 1)
    spec = sim.spec
    low, span = spec.p_pre_pa, spec.p_max_pa - spec.p_pre_pa
    pressures = np.empty((len(points), spec.n_chambers))
    distances = np.empty(len(points))

    def settle(fraction: np.ndarray) -> np.ndarray:
        sim.set_pressures(low + fraction * span)
        sim.step_physics(hold_s)
        return sim.tip_pose()[0]

    def restart(point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        found, distance = drive_tip_to(sim, point, hold_s=hold_s, tolerance_m=tolerance_m,
                                       damping=damping, n_candidates=n_candidates)
        fraction = (found - low) / span
        return fraction, sim.tip_pose()[0], _jacobian(settle, fraction, sim.tip_pose()[0])[0], \
            distance

    fraction, tip, jacobian, _ = restart(points[0])
    tip = settle(fraction)
    previous = 0.0
    for k, point in enumerate(points):
        fraction, tip, distance, _ = _damped_search(settle, point, fraction, tip, jacobian,
                                                    tolerance_m, max_trials, damping)
        if distance >= tolerance_m:  # a stale Jacobian: estimate it afresh here and go on
            tip = settle(fraction)
            jacobian = _jacobian(settle, fraction, tip)[0]
            fraction, tip, distance, _ = _damped_search(settle, point, fraction, tip,
                                                        jacobian, tolerance_m, max_trials,
                                                        damping)
        if distance >= tolerance_m and distance > previous:  # lost the path: search afresh
            again, again_tip, again_jacobian, again_distance = restart(point)
            if again_distance < distance:
                fraction, tip, jacobian, distance = again, again_tip, again_jacobian, \
                    again_distance
            else:
                tip = settle(fraction)
        pressures[k] = low + fraction * span
        distances[k] = previous = distance
    return pressures, distances


def _jacobian(settle, fraction: np.ndarray, tip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``d tip / d fraction`` (m per unit of the chamber range) by one-sided differences of
    0.1 of the range, probing inwards, away from the limits; the arm is left at ``fraction``,
    whose tip (read again there) is returned with it."""
    probe = 0.1 * np.where(fraction > 0.5, -1.0, 1.0)
    jacobian = np.empty((3, len(fraction)))
    for chamber in range(len(fraction)):
        trial = fraction.copy()
        trial[chamber] += probe[chamber]
        jacobian[:, chamber] = (settle(trial) - tip) / probe[chamber]
    return jacobian, settle(fraction)


def _damped_search(settle, point: np.ndarray, fraction: np.ndarray, tip: np.ndarray,
                   jacobian: np.ndarray, tolerance_m: float, max_trials: int,
                   damping: float) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Damped least-squares trials from ``fraction`` (tip at ``tip``) towards ``point``, the
    Jacobian updated in place by Broyden's rule; returns the best ``(fraction, tip, distance)``
    seen and the tip of the last trial, where the arm is left."""
    best = (float(np.linalg.norm(tip - point)), fraction.copy(), tip.copy())
    for _ in range(max_trials):
        error = point - tip
        if np.linalg.norm(error) < tolerance_m:
            break
        scale = damping * max(np.linalg.norm(jacobian, 2) ** 2, 1e-12)
        step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + scale * np.eye(3), error)
        trial = np.clip(fraction + step, 0.0, 1.0)
        new_tip = settle(trial)
        moved, change = new_tip - tip, trial - fraction
        if change @ change > 1e-12:  # Broyden's update of the Jacobian
            jacobian += np.outer(moved - jacobian @ change, change) / (change @ change)
        fraction, tip = trial, new_tip
        distance = float(np.linalg.norm(tip - point))
        if distance < best[0]:
            best = (distance, fraction.copy(), tip.copy())
    return best[1], best[2], best[0], tip
