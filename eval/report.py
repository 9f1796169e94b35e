"""Benchmark reports: per-step CSV, JSON, Markdown tables and PNG plots.

* :func:`write_records_csv` writes one episode record as a per-step CSV with
  named columns (``time_s, cycle, target_x_m, target_y_m, ...``) that
  ``numpy.genfromtxt(path, delimiter=",", names=True)`` reads back.
* :func:`write_json` writes summaries and configs, converting numpy types;
  :func:`write_results_json` writes an eval run's rows with the package version that made them.
* :func:`markdown_table` renders flat rows (from
  :func:`eval.metrics.summary_table`) as a GitHub-flavoured Markdown table;
  :func:`with_mean_std` adds "mean ± std" text columns as in Wang et al.
  2023, Tables I-II.
* :func:`plot_trajectory`, :func:`plot_error_time` and
  :func:`plot_estimation` draw the figures of Wang et al. 2023 (Figs. 9-12
  and 6-7): trajectories in the path plane, tracking error and path
  deviation over time, and estimation error with the camera quality e_S.

Plots are drawn on :class:`matplotlib.figure.Figure` objects rendered by the
non-interactive Agg canvas, never through ``pyplot``: no window opens, the
global pyplot figure list and backend stay untouched, and each figure is
cleared after saving.  Sizes, resolution and styles are fixed and the PNG
carries no software/version metadata, so the same inputs give the same
bytes.  Records are in SI units; every plot axis is in millimetres.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from eval.metrics import (
    ESTIMATE_COLUMNS,
    MM_PER_M,
    estimation_error_mm,
    path_deviation_mm,
    tracking_error_mm,
)
from eval.palette import policy_color

__all__ = [
    "csv_columns",
    "markdown_table",
    "plot_error_time",
    "plot_estimation",
    "plot_trajectory",
    "to_jsonable",
    "with_mean_std",
    "package_version",
    "write_json",
    "write_records_csv",
    "write_results_json",
]

PathLike = Union[str, Path]

#: Columns written first (in this order) by :func:`write_records_csv`.
_CSV_ORDER: tuple[str, ...] = (
    "time_s", "cycle", "target_m", "tip_m", "feedback_m", "action", "pressure_pa",
    "camera_m", "femp_m", "fused_m", "em_m", "reprojection_error_px",
)
#: Unit suffixes kept at the end of expanded column names.
_UNITS = frozenset({"m", "mm", "s", "pa", "px", "rad", "n", "kg", "deg"})
_AXES = ("x", "y", "z")
_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
_ESTIMATOR_COLORS = {"camera": "tab:orange", "femp": "tab:green", "fused": "tab:blue",
                     "em": "tab:purple"}
_DPI = 120
_PNG_METADATA = {"Software": None}


def _prepare(path: PathLike) -> Path:
    """Return ``path`` as a Path, creating its parent directory."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    return out


# ---------------------------------------------------------------------------
# CSV
# ---------------------------------------------------------------------------


def _expand_names(key: str, width: int) -> list[str]:
    """Column names of a (T, width) record entry.

    ``target_m`` (T, 3) -> ``target_x_m, target_y_m, target_z_m``;
    ``pressure_pa`` (T, 3) -> ``pressure_0_pa, ...``; ``action`` -> ``action_0, ...``.
    """
    base, _, unit = key.rpartition("_")
    if not base or unit not in _UNITS:
        base, unit = key, ""
    labels = list(_AXES) if (width == 3 and unit == "m") else [str(i) for i in range(width)]
    return [f"{base}_{lab}_{unit}" if unit else f"{base}_{lab}" for lab in labels]


