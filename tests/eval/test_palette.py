"""One colour per policy in every plot (eval/palette.py), and the plots that use it: the error
plot's colours and shared y-scale, the suite report's one-seed aggregates ("1 seed: no
interval"), one y-scale per arm across its error plots, and the benchmark plot's title."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_hex

import eval.report
from agents.policies import BASELINES, shipped_agents
from eval import suite
import eval.papers.wang2023.benchmark_command as paper_benchmark
from eval.commands.track import _track_title
from eval.palette import (MIN_DELTA_E, PALETTE, agent_family, delta_e, lab, named_policies,
                          policy_color, policy_colors, policy_label)
from eval.report import error_peaks_mm, plot_error_time


class _Axes:
    """What a test reads of a saved figure's axes (saving clears the figure)."""

    def __init__(self, ax) -> None:
        self.lines = [(line.get_label(), to_hex(line.get_color()), str(line.get_linestyle()))
                      for line in ax.get_lines()]
        self.ylim = ax.get_ylim()
        self.title = ax.get_title()
        self.xlabel = ax.get_xlabel()
        self.texts = [text.get_text() for text in ax.texts]


def _capture(monkeypatch, module) -> list[list[_Axes]]:
    """The axes of every figure handed to ``module.save_figure`` (then written as usual)."""
    figures = []
    original = eval.report.save_figure

    def save(figure, path):
        figures.append([_Axes(ax) for ax in figure.axes])
        return original(figure, path)

    monkeypatch.setattr(module, "save_figure", save)
    return figures


def _record(scale_mm: float, steps: int = 40) -> dict[str, np.ndarray]:
    """A run whose tracking error rises linearly to ``scale_mm`` (and a polyline)."""
    t = np.arange(1, steps + 1) * 0.05
    target = np.zeros((steps, 3))
    tip = target.copy()
    tip[:, 0] = np.linspace(0.0, scale_mm / 1000.0, steps)
    square = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.01, 0.01, 0.0], [0.0, 0.01, 0.0]])
    return {"time_s": t, "target_m": target, "tip_m": tip, "feedback_m": tip,
            "error_mm": np.linalg.norm(tip - target, axis=1) * 1000.0,
            "cycle": np.zeros(steps, dtype=int), "polyline_m": square}


@pytest.mark.smoke
def test_every_named_policy_has_its_own_colour_and_a_name_keeps_its_colour():
    named = named_policies()
    assert list(named[:len(BASELINES)]) == list(BASELINES)
    assert set(named[len(BASELINES):]) == set(shipped_agents()) - set(BASELINES)
    colours = [policy_color(name) for name in named]
    # a baseline has a colour of its own; an agent its family's (the same algorithm on another
    # arm, never drawn beside it), none of them a baseline's
    baseline_colours = colours[:len(BASELINES)]
    assert len(set(baseline_colours)) == len(BASELINES)
    agents = named[len(BASELINES):]
    for first in agents:
        assert policy_color(first) not in baseline_colours
        for second in agents:
            assert (policy_color(first) == policy_color(second)) == (
                agent_family(first) == agent_family(second)), (first, second)
    assert agent_family("ppo_lstm_wang2023_fused") == "ppo_lstm_fused"
    assert policy_color("sb3:agents/trained/sac_wang2023_track") == \
        policy_color("sac_wang2023_track") == policy_color("sb3:sac_wang2023_track")
    assert policy_label("sb3:/some/run/dir") == "dir"
    other = policy_color("my_label")
    assert other == policy_color("my_label") and other in PALETTE
    assert other not in colours  # names outside the registries take the spare colours
    with pytest.raises(TypeError, match="policy must be a str, got int"):
        policy_color(3)


def test_the_error_plot_draws_each_policy_in_its_colour_on_the_given_scale(tmp_path,
                                                                         monkeypatch):
    figures = _capture(monkeypatch, eval.report)
    records = {"hybrid_gpr": _record(4.0), "cc_model": _record(2.0)}
    plot_error_time(tmp_path / "a.png", records, "a")
    plot_error_time(tmp_path / "b.png", {"cc_model": _record(1.0)}, "b", ymax_mm=[9.0, 7.0])
    first, second = figures
    for name in records:  # the same colour whatever the order in the plot
        (colour,) = [colour for label, colour, _ in first[0].lines
                     if label.startswith(name + " (mean")]
        assert colour == policy_color(name)
    assert [ax.ylim for ax in second] == [(0.0, 9.0), (0.0, 7.0)]
    # one policy at two gains: one colour, two line styles
    plot_error_time(tmp_path / "c.png", {"cc_model_kp0.04": _record(1.0),
                                         "cc_model_kp0.1": _record(2.0)}, "c",
                    colors={"cc_model_kp0.04": policy_color("cc_model"),
                            "cc_model_kp0.1": policy_color("cc_model")})
    lines = [line for line in figures[2][0].lines if "(mean" in line[0]]
    assert {colour for _, colour, _ in lines} == {policy_color("cc_model")}
    assert len({style for _, _, style in lines}) == 2
    assert error_peaks_mm([_record(2.0), _record(5.0)])[0] == pytest.approx(5.0 * 1.08)


