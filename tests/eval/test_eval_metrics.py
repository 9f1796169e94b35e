"""Tests for eval.metrics and eval.report on synthetic episode records."""

from __future__ import annotations

import json
import math

import matplotlib.pyplot as plt
import numpy as np
import pytest

from eval.metrics import (
    add_improvement,
    aggregate_seeds,
    error_stats,
    estimation_errors,
    improvement,
    is_metric_column,
    path_deviation_mm,
    summarize,
    summary_table,
    tracking_error_mm,
)
from eval.report import (
    csv_columns,
    markdown_table,
    plot_error_time,
    plot_estimation,
    plot_trajectory,
    to_jsonable,
    with_mean_std,
    write_json,
    write_records_csv,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
RADIUS_M = 0.02
HEIGHT_M = 0.1
DT_S = 0.05


# ---------------------------------------------------------------------------
# synthetic records
# ---------------------------------------------------------------------------


def _circle(n: int, radius: float = RADIUS_M) -> np.ndarray:
    """n points of a circle in the plane z = HEIGHT_M, counter-clockwise from +x."""
    theta = 2.0 * np.pi * np.arange(n) / n
    return np.column_stack(
        (radius * np.cos(theta), radius * np.sin(theta), np.full(n, HEIGHT_M))
    )


def _radial_offset(points: np.ndarray, offset_m: np.ndarray | float) -> np.ndarray:
    """Move points in the z = HEIGHT_M plane radially outward by ``offset_m``."""
    xy = points[:, :2]
    r = np.linalg.norm(xy, axis=1, keepdims=True)
    out = points.copy()
    out[:, :2] = xy * (r + np.reshape(offset_m, (-1, 1))) / r
    return out


def _track_record(
    per_cycle: int = 40,
    cycles: int = 3,
    lag: int = 0,
    offsets_m: tuple[float, ...] = (0.0, 0.0, 0.0),
    dense_factor: int = 10,
) -> dict[str, np.ndarray]:
    """Circle tracking record.

    Targets are the vertices ``k * dense_factor`` of the dense polyline, so
    a tip moved radially outward from a target lies exactly ``offset`` from
    the polyline (the nearest point is that vertex).  The tip is the target
    ``lag`` steps earlier (cyclically) moved outward by the cycle's offset.
    """
    poly = _circle(per_cycle * dense_factor)
    one = poly[::dense_factor]
    target = np.tile(one, (cycles, 1))
    t = target.shape[0]
    cycle = np.repeat(np.arange(cycles), per_cycle)
    tip = np.roll(target, lag, axis=0)
    tip = _radial_offset(tip, np.asarray(offsets_m, dtype=float)[cycle])
    n = 3
    return {
        "time_s": np.arange(t) * DT_S,
        "target_m": target,
        "tip_m": tip,
        "feedback_m": tip + np.array([0.0002, -0.0001, 0.0]),
        "action": np.linspace(-1.0, 1.0, t * n).reshape(t, n),
        "pressure_pa": np.linspace(0.0, 3e4, t * n).reshape(t, n),
        "cycle": cycle,
        "polyline_m": poly,
    }


def _estimation_record() -> dict[str, np.ndarray]:
    """Record with estimates of known error: fused 1 mm, camera 0.5 mm then 4 mm."""
    rec = _track_record(per_cycle=40, cycles=2)
    t = rec["tip_m"].shape[0]
    rec["fused_m"] = rec["tip_m"] + np.array([0.001, 0.0, 0.0])
    cam_err = np.where(rec["time_s"] < 2.0, 0.0005, 0.004)
    rec["camera_m"] = rec["tip_m"] + np.column_stack((np.zeros(t), cam_err, np.zeros(t)))
    rec["reprojection_error_px"] = np.where(rec["time_s"] < 2.0, 0.5, 3.0)
    return rec


# ---------------------------------------------------------------------------
# per-step errors and statistics
# ---------------------------------------------------------------------------


def test_path_deviation_equals_radial_offset() -> None:
    rec = _track_record(offsets_m=(0.003, 0.003, 0.003))
    dev = path_deviation_mm(rec)
    assert dev.shape == (rec["tip_m"].shape[0],)
    np.testing.assert_allclose(dev, 3.0, rtol=0, atol=1e-9)


def test_path_deviation_is_nan_without_polyline() -> None:
    rec = _track_record()
    del rec["polyline_m"]
    dev = path_deviation_mm(rec)
    assert dev.shape == (rec["tip_m"].shape[0],)
    assert np.all(np.isnan(dev))
    summary = summarize(rec)
    assert math.isnan(summary["deviation"]["mean_mm"])
    assert summary["deviation"]["n"] == 0


@pytest.mark.smoke
def test_tracking_error_of_known_lag() -> None:
    per_cycle, lag = 40, 3
    rec = _track_record(per_cycle=per_cycle, lag=lag)
    chord_mm = 2.0 * RADIUS_M * math.sin(math.pi * lag / per_cycle) * 1000.0
    err = tracking_error_mm(rec)
    np.testing.assert_allclose(err, chord_mm, rtol=1e-12)
    # A lagging tip on the path has zero deviation.
    np.testing.assert_allclose(path_deviation_mm(rec), 0.0, atol=1e-9)
    summary = summarize(rec)
    assert summary["tracking"]["mean_mm"] == pytest.approx(chord_mm, rel=1e-12)
    assert summary["tracking"]["max_mm"] == pytest.approx(chord_mm, rel=1e-12)
    assert summary["tracking"]["std_mm"] == pytest.approx(0.0, abs=1e-9)
    assert summary["tracking"]["final_mm"] == pytest.approx(chord_mm, rel=1e-12)


def test_tracking_error_shape_mismatch_raises() -> None:
    rec = _track_record()
    rec["target_m"] = rec["target_m"][:-1]
    with pytest.raises(ValueError, match="target_m"):
        tracking_error_mm(rec)
    with pytest.raises(ValueError, match="tip_m"):
        tracking_error_mm({"target_m": np.zeros((3, 3))})


def test_per_cycle_split() -> None:
    rec = _track_record(offsets_m=(0.001, 0.002, 0.003))
    s = summarize(rec)
    assert s["n_steps"] == 120 and s["n_cycles"] == 3 and s["cycles"] == [0, 1, 2]
    dev = s["deviation"]
    np.testing.assert_allclose(dev["per_cycle"]["mean_mm"], [1.0, 2.0, 3.0], atol=1e-9)
    np.testing.assert_allclose(dev["per_cycle"]["max_mm"], [1.0, 2.0, 3.0], atol=1e-9)
    np.testing.assert_allclose(dev["per_cycle"]["std_mm"], 0.0, atol=1e-9)
    assert dev["per_cycle"]["n"] == [40, 40, 40]
    assert dev["mean_mm"] == pytest.approx(2.0)
    assert dev["max_mm"] == pytest.approx(3.0)
    assert dev["std_mm"] == pytest.approx(math.sqrt(2.0 / 3.0))
    assert dev["rmse_mm"] == pytest.approx(math.sqrt(14.0 / 3.0))
    # Zero lag: the tracking error is the radial offset too.
    np.testing.assert_allclose(s["tracking"]["per_cycle"]["mean_mm"], [1.0, 2.0, 3.0], atol=1e-9)


def test_reach_record_is_one_cycle() -> None:
    t = 25
    target = np.tile([[0.01, 0.0, 0.1]], (t, 1))
    tip = target + np.array([0.0, 0.002, 0.0])
    s = summarize({"target_m": target, "tip_m": tip})
    assert s["n_cycles"] == 1 and s["cycles"] == [0]
    assert s["tracking"]["per_cycle"]["mean_mm"] == [pytest.approx(2.0)]


@pytest.mark.smoke
def test_error_stats_match_numpy() -> None:
    rng = np.random.default_rng(3)
    e = rng.gamma(2.0, 1.5, size=500)
    stats = error_stats(e)
    assert stats["mean_mm"] == pytest.approx(np.mean(e))
    assert stats["std_mm"] == pytest.approx(np.std(e))
    assert stats["max_mm"] == pytest.approx(np.max(e))
    assert stats["rmse_mm"] == pytest.approx(np.sqrt(np.mean(e**2)))
    assert stats["n"] == 500
    # Non-finite samples are left out.
    stats_nan = error_stats(np.append(e, [np.nan, np.inf]))
    assert stats_nan["mean_mm"] == pytest.approx(np.mean(e)) and stats_nan["n"] == 500
    empty = error_stats(np.array([np.nan]))
    assert empty["n"] == 0 and math.isnan(empty["rmse_mm"])


def test_rmse_of_record_matches_numpy() -> None:
    rec = _track_record()
    rng = np.random.default_rng(0)
    rec["tip_m"] = rec["tip_m"] + rng.normal(0.0, 0.001, rec["tip_m"].shape)
    err = np.linalg.norm(rec["target_m"] - rec["tip_m"], axis=1) * 1000.0
    s = summarize(rec)
    assert s["tracking"]["rmse_mm"] == pytest.approx(np.sqrt(np.mean(err**2)))
    assert s["tracking"]["std_mm"] == pytest.approx(np.std(err))
    per = [np.sqrt(np.mean(err[rec["cycle"] == c] ** 2)) for c in range(3)]
    np.testing.assert_allclose(s["tracking"]["per_cycle"]["rmse_mm"], per)


def test_estimation_errors_and_phases() -> None:
    rec = _estimation_record()
    out = estimation_errors(rec, phases=[("clear", 0.0, 2.0), ("occluded", 2.0, 4.0)])
    assert list(out) == ["camera", "fused"]
    fused = out["fused"]
    assert fused["mean_mm"] == pytest.approx(1.0)
    assert fused["max_mm"] == pytest.approx(1.0)
    assert fused["rmse_mm"] == pytest.approx(1.0)
    assert fused["std_mm"] == pytest.approx(0.0, abs=1e-9)
    cam = out["camera"]
    # time < 2 s: 40 steps at 0.5 mm; 2 s .. 4 s: 40 steps at 4 mm.
    assert cam["mean_mm"] == pytest.approx(2.25)
    assert cam["max_mm"] == pytest.approx(4.0)
    assert cam["rmse_mm"] == pytest.approx(math.sqrt((0.25 + 16.0) / 2.0))
    assert cam["phases"]["clear"]["mean_mm"] == pytest.approx(0.5)
    assert cam["phases"]["clear"]["n"] == 40
    assert cam["phases"]["occluded"]["mean_mm"] == pytest.approx(4.0)
    assert "phases" not in estimation_errors(rec)["camera"]
    assert estimation_errors(_track_record()) == {}
    with pytest.raises(ValueError, match="end_s > start_s"):
        estimation_errors(rec, phases=[("bad", 2.0, 1.0)])


# ---------------------------------------------------------------------------
# improvement and tables
# ---------------------------------------------------------------------------


@pytest.mark.smoke
def test_improvement_formula() -> None:
    assert improvement(10.0, 2.5) == pytest.approx(0.75)
    # Table I of Wang et al. 2023, K_p = 0.04: 16.942 -> 2.305 mm is 86.4 %.
    assert improvement(16.942, 2.305) == pytest.approx(0.864, abs=5e-4)
    assert improvement(2.0, 3.0) == pytest.approx(-0.5)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="positive finite baseline"):
            improvement(bad, 1.0)
    with pytest.raises(ValueError, match="finite value"):
        improvement(1.0, math.nan)


