"""zhao2021 Table II: the backbone fit on FEM-like shapes with noisy key points (Section V-A).

The paper checks its fit (eqs. (7)-(10)) against FEM: the two-segment arm with one or two
chambers per segment at 1 bar in eight configurations, four 1 N forces along the backbone
(60 mm apart, each turned 90 deg from the last, spiralling round the arm; in the two torsion
configurations the first acts at the arm's edge), the seven key points every 50 mm, and the
eq. (21) error against the FEM centreline (60 points). Uniform noise ``U(-xi, xi)`` on every
coordinate of ``P1..P6`` mimics the networks' error: Table II gives 2.4-3.2 mm at ``xi = 0``
and 2.7-4.0 mm up to ``xi = 4`` mm.

Here the FEM is the zhao2021 arm simulated with twice the preset's links per segment
(:data:`LINKS_PER_SEGMENT`: the true backbone a polyline of 13 mm links) under the same
configurations, forces and noise; the differences from the paper's FEM:

* the chambers take the preset's 0.8 bar (its regulators' limit; the paper's FEM 1 bar);
* the forces act at 20 / 40 / 60 / 80 % of the arm's rest length (the paper's 60 mm on 300 mm)
  and keep their direction in the base frame;
* the arm has no torsional freedom, so an edge force only bends it (the torsion rows differ
  from the others only in their chambers);
* gravity acts, as on the hanging arm.

Every curve of :data:`~soft_gym.papers.zhao2021.backbone_fit.BACKBONE_CURVES` is fitted to the
same noisy key points, and each row counts the subsegments fitted by the paper's ISF and by the
cubic.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from tqdm import tqdm

from eval.report import save_figure
from soft_gym._validation import require_integer, require_seed
from soft_gym.engines import REFERENCE_ENGINE, make_simulator
from soft_gym.robots.presets import get_preset
from soft_gym.papers.zhao2021.frames import paper_pressures_to_chambers
from soft_gym.robots.spec import ArmSpec
from soft_gym.papers.zhao2021.backbone_fit import (BACKBONE_CURVES, fit_backbone,
                                                    mean_backbone_error_m)
from soft_gym.sensing.key_points import key_points_from_backbone
from soft_gym.sensors.fbg import locate, rest_vertex_arcs

CONFIGURATIONS = {"1,4": (1, 4), "1,5": (1, 5), "2,4": (2, 4), "2,5": (2, 5), "3,5": (3, 5),
                  "3,6": (3, 6), "1,2,4,5 (tors.)": (1, 2, 4, 5),
                  "2,3,4,6 (tors.)": (2, 3, 4, 6)}
"""zhao2021 Table II's rows: the paper's chambers (1-3 segment 1, 4-6 segment 2) at full
pressure."""

TORSION = ("1,2,4,5 (tors.)", "2,3,4,6 (tors.)")
"""The rows whose first force acts at the arm's edge (Section V-A)."""

PAPER_TABLE2_MM = {
    "1,4": (2.83, 3.08, 3.29, 3.46), "1,5": (3.16, 3.88, 3.97, 3.61),
    "2,4": (2.91, 3.31, 3.58, 3.68), "2,5": (3.18, 3.23, 3.35, 3.59),
    "3,5": (2.55, 2.69, 2.92, 3.34), "3,6": (2.69, 2.73, 3.17, 3.41),
    "1,2,4,5 (tors.)": (2.42, 2.76, 3.21, 3.53), "2,3,4,6 (tors.)": (2.53, 2.87, 3.32, 3.59)}
"""zhao2021 Table II: mean eq. (21) error (mm) at ``xi`` = :data:`XI_MM`."""

XI_MM = (0.0, 2.0, 3.0, 4.0)
"""Table II's key-point noise bounds (mm)."""

FORCE_N = 1.0
FORCE_ARC_FRACTIONS = (0.2, 0.4, 0.6, 0.8)
LINKS_PER_SEGMENT = 8
HOLD_S = 3.0
"""Each configuration is held this long from rest before the backbone is read (s)."""


def fem_like_arm(links_per_segment: int = LINKS_PER_SEGMENT) -> ArmSpec:
    """The zhao2021 preset with ``links_per_segment`` links per segment (finer than its 4)."""
    links = require_integer("links_per_segment", links_per_segment, 1, 64)
    preset = get_preset("zhao2021")
    return dataclasses.replace(preset, segments=tuple(
        dataclasses.replace(segment, n_links=links) for segment in preset.segments))