SPEC = """\
name: plots
seeds: [0]
cycles: 1
arms:
  wang2023:
    paths: [circle]
    feedback: ground_truth
    conditions:
      nominal: {}
      loaded: {scenario: {name: tip_mass, mass_kg: 0.01}}
    policies: [cc_model, hybrid_gpr]
"""


def test_one_seed_aggregates_say_there_is_no_interval(tmp_path, monkeypatch):
    pytest.importorskip("rliable")
    from eval.suite import report

    path = tmp_path / "plots.yaml"
    path.write_text(textwrap.dedent(SPEC))
    spec = suite.load_suite(path)
    one = {"cc_model": np.array([[1.27, 2.0]]), "hybrid_gpr": np.array([[1.0, 1.5]])}
    three = {"cc_model": np.array([[1.0, 2.0], [1.5, 2.5], [1.2, 3.0]])}
    for matrices, seeds in ((one, 1), (three, 3)):
        per_arm = {"wang2023": {"aggregates": report.aggregate_scores(matrices, reps=50),
                                "excluded": {}}}
        text = report.leaderboard_markdown(spec, [], {}, per_arm,
                                           {"done": 0, "n/a": 0, "missing": 0})
        figures = _capture(monkeypatch, report)
        report._plot_aggregates(tmp_path / f"aggregate_{seeds}.png", per_arm)
        title = figures[0][0].title
        if seeds == 1:
            assert text.count(report.NO_INTERVAL) == 2 * len(one)  # IQM and mean, per policy
            assert "[1.27, 1.27]" not in text and "95% CI (bar)" not in title
            assert report.NO_INTERVAL in title
        else:
            assert report.NO_INTERVAL not in text and "95% CI (bar)" in title


def test_the_error_plots_of_one_arm_share_a_y_scale(tmp_path, monkeypatch):
    pytest.importorskip("rliable")
    from eval.suite import report

    path = tmp_path / "plots.yaml"
    path.write_text(textwrap.dedent(SPEC))
    spec = suite.load_suite(path)
    cells = suite.expand(spec)
    scale = {"nominal": 2.0, "loaded": 20.0}
    steps = {cell.key: _record(scale[cell.labels["condition"]]
                               * (2 if cell.labels["policy"] == "hybrid_gpr" else 1))
             for cell in cells}
    monkeypatch.setattr(report, "read_steps", lambda out, key: steps[key])
    figures = _capture(monkeypatch, eval.report)
    rows = [{"key": cell.key, "status": "done"} for cell in cells]
    report._plot_first_seed(tmp_path / "plots", report._first_seed_groups(cells, rows, 0),
                            tmp_path, 0)
    assert len(figures) == 2  # nominal and loaded error plots
    for figure in figures:  # the loaded hybrid_gpr's 40 mm peak sets both
        assert figure[0].ylim == pytest.approx((0.0, 40.0 * 1.08))
    assert (tmp_path / "plots" / "error_wang2023_circle_nominal.png").is_file()


def test_the_benchmark_plot_title_names_the_load_and_the_occlusion_window():
    title = paper_benchmark.benchmark_title().format(end_s=61.9)
    load_g = paper_benchmark.BENCHMARK_LOAD_KG * 1000
    start = paper_benchmark.BENCHMARK_OCCLUDER["start_s"]
    assert f"{load_g:g} g tip load" in title
    assert f"from {start:g} s to 62 s (the end)" in title and "partial occluder" in title
    args = type("Args", (), {"title": paper_benchmark.benchmark_title(), "preset": "wang2023",
                             "path": "circle"})()
    assert _track_title(args, {"a": {"time_s": np.array([0.05, 61.9])}}) == title


DELTA_E = 20.0
"""The least CIE76 delta-E between two policies drawn together (one arm of a suite)."""


def test_lab_conversion_matches_reference_values():
    """The small sRGB -> CIE L*a*b* (D65) conversion behind delta_e, on known values."""
    assert lab("#ffffff") == pytest.approx([100.0, 0.0, 0.0], abs=0.05)
    assert lab("#000000") == pytest.approx([0.0, 0.0, 0.0], abs=0.05)
    assert lab("#ff0000") == pytest.approx([53.24, 80.09, 67.20], abs=0.05)
    assert lab("#0000ff") == pytest.approx([32.30, 79.19, -107.86], abs=0.05)
    assert delta_e("#ff0000", "#ff0000") == 0.0