def _rows() -> list[dict]:
    """Flat rows: two policies x two seeds with known tracking errors."""
    pairs = []
    means = {("cc_model", 0): 0.004, ("cc_model", 1): 0.006,
             ("hybrid_gpr", 0): 0.001, ("hybrid_gpr", 1): 0.002}
    for (policy, seed), offset in means.items():
        rec = _track_record(offsets_m=(offset, offset, offset))
        labels = {"policy": policy, "kp": 0.06, "path": "circle", "seed": seed}
        pairs.append((labels, summarize(rec)))
    return summary_table(pairs)


def test_summary_table_columns() -> None:
    rows = _rows()
    assert len(rows) == 4
    row = rows[0]
    assert list(row)[:4] == ["policy", "kp", "path", "seed"]
    for col in ("track_mean_mm", "track_std_mm", "track_max_mm", "track_rmse_mm",
                "dev_mean_mm", "dev_std_mm", "dev_max_mm", "dev_rmse_mm",
                "track_mean_mm_cycle1", "track_mean_mm_cycle3", "dev_max_mm_cycle2",
                "n_steps", "n_cycles"):
        assert col in row, col
    assert "track_mean_mm_cycle4" not in row
    assert row["track_mean_mm"] == pytest.approx(4.0)
    assert row["dev_mean_mm_cycle2"] == pytest.approx(4.0)
    assert all(list(r) == list(row) for r in rows)
    assert is_metric_column("track_mean_mm") and not is_metric_column("kp")


