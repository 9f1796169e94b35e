"""Per-preset sets of reachable tip positions, found by forward-simulating random pressures.

Built once per arm on a private simulator and kept in the calibration cache (in the process and
on disk, :mod:`soft_gym.sensing.calibration_cache`), so every environment reuses it: the reach
task draws its targets from them and the track task places its paths. Built afresh it took
2.5 s on zou2022's arm, which every new process paid when making that arm's env.
:func:`reach_distances` tells how far given points (a track path's targets) lie from what the
arm reaches, by the pressure search of :mod:`soft_gym.procedures.positioning`.
"""

from __future__ import annotations

import numpy as np

from soft_gym._validation import as_points, require_positive
from soft_gym.engines import REFERENCE_ENGINE, make_simulator
from soft_gym.procedures.positioning import follow_path
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensing.calibration_cache import cached

def reachable_tips(spec: ArmSpec, n_samples: int = 96, hold_s: float = 0.4,
                   seed: int = 12345) -> np.ndarray:
    """Tip positions (m, base frame), shape (n_samples, 3), reached under random pressures.

    The arm walks through ``n_samples`` uniform random pressure commands, holding each for
    ``hold_s``; the tip position at the end of each hold is recorded. The walk is seeded, so the
    set is the same in every process.
    """
    def walk() -> np.ndarray:
        sim = make_simulator(spec, REFERENCE_ENGINE)
        rng = np.random.default_rng(seed)
        sim.reset(settle_s=0.3)
        low, high = spec.p_pre_pa, spec.p_max_pa
        tips = np.empty((n_samples, 3))
        for i in range(n_samples):
            sim.set_pressures(low + rng.uniform(0, 1, spec.n_chambers) * (high - low))
            sim.step_physics(hold_s)
            tips[i] = sim.tip_pose()[0]
        sim.close()
        return tips

    parts = {"what": "reachable tips", "arm": repr(spec), "engine": REFERENCE_ENGINE,
             "n_samples": int(n_samples), "hold_s": float(hold_s), "seed": int(seed)}
    return cached(parts, walk)


def reach_distances(spec: ArmSpec, points_m: np.ndarray, hold_s: float = 1.0,
                    tolerance_m: float = 1e-3) -> np.ndarray:
    """Distance (m) from each point to the closest tip the pressure search finds for it on the
    unloaded arm: a measure of how far the points lie outside the reachable set.

    A private reference-engine (PyBullet) simulator of ``spec``, rested 0.3 s, is driven
    through ``points_m`` in order by :func:`~soft_gym.procedures.positioning.follow_path` (each
    trial pressure held ``hold_s``, the search for a point stopping within ``tolerance_m``).
    A point the arm reaches gets a distance below ``tolerance_m`` (or a little above, where the
    search stalls); one outside the reachable set at least its distance from that set (the
    search may stop short of the closest reachable tip, so more far from it).

    Args:
        spec: the arm.
        points_m: points (m, base frame), shape (n, 3); consecutive points close together
            (a path's targets) make the search cheap.
        hold_s: time each trial pressure is held (s).
        tolerance_m: distance at which the search for a point stops (m).

    Returns:
        Distances (m), shape (n,).

    Raises:
        ValueError: ``points_m`` not of shape (n >= 1, 3) or not finite, or a bad setting.
    """
    points = as_points("points_m", points_m)
    hold_s = require_positive("hold_s", hold_s)
    tolerance_m = require_positive("tolerance_m", tolerance_m)
    sim = make_simulator(spec, REFERENCE_ENGINE)
    try:
        sim.reset(settle_s=0.3)
        return follow_path(sim, points, hold_s=hold_s, tolerance_m=tolerance_m)[1]
    finally:
        sim.close()