def csv_columns(
    record: Mapping[str, Any], include_errors: bool = True
) -> tuple[list[str], np.ndarray]:
    """Column names and the (T, K) float matrix written by :func:`write_records_csv`.

    Per-step entries (first dimension T = ``len(record["tip_m"])``, 1-D or
    2-D, numeric or boolean) become columns: the known keys first (time,
    cycle, target, tip, feedback, action, pressure, estimates, e_S), then
    any other per-step keys in sorted order.  Entries of another length (the
    path ``polyline_m``) or with more than two dimensions are left out.  With
    ``include_errors`` the derived ``tracking_error_mm`` and
    ``path_deviation_mm`` are appended.
    """
    if "tip_m" not in record:
        raise ValueError("record has no 'tip_m' column")
    t = int(np.shape(record["tip_m"])[0])
    keys = [k for k in _CSV_ORDER if k in record]
    keys += sorted(k for k in record if k not in _CSV_ORDER)
    names: list[str] = []
    blocks: list[np.ndarray] = []
    for key in keys:
        arr = np.asarray(record[key])
        if arr.ndim not in (1, 2) or arr.shape[0] != t:
            continue
        if arr.dtype.kind not in "biuf":
            continue
        arr = arr.astype(float)
        if arr.ndim == 1:
            names.append(str(key))
            blocks.append(arr[:, None])
        else:
            names.extend(_expand_names(str(key), arr.shape[1]))
            blocks.append(arr)
    if include_errors:
        names += ["tracking_error_mm", "path_deviation_mm"]
        blocks += [tracking_error_mm(record)[:, None], path_deviation_mm(record)[:, None]]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"record entries give duplicate CSV column names {dup}")
    data = np.hstack(blocks) if blocks else np.empty((t, 0))
    return names, data


def write_records_csv(
    path: PathLike, record: Mapping[str, Any], include_errors: bool = True
) -> Path:
    """Write one episode record as a per-step CSV file.

    One header line of comma-separated names (see :func:`csv_columns`), then
    one line per step with full float precision (``%.17g``; integers print
    without a decimal point, NaN as ``nan``).  Read it back with
    ``numpy.genfromtxt(path, delimiter=",", names=True)``.

    Args:
        path: Output file; its directory is created.
        record: Episode record (SI units).
        include_errors: Append ``tracking_error_mm`` and ``path_deviation_mm``.

    Returns:
        The path written.
    """
    out = _prepare(path)
    names, data = csv_columns(record, include_errors=include_errors)
    np.savetxt(out, data, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
    return out


# ---------------------------------------------------------------------------
# JSON
# ---------------------------------------------------------------------------


def to_jsonable(obj: Any) -> Any:
    """Convert numpy arrays/scalars, tuples, sets and paths to JSON types.

    Non-finite floats (NaN, +-inf) become ``None`` (JSON ``null``) so the
    output is strict JSON; mapping keys become strings.
    """
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return [to_jsonable(v) for v in sorted(obj, key=repr)]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, Path):
        return str(obj)
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    raise TypeError(f"cannot convert {type(obj).__name__} to JSON: {obj!r}")


def write_json(path: PathLike, obj: Any) -> Path:
    """Write ``obj`` as indented strict JSON (numpy-safe, NaN -> null).

    Args:
        path: Output file; its directory is created.
        obj: Dicts, lists, numbers, strings, numpy arrays and scalars.

    Returns:
        The path written.
    """
    out = _prepare(path)
    text = json.dumps(to_jsonable(obj), indent=2, allow_nan=False)
    out.write_text(text + "\n", encoding="utf-8")
    return out


def package_version() -> str:
    """The installed version of soft-arm-gym (``importlib.metadata``), or ``"unknown"`` when
    the package is not installed (run from a bare checkout)."""
    try:
        return metadata.version("soft-arm-gym")
    except metadata.PackageNotFoundError:
        return "unknown"


def write_results_json(path: PathLike, rows: Sequence[Mapping[str, Any]]) -> Path:
    """Write an eval run's result rows as ``{"soft_arm_gym_version": ..., "rows": [...]}``.

    Args:
        path: Output file; its directory is created.
        rows: The run's table, one dict per row (numpy values allowed).

    Returns:
        The path written.
    """
    return write_json(path, {"soft_arm_gym_version": package_version(), "rows": list(rows)})