def test_summary_table_fills_missing_columns() -> None:
    one = summarize(_track_record(cycles=1, offsets_m=(0.001,)))
    three = summarize(_track_record())
    rows = summary_table([({"policy": "a"}, one), ({"policy": "b", "seed": 1}, three)])
    assert list(rows[0]) == list(rows[1])
    assert math.isnan(rows[0]["track_mean_mm_cycle3"])
    assert rows[0]["seed"] is None
    with pytest.raises(ValueError, match="clash"):
        summary_table([({"track_mean_mm": 1}, one)])


def test_aggregate_seeds() -> None:
    agg = aggregate_seeds(_rows())
    assert len(agg) == 2
    cc, hy = agg
    assert cc["policy"] == "cc_model" and hy["policy"] == "hybrid_gpr"
    assert "seed" not in cc
    assert cc["n_seeds"] == 2 and cc["kp"] == 0.06 and cc["path"] == "circle"
    assert cc["track_mean_mm"] == pytest.approx(5.0)
    assert cc["track_mean_mm_seed_std"] == pytest.approx(np.std([4.0, 6.0], ddof=1))
    assert hy["dev_max_mm"] == pytest.approx(1.5)
    assert hy["dev_max_mm_seed_std"] == pytest.approx(np.std([1.0, 2.0], ddof=1))
    # Explicit grouping; a single seed has NaN spread.
    by_policy = aggregate_seeds(_rows()[:1], by=["policy"])
    assert list(by_policy[0])[:2] == ["policy", "n_seeds"]
    assert math.isnan(by_policy[0]["track_mean_mm_seed_std"])
    # Grouping that mixes runs with the same seed is an error.
    with pytest.raises(ValueError, match="repeat"):
        aggregate_seeds(_rows(), by=["path"])