def simulate_shapes(links_per_segment: int = LINKS_PER_SEGMENT, engine: str = REFERENCE_ENGINE
                    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each configuration's key points ``P0..P6`` (7, 3) and true backbone (m, 3) (m, base
    frame) on :func:`fem_like_arm`, under the four spiralling forces."""
    spec = fem_like_arm(links_per_segment)
    vertices = rest_vertex_arcs(spec)
    links, _ = locate(vertices, vertices[-1] * np.array(FORCE_ARC_FRACTIONS))
    edge = (0.0, spec.segments[0].outer_radius_m, 0.0)
    sim = make_simulator(spec, engine=engine)
    shapes = {}
    try:
        for name, chambers in CONFIGURATIONS.items():
            sim.reset()
            paper = np.zeros(6)
            paper[[c - 1 for c in chambers]] = spec.segments[0].p_max_pa
            sim.set_pressures(paper_pressures_to_chambers(paper))
            for k, link in enumerate(links):
                angle = 0.5 * np.pi * k
                sim.set_external_force(f"table2_{k}", int(link),
                                       FORCE_N * np.array([np.cos(angle), np.sin(angle), 0.0]),
                                       edge if (k == 0 and name in TORSION) else None)
            sim.step_physics(HOLD_S)
            backbone = sim.backbone()
            shapes[name] = (np.vstack([np.zeros(3), key_points_from_backbone(spec, backbone)]),
                            backbone)  # the next configuration replaces the four forces
    finally:
        sim.close()
    return shapes


def run_table2(seed: int = 0, draws: int = 20, progress: bool = True,
               shapes: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
               ) -> dict[str, Any]:
    """Table II for every curve: mean eq. (21) error (mm) per configuration and ``xi``, over
    ``draws`` noise draws (one at ``xi = 0``), and how many subsegments each method fitted.

    :param seed: seeds the key-point noise.
    :param draws: noisy key-point sets per configuration and ``xi > 0``.
    :param shapes: :func:`simulate_shapes`'s result (simulated here when ``None``).
    """
    seed = require_seed("seed", seed)
    draws = require_integer("draws", draws, 1)
    shapes = simulate_shapes() if shapes is None else shapes
    rng = np.random.default_rng(seed)
    errors = {curve: {name: [] for name in shapes} for curve in BACKBONE_CURVES}
    methods = {curve: {"isf": 0, "cubic": 0} for curve in BACKBONE_CURVES}
    bar = tqdm(total=len(XI_MM) * len(shapes), desc="zhao2021 Table II", disable=not progress,
               leave=False)
    for xi in XI_MM:
        for name, (key_points, truth) in shapes.items():
            per_curve = {curve: [] for curve in BACKBONE_CURVES}
            for _ in range(draws if xi > 0 else 1):
                noisy = key_points.copy()
                noisy[1:] += rng.uniform(-xi, xi, (6, 3)) * 1e-3
                for curve in BACKBONE_CURVES:
                    fit = fit_backbone(noisy, curve=curve)
                    per_curve[curve].append(1000.0 * mean_backbone_error_m(truth, fit.points_m))
                    for method in fit.methods:
                        methods[curve][method] += 1
            for curve in BACKBONE_CURVES:
                errors[curve][name].append(float(np.mean(per_curve[curve])))
            bar.update(1)
    bar.close()
    return {"seed": seed, "draws": draws, "xi_mm": list(XI_MM), "error_mm": errors,
            "mean_error_mm": {curve: np.mean(list(rows.values()), axis=0).tolist()
                              for curve, rows in errors.items()},
            "subsegments": methods,
            "paper_mm": {name: list(row) for name, row in PAPER_TABLE2_MM.items()}}


def report_table2(result: dict[str, Any]) -> list[str]:
    """Markdown lines: Table II per curve beside the paper's."""
    xi = result["xi_mm"]
    header = " | ".join(f"xi = {v:g}" for v in xi)
    lines = [f"Table II: mean backbone error, eq. (21) (mm), {result['draws']} noise draws per "
             f"cell; ours / paper's", "", f"| configuration | curve | {header} |",
             "|---|---|" + "---|" * len(xi)]
    for name, paper in result["paper_mm"].items():
        for curve in BACKBONE_CURVES:
            cells = " | ".join(f"{ours:.2f} / {theirs:.2f}"
                               for ours, theirs in zip(result["error_mm"][curve][name], paper))
            lines.append(f"| {name} | {curve} | {cells} |")
    for curve in BACKBONE_CURVES:
        means = " | ".join(f"{v:.2f}" for v in result["mean_error_mm"][curve])
        counts = result["subsegments"][curve]
        lines.append(f"| mean | {curve} | {means} |")
        lines.append(f"| subsegments | {curve} | ISF {counts['isf']}, cubic {counts['cubic']} |"
                     + " |" * (len(xi) - 1))
    paper_mean = np.mean(list(result["paper_mm"].values()), axis=0)
    lines.append("| mean | paper | " + " | ".join(f"{v:.2f}" for v in paper_mean) + " |")
    return lines


def plot_table2(path: str | Path, result: dict[str, Any]) -> Path:
    """Mean error against ``xi`` per curve, each configuration thin, the paper's in grey."""
    fig = Figure(figsize=(6.5, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    xi = result["xi_mm"]
    for row in result["paper_mm"].values():
        ax.plot(xi, row, color="0.75", lw=0.8)
    ax.plot(xi, np.mean(list(result["paper_mm"].values()), axis=0), color="0.4", lw=2.5,
            label="paper (Table II), mean")
    for curve, colour in zip(BACKBONE_CURVES, ("C0", "C3", "C2")):
        for row in result["error_mm"][curve].values():
            ax.plot(xi, row, color=colour, lw=0.6, alpha=0.5)
        ax.plot(xi, result["mean_error_mm"][curve], color=colour, lw=2.5,
                label=f"ours, curve={curve}")
    ax.set(xlabel="key-point noise xi (mm)", ylabel="mean backbone error, eq. (21) (mm)",
           yscale="log", title="zhao2021 Table II: backbone fit on FEM-like shapes")
    ax.legend(fontsize=8)
    return save_figure(fig, path)
