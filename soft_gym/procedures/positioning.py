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

It reads the simulator's true tip: a set-up step that no controller sees.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import as_finite_array, require_integer, require_positive
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
    fraction = candidates[closest].copy()
    probe = 0.1 * np.where(fraction > 0.5, -1.0, 1.0)  # probe inwards, away from the limits
    tip = settle(fraction)
    jacobian = np.empty((3, spec.n_chambers))
    for chamber in range(spec.n_chambers):
        trial = fraction.copy()
        trial[chamber] += probe[chamber]
        jacobian[:, chamber] = (settle(trial) - tip) / probe[chamber]
    tip = settle(fraction)
    best = (np.linalg.norm(tip - start_m), fraction.copy())
    for _ in range(max_trials):
        error = start_m - tip
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
        distance = np.linalg.norm(tip - start_m)
        if distance < best[0]:
            best = (distance, fraction.copy())
    if np.linalg.norm(tip - start_m) > best[0]:
        tip = settle(best[1])
        fraction = best[1]
    return low + fraction * span, float(np.linalg.norm(tip - start_m))