def test_add_improvement_per_seed_and_aggregated() -> None:
    rows = add_improvement(_rows())
    by_key = {(r["policy"], r["seed"]): r["improvement_%"] for r in rows}
    assert by_key[("cc_model", 0)] == pytest.approx(0.0)
    assert by_key[("hybrid_gpr", 0)] == pytest.approx(75.0)  # 4 mm -> 1 mm
    assert by_key[("hybrid_gpr", 1)] == pytest.approx(100.0 * (6.0 - 2.0) / 6.0)
    agg = add_improvement(aggregate_seeds(_rows()), metric="dev_mean_mm", column="dev_improv_%")
    assert agg[1]["dev_improv_%"] == pytest.approx(100.0 * (5.0 - 1.5) / 5.0)
    # No matching baseline -> NaN; an explicit match list works too.
    lone = add_improvement(_rows(), baseline={"policy": "missing"})
    assert all(math.isnan(r["improvement_%"]) for r in lone)
    explicit = add_improvement(_rows(), match=["seed"])
    assert explicit[3]["improvement_%"] == pytest.approx(by_key[("hybrid_gpr", 1)])
    with pytest.raises(ValueError, match="baseline rows match"):
        add_improvement(_rows(), match=["path"])
    with pytest.raises(ValueError, match="metric"):
        add_improvement(_rows(), metric="no_such_metric")


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------