def test_the_palette_has_no_two_close_colours_and_no_light_shades():
    """Every two colours of the palette differ by MIN_DELTA_E (>= DELTA_E), and it holds none of
    tab20's light shades (the light orange once drawn beside local_ik_asdm's orange)."""
    import itertools

    from matplotlib.colors import to_hex
    from matplotlib import colormaps

    assert MIN_DELTA_E >= DELTA_E
    for first, second in itertools.combinations(PALETTE, 2):
        assert delta_e(first, second) >= MIN_DELTA_E, (first, second)
    light = {to_hex(colour) for colour in colormaps["tab20"].colors[1::2]}
    assert not light & set(PALETTE)
    assert policy_color("local_ik_asdm") != policy_color("sac_zhao2021_track")


@pytest.mark.parametrize("name", sorted(suite.bundled_suites()))
def test_policies_drawn_together_in_a_bundled_suite_have_distinct_colours(name):
    """Every pair of policies of one arm of a bundled suite (drawn together in each of its plots
    and panels) differs by at least DELTA_E in CIE76 delta-E, in the colours the suite's report
    draws them with."""
    from eval.suite import report

    spec = suite.load_suite(name)
    colours = report.suite_colors(spec)
    for arm in spec.arms:
        labels = [policy.label for policy in arm.policies]
        for i, first in enumerate(labels):
            for second in labels[i + 1:]:
                difference = delta_e(colours[first], colours[second])
                assert difference >= DELTA_E, (name, arm.preset, first, second, difference)
        # and so do the colours each plot of the arm picks for its own set
        own = policy_colors(labels)
        assert len(set(own.values())) == len(labels)


def test_a_suites_own_labels_take_free_colours_and_keep_them():
    """Two labels outside the registries hashed onto one spare colour are moved apart; the named
    policies keep their colours; the same set gives the same colours."""
    labels = ["lwpr_rwr", "run_a", "run_b", "run_c", "run_d", "run_e"]
    colours = policy_colors(labels)
    assert colours["lwpr_rwr"] == policy_color("lwpr_rwr")
    assert len(set(colours.values())) == len(labels)
    assert colours == policy_colors(labels)


@pytest.mark.parametrize("seeds", [[0], [0, 1, 2, 3, 4]])
def test_performance_profiles_need_enough_runs_and_name_their_axis(seeds, tmp_path, monkeypatch):
    """The profile's x axis says what tau is (the error threshold, mm); a policy with fewer than
    PROFILE_MIN_RUNS scores on an arm (one seed x two conditions: 2) gets no profile, and the
    panel and the leaderboard say why; with five seeds (10 scores) both profiles are drawn."""
    pytest.importorskip("rliable")
    from eval.suite import report

    path = tmp_path / "plots.yaml"
    path.write_text(textwrap.dedent(SPEC))
    spec = suite.load_suite(path).with_seeds(seeds)
    out = tmp_path / "out"
    for k, cell in enumerate(suite.expand(spec)):
        error = 1.0 + 0.1 * k
        suite.write_record(out, {
            "key": cell.key, "suite": spec.name, "labels": cell.labels, "config": cell.config,
            "wall_s": 1.0, "versions": {}, "git_revision": "abc", "steps": None,
            "status": "done", "reason": None,
            "metrics": {"last_cycle_error_mm": error, "mean_error_mm": error,
                        "max_error_mm": error, "path_deviation_mm": error}})
    figures = _capture(monkeypatch, report)
    text = report.write_report(spec, out, reps=20, profile_reps=20)
    profile = next(axes[0] for axes in figures if axes[0].xlabel == report.PROFILE_AXIS)
    assert "error threshold (mm)" in report.PROFILE_AXIS
    runs = len(seeds) * 2
    drawn = {label for label, _, _ in profile.lines}
    if runs < report.PROFILE_MIN_RUNS:
        assert not drawn & {"cc_model", "hybrid_gpr"}
        assert any(f"{runs} runs x tasks" in t and f"fewer than the {report.PROFILE_MIN_RUNS}"
                   in t for t in profile.texts)
        assert (f"No performance profile drawn for cc_model ({runs} runs x tasks, fewer than "
                f"{report.PROFILE_MIN_RUNS})") in text
    else:
        assert {"cc_model", "hybrid_gpr"} <= drawn and not profile.texts
        assert "performance profile" not in text