# ---------------------------------------------------------------------------
# Markdown
# ---------------------------------------------------------------------------


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _cell(value: Any, float_format: str) -> str:
    """Text of one Markdown table cell."""
    if value is None:
        text = ""
    elif isinstance(value, (bool, np.bool_)):
        text = str(bool(value))
    elif isinstance(value, (int, np.integer)):
        text = str(int(value))
    elif isinstance(value, (float, np.floating)):
        f = float(value)
        text = float_format.format(f) if math.isfinite(f) else str(f)
    else:
        text = str(value)
    return text.replace("|", "\\|").replace("\r", " ").replace("\n", " ")


def markdown_table(
    rows: Sequence[Mapping[str, Any]],
    columns: Optional[Union[Sequence[str], Mapping[str, str]]] = None,
    float_format: str = "{:.3f}",
) -> str:
    """Render rows as a GitHub-flavoured Markdown table.

    Args:
        rows: Flat dicts (e.g. from :func:`eval.metrics.summary_table`).
        columns: Columns to show, in order; a mapping gives ``{column:
            header text}``.  Default: every column, in first-seen order.
        float_format: Format of float cells; non-finite floats print as
            ``nan``/``inf``, None as an empty cell, ints unchanged.

    Returns:
        The table: a header line, an alignment line (numeric columns
        right-aligned) and one line per row, joined by newlines, with a
        trailing newline.  A missing value is an empty cell.

    Raises:
        ValueError: If there are no columns to show.
    """
    if columns is None:
        keys: dict[str, None] = {}
        for row in rows:
            for k in row:
                keys.setdefault(k, None)
        headers = {k: str(k) for k in keys}
    elif isinstance(columns, Mapping):
        headers = {k: str(v) for k, v in columns.items()}
    else:
        headers = {k: str(k) for k in columns}
    if not headers:
        raise ValueError("markdown_table needs at least one column")
    cols = list(headers)
    align = []
    for c in cols:
        values = [row.get(c) for row in rows if row.get(c) is not None]
        numeric = bool(values) and all(_is_number(v) for v in values)
        align.append("---:" if numeric else "---")
    lines = [
        "| " + " | ".join(_cell(headers[c], "{}") for c in cols) + " |",
        "| " + " | ".join(align) + " |",
    ]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row.get(c), float_format) for c in cols) + " |")
    return "\n".join(lines) + "\n"


def with_mean_std(
    rows: Sequence[Mapping[str, Any]],
    mean_column: str,
    std_column: str,
    column: Optional[str] = None,
    float_format: str = "{:.3f}",
) -> list[dict[str, Any]]:
    """Add a text column ``"mean ± std"`` (Wang et al. 2023 Tables I-II style).

    Args:
        rows: Flat rows.
        mean_column: e.g. ``"track_mean_mm"``.
        std_column: e.g. ``"track_std_mm"`` (or a ``*_seed_std`` column).
        column: Name of the new column; default ``mean_column + "_pm"``.
        float_format: Format of both numbers.

    Returns:
        Copies of the rows with the new column (empty text where a value is
        missing; the mean alone where the std is NaN, e.g. over a single seed).
    """
    name = column or f"{mean_column}_pm"
    out = []
    for row in rows:
        new = dict(row)
        m, s = row.get(mean_column), row.get(std_column)
        if m is None or s is None:
            new[name] = ""
        elif _is_number(s) and not np.isfinite(s):
            new[name] = _cell(m, float_format)
        else:
            new[name] = f"{_cell(m, float_format)} ± {_cell(s, float_format)}"
        out.append(new)
    return out


# ---------------------------------------------------------------------------
# Plots
# ---------------------------------------------------------------------------


def _new_figure(width_in: float, height_in: float, nrows: int = 1) -> tuple[Figure, Any]:
    """A Figure with an Agg canvas and ``nrows`` stacked axes."""
    fig = Figure(figsize=(width_in, height_in), dpi=_DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, sharex=nrows > 1, squeeze=False)[:, 0]
    return fig, axes


def save_figure(fig: Figure, path_png: PathLike) -> Path:
    """Save a figure as PNG (fixed dpi, no metadata) and release it."""
    out = _prepare(path_png)
    fig.savefig(out, format="png", dpi=_DPI, metadata=_PNG_METADATA, bbox_inches="tight")
    fig.clear()
    return out