def test_csv_round_trip(tmp_path) -> None:
    rec = _estimation_record()
    path = write_records_csv(tmp_path / "sub" / "episode.csv", rec)
    assert path.exists() and path.stat().st_size > 0
    data = np.genfromtxt(path, delimiter=",", names=True)
    names = data.dtype.names
    assert names[:5] == ("time_s", "cycle", "target_x_m", "target_y_m", "target_z_m")
    for col in ("tip_z_m", "feedback_x_m", "action_2", "pressure_0_pa", "camera_y_m",
                "fused_x_m", "reprojection_error_px", "tracking_error_mm", "path_deviation_mm"):
        assert col in names, col
    assert not any(n.startswith("polyline") for n in names)
    assert data.shape == (rec["tip_m"].shape[0],)
    np.testing.assert_array_equal(data["time_s"], rec["time_s"])
    np.testing.assert_array_equal(data["cycle"], rec["cycle"])
    tip = np.column_stack([data[f"tip_{a}_m"] for a in "xyz"])
    np.testing.assert_array_equal(tip, rec["tip_m"])
    np.testing.assert_array_equal(data["pressure_1_pa"], rec["pressure_pa"][:, 1])
    np.testing.assert_allclose(data["tracking_error_mm"], tracking_error_mm(rec))
    names2, matrix = csv_columns(rec, include_errors=False)
    assert "tracking_error_mm" not in names2 and matrix.shape == (len(data), len(names2))


def test_write_json_numpy_safe(tmp_path) -> None:
    obj = {
        "summary": summarize(_track_record()),
        "array": np.arange(3),
        "scalar": np.float32(1.5),
        "int": np.int64(7),
        "flag": np.bool_(True),
        "nan": float("nan"),
        "labels": ("a", 1),
    }
    path = write_json(tmp_path / "out.json", obj)
    loaded = json.loads(path.read_text())
    assert loaded["array"] == [0, 1, 2]
    assert loaded["scalar"] == 1.5 and loaded["int"] == 7 and loaded["flag"] is True
    assert loaded["nan"] is None and loaded["labels"] == ["a", 1]
    assert loaded["summary"]["n_cycles"] == 3
    assert to_jsonable({1: np.array([np.inf])}) == {"1": [None]}


def test_markdown_table() -> None:
    rows = add_improvement(_rows())
    text = markdown_table(rows, columns=["policy", "kp", "seed", "track_mean_mm", "improvement_%"])
    lines = text.strip("\n").split("\n")
    assert len(lines) == 2 + len(rows)
    assert lines[0] == "| policy | kp | seed | track_mean_mm | improvement_% |"
    assert lines[1] == "| --- | ---: | ---: | ---: | ---: |"
    assert lines[3] == "| cc_model | 0.060 | 1 | 6.000 | 0.000 |"
    assert all(line.startswith("| ") and line.endswith(" |") for line in lines)
    # Header renaming, NaN, None and pipe escaping.
    odd = [{"a": float("nan"), "b": None, "c": "x|y"}]
    text = markdown_table(odd, columns={"a": "A", "b": "B", "c": "C"}, float_format="{:.1f}")
    assert text.splitlines() == ["| A | B | C |", "| ---: | --- | --- |", "| nan |  | x\\|y |"]
    full = markdown_table(rows)
    assert len(full.splitlines()) == 2 + len(rows)
    with pytest.raises(ValueError):
        markdown_table([])


def test_with_mean_std() -> None:
    rows = with_mean_std([{"m": 16.942, "s": 5.421}, {"m": 1.0}, {"m": 2.0, "s": float("nan")}],
                         "m", "s", column="pm")
    assert rows[0]["pm"] == "16.942 ± 5.421"
    assert rows[1]["pm"] == ""
    assert rows[2]["pm"] == "2.000"


def _assert_png(path) -> None:
    assert path.exists() and path.stat().st_size > 1000
    assert path.read_bytes()[:8] == PNG_SIGNATURE


