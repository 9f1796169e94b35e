"""Benchmark metrics: tracking error, path deviation, estimation error, tables.

The metrics follow docs/architecture.md, "Tasks and metrics", and the tables of Wang et al. 2023
(Tables I-II): tracking error (distance from the current target to the tip),
path deviation (distance from the tip to the closest point of the path), each
reported as mean +- std and max, overall and per path cycle, and the
improvement ``(e_m - e_h) / e_m`` of a controller over the CC model-based
baseline.

Episode record
--------------
One episode is a ``dict`` of numpy arrays over ``T`` control steps, SI units:

========================= ========= =============================================
key                       shape     meaning
========================= ========= =============================================
``time_s``                (T,)      time of each step (s)
``target_m``              (T, 3)    target presented at each step (m)
``tip_m``                 (T, 3)    ground-truth tip after the step (m)
``feedback_m``            (T, 3)    pose the controller saw (m)
``action``                (T, n)    action in [-1, 1]
``pressure_pa``           (T, n)    chamber pressures (Pa)
``cycle``                 (T,)      0-based path cycle of each step (all 0 for reach)
``polyline_m`` (optional) (P, 3)    dense closed path, for path deviation (m)
``camera_m`` ... (opt.)   (T, 3)    pose estimates: ``camera_m``, ``femp_m``,
                                    ``fused_m``, ``em_m`` (m)
``reprojection_error_px`` (T,)      camera quality e_S (px), optional
========================= ========= =============================================

Only ``target_m`` and ``tip_m`` are needed for the tracking metrics; a record
without ``cycle`` counts as a single cycle.

Units: records are SI (metres); every output of this module is in
millimetres and its name says so (``*_mm``).

The per-step tracking error (:func:`tracking_error_mm`), the statistics of an
error series (:func:`error_stats`) and :data:`MM_PER_M` are defined in
:mod:`agents.tracking_error`, below evaluation and training (training's
tracking curve scores agents with them), and are part of this module's API.

Statistics
----------
Every statistic is taken over the finite samples only (a step whose tip or
target is NaN is left out and the ``n`` entry says how many samples were
used); with no finite sample every statistic is NaN.  ``std`` is the
population standard deviation (``ddof=0``), as for ``numpy.std``, and
``rmse`` is ``sqrt(mean(e**2))``.

Flat tables
-----------
:func:`summary_table` turns ``(labels, summary)`` pairs into one flat ``dict``
per run; :func:`aggregate_seeds` averages runs over seeds and
:func:`add_improvement` adds the improvement over a baseline controller.
Metric columns are recognised by name (:func:`is_metric_column`); every other
column is a label (``policy``, ``kp``, ``path``, ``seed``, ...).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Optional

import numpy as np

from agents.tracking_error import (MM_PER_M, distance_mm, error_stats, record_cycles,
                                    record_positions, record_steps, tracking_error_mm)
from soft_gym.tasks.paths import path_deviation

__all__ = [
    "ESTIMATE_COLUMNS",
    "MM_PER_M",
    "SEED_STD_SUFFIX",
    "STAT_KEYS",
    "add_improvement",
    "aggregate_seeds",
    "cycle_ids",
    "error_stats",
    "estimation_error_mm",
    "estimation_errors",
    "improvement",
    "is_metric_column",
    "path_deviation_mm",
    "summarize",
    "summary_table",
    "tracking_error_mm",
]

#: Estimator name -> record column of its position estimate (m).
ESTIMATE_COLUMNS: dict[str, str] = {
    "camera": "camera_m",
    "femp": "femp_m",
    "fused": "fused_m",
    "em": "em_m",
}

#: Keys of the statistics dicts returned by :func:`error_stats` that become
#: table columns (the sample count ``n`` does not).
STAT_KEYS: tuple[str, ...] = ("mean_mm", "std_mm", "max_mm", "rmse_mm")

#: Prefix of the flat-table columns of each summary section.
_SECTION_PREFIX = {"tracking": "track", "deviation": "dev"}

_METRIC_NAMES = frozenset({"n_steps", "n_cycles", "n_seeds"})
_METRIC_PATTERN = re.compile(r"^(track|dev|est)_|improvement")

#: Suffix of the between-seed standard deviation columns of :func:`aggregate_seeds`.
SEED_STD_SUFFIX = "_seed_std"


# ---------------------------------------------------------------------------
# Record access
# ---------------------------------------------------------------------------


def cycle_ids(record: Mapping[str, Any]) -> list[int]:
    """Sorted distinct cycle indices of a record (``[0]`` without ``cycle``)."""
    return [int(c) for c in np.unique(record_cycles(record))]


# ---------------------------------------------------------------------------
# Per-step errors
# ---------------------------------------------------------------------------


def path_deviation_mm(record: Mapping[str, Any]) -> np.ndarray:
    """Path deviation per step: distance from the tip to the closed path (mm).

    Uses the exact point-to-polyline distance of
    :func:`soft_gym.tasks.paths.path_deviation` to ``record["polyline_m"]``
    (closed: the last point joins the first).  Steps whose tip is not finite
    get NaN.

    Args:
        record: Episode record with ``tip_m`` (T, 3) and optionally
            ``polyline_m`` (P, 3), metres.

    Returns:
        Array of shape (T,) in millimetres; all NaN if the record has no
        polyline (reach tasks).
    """
    tip = record_positions(record, "tip_m")
    out = np.full(tip.shape[0], np.nan)
    polyline = record.get("polyline_m")
    if polyline is None:
        return out
    finite = np.all(np.isfinite(tip), axis=1)
    if np.any(finite):
        out[finite] = path_deviation(tip[finite], np.asarray(polyline, dtype=float)) * MM_PER_M
    return out


def estimation_error_mm(record: Mapping[str, Any], column: str) -> np.ndarray:
    """Per-step error of a position estimate against ``tip_m`` (mm).

    Args:
        record: Episode record with ``tip_m`` and ``column`` (T, 3), metres.
        column: Record column of the estimate, e.g. ``"fused_m"``.

    Returns:
        Array of shape (T,) in millimetres.
    """
    tip = record_positions(record, "tip_m")
    est = record_positions(record, column)
    if est.shape != tip.shape:
        raise ValueError(
            f"record[{column!r}] {est.shape} and record['tip_m'] {tip.shape} differ in shape"
        )
    return distance_mm(est, tip)


# ---------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------


def _section(errors_mm: np.ndarray, cycles: np.ndarray, ids: Sequence[int]) -> dict[str, Any]:
    """Overall stats, final value and per-cycle lists of one error series."""
    out: dict[str, Any] = dict(error_stats(errors_mm))
    out["final_mm"] = float(errors_mm[-1]) if errors_mm.size else math.nan
    per = [error_stats(errors_mm[cycles == c]) for c in ids]
    out["per_cycle"] = {key: [p[key] for p in per] for key in STAT_KEYS + ("n",)}
    return out


def _check_phases(phases: Sequence[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """Validate ``(name, start_s, end_s)`` phases."""
    out = []
    seen = set()
    for item in phases:
        try:
            name, start, end = item
        except (TypeError, ValueError):
            raise ValueError(f"a phase must be (name, start_s, end_s), got {item!r}") from None
        if not isinstance(name, str) or not name:
            raise ValueError(f"phase name must be a non-empty string, got {name!r}")
        if name in seen:
            raise ValueError(f"duplicate phase name {name!r}")
        start, end = float(start), float(end)
        if not end > start:
            raise ValueError(f"phase {name!r} must have end_s > start_s, got {start!r}, {end!r}")
        seen.add(name)
        out.append((name, start, end))
    return out


def estimation_errors(
    record: Mapping[str, Any],
    phases: Optional[Sequence[tuple[str, float, float]]] = None,
    columns: Mapping[str, str] = ESTIMATE_COLUMNS,
) -> dict[str, dict[str, Any]]:
    """Error statistics of each position estimate present in the record (mm).

    Args:
        record: Episode record with ``tip_m`` and any of the estimate columns.
        phases: Optional ``(name, start_s, end_s)`` windows (e.g. "no
            obstacle", "moving hand"); a step belongs to a phase when
            ``start_s <= time_s < end_s``.  Needs ``time_s``.
        columns: Estimator name -> record column; default
            :data:`ESTIMATE_COLUMNS` (camera, femp, fused, em).

    Returns:
        ``{name: {"mean_mm", "std_mm", "max_mm", "rmse_mm", "n"}}`` for each
        estimator whose column is in the record, in the order of
        ``columns``; with ``phases`` each entry also has ``"phases": {phase
        name: stats}`` (NaN stats, ``n`` 0, for a phase without steps).
    """
    checked = _check_phases(phases) if phases else []
    time = None
    if checked:
        if "time_s" not in record:
            raise ValueError("estimation_errors with phases needs record['time_s']")
        time = np.asarray(record["time_s"], dtype=float)
        if time.shape != (record_steps(record),):
            raise ValueError(f"record['time_s'] must have shape ({record_steps(record)},), "
                             f"got {time.shape}")
    out: dict[str, dict[str, Any]] = {}
    for name, column in columns.items():
        if column not in record:
            continue
        err = estimation_error_mm(record, column)
        entry: dict[str, Any] = dict(error_stats(err))
        if checked:
            entry["phases"] = {
                ph: error_stats(err[(time >= lo) & (time < hi)]) for ph, lo, hi in checked
            }
        out[name] = entry
    return out


def summarize(
    record: Mapping[str, Any],
    phases: Optional[Sequence[tuple[str, float, float]]] = None,
) -> dict[str, Any]:
    """Summary of one episode: tracking error, path deviation, estimation errors.

    Args:
        record: Episode record (see the module docstring).
        phases: Optional phases passed on to :func:`estimation_errors`.

    Returns:
        A dict::

            {
              "n_steps": T, "n_cycles": C, "cycles": [0, 1, ...],
              "tracking":  {"mean_mm", "std_mm", "max_mm", "rmse_mm", "n",
                            "final_mm",
                            "per_cycle": {"mean_mm": [...], "std_mm": [...],
                                          "max_mm": [...], "rmse_mm": [...],
                                          "n": [...]}},
              "deviation": {same keys; NaN without a polyline},
              "estimation": estimation_errors(record, phases),
            }

        Per-cycle lists follow ``cycles`` (sorted distinct values of
        ``record["cycle"]``).  ``final_mm`` is the error at the last step
        (the reach-task figure of merit).
    """
    cycles = record_cycles(record)
    ids = [int(c) for c in np.unique(cycles)]
    track = tracking_error_mm(record)
    dev = path_deviation_mm(record)
    return {
        "n_steps": int(track.shape[0]),
        "n_cycles": len(ids),
        "cycles": ids,
        "tracking": _section(track, cycles, ids),
        "deviation": _section(dev, cycles, ids),
        "estimation": estimation_errors(record, phases),
    }


def improvement(baseline_value: float, value: float) -> float:
    """Relative improvement ``(e_m - e_h) / e_m`` over a baseline error.

    As in Wang et al. 2023 (Tables I-II, "Improv."): ``e_m`` is the error of
    the model-based baseline, ``e_h`` that of the evaluated controller.  The
    result is a fraction (0.75 means 75 % lower error); it is negative when
    the controller is worse than the baseline.

    Args:
        baseline_value: Baseline error e_m (> 0, finite).
        value: Evaluated error e_h (finite).

    Returns:
        The improvement as a fraction.

    Raises:
        ValueError: If ``baseline_value`` is not a positive finite number or
            ``value`` is not finite.
    """
    try:
        base = float(baseline_value)
        val = float(value)
    except (TypeError, ValueError):
        raise ValueError(
            f"improvement needs numbers, got baseline_value={baseline_value!r}, value={value!r}"
        ) from None
    if not math.isfinite(base) or base <= 0.0:
        raise ValueError(
            f"improvement needs a positive finite baseline error, got baseline_value={baseline_value!r}"
        )
    if not math.isfinite(val):
        raise ValueError(f"improvement needs a finite value, got value={value!r}")
    return (base - val) / base


# ---------------------------------------------------------------------------
# Flat tables
# ---------------------------------------------------------------------------


def is_metric_column(name: str) -> bool:
    """Whether a flat-table column holds a metric (else it is a label).

    Metric columns start with ``track_``, ``dev_`` or ``est_``, contain
    ``improvement``, or are ``n_steps``, ``n_cycles`` or ``n_seeds``.
    """
    return name in _METRIC_NAMES or bool(_METRIC_PATTERN.search(name))


def _flatten(summary: Mapping[str, Any]) -> dict[str, Any]:
    """Metric columns of one summary (see :func:`summary_table`)."""
    row: dict[str, Any] = {
        "n_steps": summary.get("n_steps"),
        "n_cycles": summary.get("n_cycles"),
    }
    for section, prefix in _SECTION_PREFIX.items():
        sec = summary[section]
        for key in STAT_KEYS + ("final_mm",):
            row[f"{prefix}_{key}"] = sec[key]
    estimation = summary.get("estimation") or {}
    for name, stats in estimation.items():
        for key in STAT_KEYS:
            row[f"est_{name}_{key}"] = stats[key]
    cycles = summary.get("cycles") or []
    for section, prefix in _SECTION_PREFIX.items():
        per = summary[section]["per_cycle"]
        for i, c in enumerate(cycles):
            for key in STAT_KEYS:
                row[f"{prefix}_{key}_cycle{int(c) + 1}"] = per[key][i]
    for name, stats in estimation.items():
        for phase, pstats in (stats.get("phases") or {}).items():
            for key in STAT_KEYS:
                row[f"est_{name}_{key}_{phase}"] = pstats[key]
    return row


def _union_keys(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    """All keys of ``rows`` in first-seen order."""
    keys: dict[str, None] = {}
    for row in rows:
        for k in row:
            keys.setdefault(k, None)
    return list(keys)


def summary_table(
    rows: Iterable[tuple[Mapping[str, Any], Mapping[str, Any]]],
) -> list[dict[str, Any]]:
    """Flatten ``(labels, summary)`` pairs into one dict per run.

    Columns: the labels (e.g. ``policy``, ``kp``, ``path``, ``seed``), then
    ``n_steps``, ``n_cycles``, ``track_{mean,std,max,rmse,final}_mm``,
    ``dev_{...}_mm``, ``est_<estimator>_{mean,std,max,rmse}_mm``, then per
    cycle ``track_<stat>_mm_cycle<k>`` and ``dev_<stat>_mm_cycle<k>`` with
    ``k`` counted from 1 (``cycle1`` is record cycle 0), then per estimation
    phase ``est_<estimator>_<stat>_mm_<phase>``.

    All rows get the same columns (the union, in first-seen order); a metric
    a run lacks (e.g. a third cycle) is NaN and a missing label is None.

    Args:
        rows: ``(labels, summary)`` pairs, ``summary`` from :func:`summarize`.

    Returns:
        A list of flat dicts, one per run, in input order.

    Raises:
        ValueError: If a label name looks like a metric column.
    """
    flat = []
    for labels, summary in rows:
        bad = [k for k in labels if is_metric_column(str(k))]
        if bad:
            raise ValueError(f"label names {bad} clash with metric column names")
        row = {str(k): v for k, v in labels.items()}
        row.update(_flatten(summary))
        flat.append(row)
    return _fill_columns(flat)


def _fill_columns(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Give every row the union of columns (NaN for metrics, None for labels)."""
    keys = _union_keys(rows)
    return [
        {k: row.get(k, math.nan if is_metric_column(k) else None) for k in keys}
        for row in rows
    ]


def _numeric(value: Any) -> float:
    """``value`` as a float, NaN for None or non-numeric values."""
    if value is None or isinstance(value, (str, bytes)):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _hashable(value: Any) -> Any:
    """A hashable stand-in for a label value (lists/arrays become tuples)."""
    try:
        hash(value)
        return value
    except TypeError:
        return tuple(np.asarray(value).ravel().tolist())


def aggregate_seeds(
    rows: Sequence[Mapping[str, Any]],
    by: Optional[Sequence[str]] = None,
    seed_key: str = "seed",
) -> list[dict[str, Any]]:
    """Mean and standard deviation over seeds of every metric column.

    Runs are grouped by the label columns ``by``; by default every label
    column (see :func:`is_metric_column`) except ``seed_key``, i.e. runs
    whose labels are identical except for the seed.  Each output row has the
    ``by`` labels, ``n_seeds`` (runs in the group), and for each metric
    column ``m`` (other than ``n_seeds``) its mean over the group under the
    same name ``m`` and its sample standard deviation (``ddof=1``; NaN for a
    single seed) under ``m + "_seed_std"``.  A NaN in any run makes that
    metric's mean NaN.

    Args:
        rows: Flat rows from :func:`summary_table` (or :func:`add_improvement`).
        by: Label columns to group by; default all labels but ``seed_key``.
        seed_key: Name of the seed label.

    Returns:
        One row per group, in order of first appearance.

    Raises:
        ValueError: If ``by`` names a metric column or a group holds the same
            seed twice (its runs differ in a label not in ``by``, or a run is
            duplicated).
    """
    rows = _fill_columns([dict(r) for r in rows])
    if not rows:
        return []
    keys = list(rows[0])
    metrics = [k for k in keys if is_metric_column(k) and k != "n_seeds"
               and not k.endswith(SEED_STD_SUFFIX)]
    if by is None:
        group_keys = [k for k in keys if not is_metric_column(k) and k != seed_key]
    else:
        group_keys = list(by)
        bad = [k for k in group_keys if is_metric_column(k)]
        if bad:
            raise ValueError(f"cannot group by metric columns {bad}")
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for row in rows:
        key = tuple(_hashable(row.get(k)) for k in group_keys)
        groups.setdefault(key, []).append(row)
    out = []
    for members in groups.values():
        if seed_key in members[0]:
            seeds = [_hashable(m.get(seed_key)) for m in members]
            if len(set(seeds)) != len(seeds):
                labels = {k: members[0].get(k) for k in group_keys}
                raise ValueError(
                    f"runs with labels {labels} repeat a {seed_key!r} value ({seeds}); "
                    f"group by more labels (by=...) or remove duplicate runs"
                )
        agg: dict[str, Any] = {k: members[0].get(k) for k in group_keys}
        agg["n_seeds"] = len(members)
        for m in metrics:
            values = np.array([_numeric(r.get(m)) for r in members], dtype=float)
            agg[m] = float(np.mean(values))
            agg[m + SEED_STD_SUFFIX] = (
                float(np.std(values, ddof=1)) if values.size > 1 else math.nan
            )
        out.append(agg)
    return out


def add_improvement(
    rows: Sequence[Mapping[str, Any]],
    baseline: Optional[Mapping[str, Any]] = None,
    match: Optional[Sequence[str]] = None,
    metric: str = "track_mean_mm",
    column: str = "improvement_%",
) -> list[dict[str, Any]]:
    """Add the improvement in percent of each run over its baseline run.

    For every row, the baseline row is the one whose labels equal
    ``baseline`` (default ``{"policy": "cc_model"}``) and whose ``match``
    labels equal the row's.  The new column holds
    ``100 * improvement(baseline[metric], row[metric])``, i.e.
    ``100 * (e_m - e_h) / e_m`` as in Wang et al. 2023 (0 for the baseline
    rows themselves), or NaN when no baseline row matches or either value is
    NaN.

    Args:
        rows: Flat rows (from :func:`summary_table` or :func:`aggregate_seeds`).
        baseline: Labels that identify baseline rows.
        match: Labels that must agree between a row and its baseline; default
            every label column except those in ``baseline`` (so a hybrid run
            is compared with the baseline run of the same gain, path,
            scenario, feedback and seed).
        metric: Metric column compared, e.g. ``"track_mean_mm"`` or
            ``"dev_mean_mm"``.
        column: Name of the added column.

    Returns:
        New row dicts (copies) with ``column`` added, in input order.

    Raises:
        ValueError: If ``metric`` is missing, several baseline rows match one
            row, or a matched baseline value is not positive.
    """
    if baseline is None:
        baseline = {"policy": "cc_model"}
    if not baseline:
        raise ValueError("baseline must name at least one label, e.g. {'policy': 'cc_model'}")
    rows = [dict(r) for r in rows]
    if not rows:
        return []
    missing = [i for i, r in enumerate(rows) if metric not in r]
    if missing:
        raise ValueError(f"metric {metric!r} missing from rows {missing}")
    base_rows = [r for r in rows if all(r.get(k) == v for k, v in baseline.items())]
    out = []
    for row in rows:
        if match is None:
            keys = [k for k in row if not is_metric_column(k) and k not in baseline
                    and k != column]
        else:
            keys = list(match)
        found = [b for b in base_rows
                 if all(_hashable(b.get(k)) == _hashable(row.get(k)) for k in keys)]
        if len(found) > 1:
            raise ValueError(
                f"{len(found)} baseline rows match labels {({k: row.get(k) for k in keys})}; "
                f"pass match=[...] naming the labels that identify a run"
            )
        value = math.nan
        if found:
            base_v, v = _numeric(found[0][metric]), _numeric(row[metric])
            if not (math.isnan(base_v) or math.isnan(v)):
                value = 100.0 * improvement(base_v, v)
        new = dict(row)
        new[column] = value
        out.append(new)
    return out
