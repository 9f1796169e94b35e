"""The tracking error of an episode record (:func:`agents.rollout.run_episode`) and the
statistics over it: what the suites score a policy by and training's tracking curve
(:mod:`train.tracking_curve`) evaluates an agent by.

:mod:`eval.metrics` builds its summaries (path deviation, estimation errors, flat tables) on
these and lists :func:`tracking_error_mm`, :func:`error_stats` and :data:`MM_PER_M` among its
own. Records are SI (metres); every error here is in millimetres and its name says so
(``*_mm``). Statistics are taken over the finite samples only, ``std`` is the population
standard deviation (``ddof=0``) and ``rmse`` is ``sqrt(mean(e**2))``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

MM_PER_M: float = 1000.0
"""Millimetres per metre (errors are reported in mm, records are in m)."""


def record_positions(record: Mapping[str, Any], key: str) -> np.ndarray:
    """A record's column of positions.

    Args:
        record: episode record.
        key: the column (``tip_m``, ``target_m``, an estimate's).

    Returns:
        ``record[key]`` as a float (T, 3) array (m).

    Raises:
        ValueError: the column is missing or not of shape (T, 3).
    """
    if key not in record:
        raise ValueError(f"record has no {key!r} column (keys: {sorted(record)})")
    arr = np.asarray(record[key], dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"record[{key!r}] must have shape (T, 3), got {arr.shape}")
    return arr


def record_steps(record: Mapping[str, Any]) -> int:
    """Number of steps T of a record (from ``tip_m``)."""
    return record_positions(record, "tip_m").shape[0]


def record_cycles(record: Mapping[str, Any]) -> np.ndarray:
    """The 0-based path cycle of each step as integers (T,); zeros when the record has no
    ``cycle``.

    Raises:
        ValueError: ``cycle`` is not of shape (T,) or holds non-integers.
    """
    t = record_steps(record)
    if "cycle" not in record:
        return np.zeros(t, dtype=int)
    cyc = np.asarray(record["cycle"])
    if cyc.shape != (t,):
        raise ValueError(f"record['cycle'] must have shape ({t},), got {cyc.shape}")
    if cyc.size and not np.all(np.equal(np.mod(cyc, 1), 0)):
        raise ValueError("record['cycle'] must hold integers")
    return cyc.astype(int)


def distance_mm(a_m: np.ndarray, b_m: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean distance in mm between two (T, 3) arrays in m."""
    return np.linalg.norm(a_m - b_m, axis=1) * MM_PER_M


def tracking_error_mm(record: Mapping[str, Any]) -> np.ndarray:
    """Tracking error per step: distance from the target to the tip (mm).

    ``e[t] = |target_m[t] - tip_m[t]| * 1000``: the target presented at step
    ``t`` against the ground-truth tip after that step, as in Wang et al.
    2023 ("distance between the current target and the actual end-effector").

    Args:
        record: Episode record with ``target_m`` and ``tip_m`` (T, 3), metres.

    Returns:
        Array of shape (T,) in millimetres.

    Raises:
        ValueError: If a column is missing or the shapes disagree.
    """
    target = record_positions(record, "target_m")
    tip = record_positions(record, "tip_m")
    if target.shape != tip.shape:
        raise ValueError(
            f"record['target_m'] {target.shape} and record['tip_m'] {tip.shape} differ in shape"
        )
    return distance_mm(target, tip)


def error_stats(errors_mm: np.ndarray) -> dict[str, float]:
    """Mean, std, max and RMSE of an error series (mm), over finite samples.

    Args:
        errors_mm: Errors in millimetres, any shape (flattened).

    Returns:
        ``{"mean_mm", "std_mm", "max_mm", "rmse_mm", "n"}``; ``std`` is the
        population standard deviation; ``n`` is the number of finite samples
        used.  With no finite sample the statistics are NaN and ``n`` is 0.
    """
    e = np.asarray(errors_mm, dtype=float).ravel()
    e = e[np.isfinite(e)]
    if e.size == 0:
        return {"mean_mm": math.nan, "std_mm": math.nan, "max_mm": math.nan,
                "rmse_mm": math.nan, "n": 0}
    return {
        "mean_mm": float(np.mean(e)),
        "std_mm": float(np.std(e)),
        "max_mm": float(np.max(e)),
        "rmse_mm": float(np.sqrt(np.mean(e * e))),
        "n": int(e.size),
    }


def last_cycle_error_mm(record: Mapping[str, Any]) -> float:
    """Mean tracking error over the record's last path cycle (mm): the suites' score (the last
    entry of :func:`eval.metrics.summarize`'s per-cycle tracking means).

    Args:
        record: Episode record with ``target_m``, ``tip_m`` and optionally ``cycle``.

    Returns:
        The mean of :func:`tracking_error_mm` over the steps of the highest cycle, over finite
        samples (NaN with none).

    Raises:
        ValueError: a column is missing or malformed.
    """
    cycles = record_cycles(record)
    last = [int(c) for c in np.unique(cycles)][-1]
    return float(error_stats(tracking_error_mm(record)[cycles == last])["mean_mm"])