def _time_axis(record: Mapping[str, Any], n: int) -> tuple[np.ndarray, str]:
    """Time (s) of each step, or the step index when ``time_s`` is absent."""
    if "time_s" in record:
        t = np.asarray(record["time_s"], dtype=float)
        if t.shape != (n,):
            raise ValueError(f"record['time_s'] must have shape ({n},), got {t.shape}")
        return t, "time (s)"
    return np.arange(n, dtype=float), "step"


def _cycle_starts(record: Mapping[str, Any], x: np.ndarray) -> list[float]:
    """x positions of the first step of every cycle after the first."""
    if "cycle" not in record:
        return []
    cyc = np.asarray(record["cycle"])
    if cyc.shape != x.shape:
        return []
    idx = np.flatnonzero(cyc[1:] != cyc[:-1]) + 1
    return [float(x[i]) for i in idx]


_LINE_STYLES = ("-", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
"""Line styles of runs drawn in one colour (the same policy at several gains or seeds)."""


def error_peaks_mm(records: Sequence[Mapping[str, Any]]) -> list[float]:
    """The peak tracking error and path deviation (mm) over ``records``, padded by 8 %: the
    ``ymax_mm`` of :func:`plot_error_time` that gives several plots one y-scale (0 for a
    series with no finite value)."""
    peaks = [0.0, 0.0]
    for record in records:
        series = [tracking_error_mm(record)]
        if record.get("polyline_m") is not None:
            series.append(path_deviation_mm(record))
        for row, values in enumerate(series):
            finite = values[np.isfinite(values)]
            if finite.size:
                peaks[row] = max(peaks[row], float(np.max(finite)) * 1.08)
    return peaks


def _ylim_from_zero(ax: Any, values: Sequence[np.ndarray]) -> None:
    """Set y limits to [0, 1.08 * max] of the finite values (1 if none)."""
    peaks = [float(np.max(v[np.isfinite(v)])) for v in values if np.any(np.isfinite(v))]
    top = max(peaks) if peaks else 0.0
    ax.set_ylim(0.0, top * 1.08 if top > 0.0 else 1.0)


def plot_trajectory(
    path_png: PathLike,
    record: Mapping[str, Any],
    title: str,
    plane: str = "xy",
) -> Path:
    """Tip and feedback trajectories over the path and targets (mm).

    Like Wang et al. 2023 Fig. 9: the projection on ``plane`` (default the
    x-y plane) of the closed path polyline (grey, when present), the targets
    (dots; one cross for a fixed reach target), the ground-truth tip (solid,
    one colour per cycle) and the feedback pose the controller saw (dashed,
    same colour), with equal axis scales.

    Args:
        path_png: Output PNG file; its directory is created.
        record: Episode record with ``tip_m``; ``target_m``,
            ``feedback_m``, ``polyline_m`` and ``cycle`` are used when
            present.
        title: Figure title.
        plane: ``"xy"``, ``"xz"`` or ``"yz"``.

    Returns:
        The path written.
    """
    if plane not in _PLANES:
        raise ValueError(f"plane must be one of {sorted(_PLANES)}, got {plane!r}")
    i, j = _PLANES[plane]
    tip = np.asarray(record["tip_m"], dtype=float) * MM_PER_M
    if tip.ndim != 2 or tip.shape[1] != 3:
        raise ValueError(f"record['tip_m'] must have shape (T, 3), got {tip.shape}")
    fig, (ax,) = _new_figure(6.4, 5.6)
    if record.get("polyline_m") is not None:
        line = np.asarray(record["polyline_m"], dtype=float) * MM_PER_M
        closed = np.vstack((line, line[:1]))
        ax.plot(closed[:, i], closed[:, j], color="0.6", lw=2.5, alpha=0.6,
                label="path", zorder=1)
    if "target_m" in record:
        target = np.asarray(record["target_m"], dtype=float) * MM_PER_M
        unique = np.unique(target[:, [i, j]], axis=0)
        if unique.shape[0] <= 3:
            ax.plot(unique[:, 0], unique[:, 1], "x", color="k", ms=9, mew=2,
                    label="target", zorder=4)
        else:
            ax.plot(target[:, i], target[:, j], ".", color="k", ms=2.5, alpha=0.5,
                    label="targets", zorder=2)
    cycles = np.asarray(record.get("cycle", np.zeros(tip.shape[0], dtype=int)))
    ids = np.unique(cycles)
    feedback = None
    if "feedback_m" in record:
        feedback = np.asarray(record["feedback_m"], dtype=float) * MM_PER_M
    for k, c in enumerate(ids):
        mask = cycles == c
        color = f"C{k % 10}"
        suffix = f" (cycle {int(c) + 1})" if ids.size > 1 else ""
        ax.plot(tip[mask, i], tip[mask, j], "-", color=color, lw=1.3,
                label=f"tip{suffix}", zorder=3)
        if feedback is not None:
            ax.plot(feedback[mask, i], feedback[mask, j], "--", color=color, lw=1.0,
                    alpha=0.7, label=f"feedback{suffix}", zorder=3)
    if tip.shape[0]:
        ax.plot(tip[0, i], tip[0, j], "o", color="k", mfc="none", ms=6, label="start",
                zorder=5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{plane[0]} (mm)")
    ax.set_ylabel(f"{plane[1]} (mm)")
    ax.set_title(title)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize="small", frameon=False)
    return save_figure(fig, path_png)


def plot_error_time(
    path_png: PathLike,
    records_by_label: Mapping[str, Mapping[str, Any]],
    title: str,
    colors: Mapping[str, str] | None = None,
    ymax_mm: Sequence[float] | None = None,
) -> Path:
    """Tracking error (and path deviation) over time for several runs (mm).

    Like Wang et al. 2023 Figs. 9-12: one line per run, its mean as a thin
    dashed line of the same colour (the value is in the legend), and cycle
    boundaries as dotted vertical lines.  A second panel shows path
    deviation when any run has a polyline.

    Args:
        path_png: Output PNG file; its directory is created.
        records_by_label: Legend label -> episode record.
        title: Figure title.
        colors: Legend label -> colour; default the label's policy colour
            (:func:`eval.palette.policy_color`), so a policy has one colour in every plot.
            Runs sharing a colour (one policy at several gains) differ in line style.
        ymax_mm: The top of each panel's y axis (mm; tracking error, then path deviation),
            e.g. shared by every plot of one arm; default each panel's own peak.

    Returns:
        The path written.

    Raises:
        ValueError: If ``records_by_label`` is empty.
    """
    if not records_by_label:
        raise ValueError("plot_error_time needs at least one record")
    with_dev = any(r.get("polyline_m") is not None for r in records_by_label.values())
    nrows = 2 if with_dev else 1
    fig, axes = _new_figure(8.0, 3.0 * nrows + 0.6, nrows=nrows)
    boundaries: set[float] = set()
    xlabel = "time (s)"
    plotted: list[list[np.ndarray]] = [[] for _ in range(nrows)]
    used: dict[str, int] = {}
    for label, rec in records_by_label.items():
        color = policy_color(label) if colors is None else colors[label]
        style = _LINE_STYLES[used.get(color, 0) % len(_LINE_STYLES)]
        used[color] = used.get(color, 0) + 1
        series = [tracking_error_mm(rec)]
        if with_dev:
            series.append(path_deviation_mm(rec))
        x, xlabel = _time_axis(rec, series[0].shape[0])
        boundaries.update(_cycle_starts(rec, x))
        for row, (ax, err) in enumerate(zip(axes, series)):
            finite = err[np.isfinite(err)]
            if finite.size == 0:
                continue
            plotted[row].append(err)
            mean = float(np.mean(finite))
            ax.plot(x, err, linestyle=style, color=color, lw=1.0,
                    label=f"{label} (mean {mean:.3f} mm)")
            ax.axhline(mean, color=color, ls="--", lw=0.8, alpha=0.8)
    for row, (ax, name, values) in enumerate(zip(axes, ("tracking error (mm)",
                                                         "path deviation (mm)"), plotted)):
        for b in sorted(boundaries):
            ax.axvline(b, color="0.4", ls=":", lw=0.9)
        ax.set_ylabel(name)
        if ymax_mm is not None and row < len(ymax_mm) and ymax_mm[row] > 0.0:
            ax.set_ylim(0.0, float(ymax_mm[row]))
        else:
            _ylim_from_zero(ax, values)
        ax.grid(True, lw=0.4, alpha=0.5)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel(xlabel)
    axes[0].set_title(title)
    return save_figure(fig, path_png)


def plot_estimation(
    path_png: PathLike,
    record: Mapping[str, Any],
    title: str,
    phases: Optional[Sequence[tuple[str, float, float]]] = None,
    columns: Mapping[str, str] = ESTIMATE_COLUMNS,
) -> Path:
    """Estimation error over time per estimator, with e_S on a twin axis.

    Like Wang et al. 2023 Figs. 6-7: the distance of each position estimate
    present (camera, F-emp, fusion, EM) to the ground-truth tip (mm, left
    axis) and, when the record has ``reprojection_error_px``, the camera
    quality e_S (px, right axis, grey).  Optional phases (e.g. lighting
    conditions) are shaded and named.

    Args:
        path_png: Output PNG file; its directory is created.
        record: Episode record with ``tip_m`` and estimate columns.
        title: Figure title.
        phases: Optional ``(name, start_s, end_s)`` windows to shade.
        columns: Estimator name -> record column.

    Returns:
        The path written.

    Raises:
        ValueError: If the record has no estimate column.
    """
    present = {name: col for name, col in columns.items() if col in record}
    if not present:
        raise ValueError(
            f"record has none of the estimate columns {sorted(columns.values())}"
        )
    n = np.shape(record["tip_m"])[0]
    x, xlabel = _time_axis(record, n)
    fig, (ax,) = _new_figure(8.0, 3.8)
    errors = []
    for k, (name, col) in enumerate(present.items()):
        err = estimation_error_mm(record, col)
        errors.append(err)
        color = _ESTIMATOR_COLORS.get(name, f"C{(k + 5) % 10}")
        finite = err[np.isfinite(err)]
        mean = float(np.mean(finite)) if finite.size else math.nan
        ax.plot(x, err, "-", color=color, lw=1.0, label=f"{name} (mean {mean:.3f} mm)",
                zorder=3)
    handles, labels = ax.get_legend_handles_labels()
    # Phase shading goes on the lowest axes so every curve is drawn above it.
    bottom = ax
    if record.get("reprojection_error_px") is not None:
        e_s = np.asarray(record["reprojection_error_px"], dtype=float)
        if e_s.shape == (n,):
            twin = ax.twinx()
            twin.plot(x, e_s, "-", color="0.5", lw=0.7, alpha=0.7, label="e_S (px)",
                      zorder=1)
            twin.set_ylabel("reprojection error e_S (px)", color="0.35")
            _ylim_from_zero(twin, [e_s])
            h2, l2 = twin.get_legend_handles_labels()
            handles, labels = handles + h2, labels + l2
            # Estimation errors above e_S: raise the main axes, keep the
            # background of the (now lower) twin visible.
            ax.set_zorder(twin.get_zorder() + 1)
            ax.patch.set_visible(False)
            bottom = twin
    for k, (name, lo, hi) in enumerate(phases or []):
        bottom.axvspan(lo, hi, color="0.85" if k % 2 == 0 else "0.93", zorder=0, lw=0)
        ax.text((lo + hi) / 2.0, 1.01, name, transform=ax.get_xaxis_transform(),
                ha="center", va="bottom", fontsize="small")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("estimation error (mm)")
    _ylim_from_zero(ax, errors)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(handles, labels, loc="upper left", fontsize="small")
    ax.set_title(title, pad=18 if phases else 6)
    return save_figure(fig, path_png)