def test_plots_write_png(tmp_path) -> None:
    figures_before = plt.get_fignums()
    track = _track_record(lag=2, offsets_m=(0.001, 0.0005, 0.0002))
    est = _estimation_record()
    p1 = plot_trajectory(tmp_path / "plots" / "traj.png", track, "circle, hybrid")
    p2 = plot_error_time(tmp_path / "err.png", {"cc_model": track, "hybrid_gpr": est}, "errors")
    p3 = plot_estimation(tmp_path / "est.png", est, "estimation",
                         phases=[("clear", 0.0, 2.0), ("occluded", 2.0, 4.0)])
    reach = {"target_m": np.tile([[0.01, 0.0, 0.1]], (10, 1)),
             "tip_m": np.linspace([0.0, 0.0, 0.1], [0.01, 0.0, 0.1], 10)}
    p4 = plot_trajectory(tmp_path / "reach.png", reach, "reach", plane="xz")
    p5 = plot_error_time(tmp_path / "reach_err.png", {"reach": reach}, "reach")
    for p in (p1, p2, p3, p4, p5):
        _assert_png(p)
    assert plt.get_fignums() == figures_before
    with pytest.raises(ValueError, match="estimate columns"):
        plot_estimation(tmp_path / "none.png", track, "none")
    with pytest.raises(ValueError):
        plot_error_time(tmp_path / "none.png", {}, "none")
    with pytest.raises(ValueError, match="plane"):
        plot_trajectory(tmp_path / "none.png", track, "none", plane="xw")


def test_plots_are_deterministic(tmp_path) -> None:
    rec = _estimation_record()
    a = plot_trajectory(tmp_path / "a.png", rec, "same").read_bytes()
    b = plot_trajectory(tmp_path / "b.png", rec, "same").read_bytes()
    assert a == b
    c = plot_estimation(tmp_path / "c.png", rec, "same").read_bytes()
    d = plot_estimation(tmp_path / "d.png", rec, "same").read_bytes()
    assert c == d


def test_comparison_grid_writes_tables_and_plots(tmp_path):
    from eval.compare import run_comparison

    rows = run_comparison(["cc_model", "hybrid_gpr"], paths=["circle"],
                          conditions=["nominal", "heavy_load"], seeds=[0], out=tmp_path,
                          cycles=1, feedback="ground_truth", progress=False)
    assert {(r["policy"], r["condition"]) for r in rows} == {
        (p, c) for p in ("cc_model", "hybrid_gpr") for c in ("nominal", "heavy_load")}
    assert all(r["vs cc_model (%)"] == 0.0 for r in rows if r["policy"] == "cc_model")
    for name in ("compare.md", "compare.csv", "compare.json", "compare_circle.png",
                 "error_circle_nominal.png", "error_circle_heavy_load.png"):
        assert (tmp_path / name).is_file(), name
    with pytest.raises(ValueError, match="conditions"):
        run_comparison(["cc_model"], ["circle"], ["underwater"], [0], tmp_path)


def test_agents_are_compared_with_the_model_at_the_first_gain():
    from eval.commands.track import _agents_against_first_gain

    def row(policy, kp, mean, last, dev):
        return {"policy": policy, "kp": kp, "seed": 0, "track_mean_mm": mean,
                "track_last_cycle_mm": last, "dev_last_cycle_mm": dev}

    table = [row("cc_model", 0.04, 4.0, 4.0, 2.0), row("cc_model", 0.1, 2.0, 2.0, 1.0),
             row("sb3:agent", None, 1.0, 3.0, 3.0)]
    _agents_against_first_gain(table, 0.04)
    assert table[2]["improvement_%"] == pytest.approx(75.0)
    assert table[2]["improvement_last_%"] == pytest.approx(25.0)
    assert table[2]["dev_improvement_last_%"] == pytest.approx(-50.0)
    assert "improvement_%" not in table[0]


def test_compare_heavy_load_lies_outside_the_training_randomisation() -> None:
    """``eval compare``'s out-of-distribution load must weigh more than anything the shipped
    agents' training randomisation draws (static tip masses and filled containers)."""
    from eval.compare import CONDITIONS
    from soft_gym.scenarios import make_scenario
    from soft_gym.scenarios.loads import heaviest_total_load_n
    from soft_gym.scenarios.randomization import DomainRandomizer, RandomizationConfig

    heaviest_trained = max(DomainRandomizer(RandomizationConfig(), n_links=4,
                                            with_camera=False).heaviest_loads_n(9.81).values())
    heavy = heaviest_total_load_n(make_scenario(CONDITIONS["heavy_load"]["scenario"]), 9.81)
    assert heavy > 1.5 * heaviest_trained, (heavy, heaviest_trained)
