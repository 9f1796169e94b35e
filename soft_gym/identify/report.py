"""What a fit leaves beside the fitted arm file: a YAML report and a plot of measured against
simulated tip paths."""

from __future__ import annotations

import hashlib
from pathlib import Path

import yaml

from soft_gym.identify.fit import UNIDENTIFIABLE_RELATIVE_SE, FitResult
from soft_gym.identify.log import ArmLog

REPORT_SUFFIX = ".identify.yaml"
PLOT_SUFFIX = ".identify.png"
"""The report and the plot are named after the arm file: ``ARM.yaml`` gets ``ARM.identify.yaml``
and ``ARM.identify.png``."""


def companion_paths(arm_file: str | Path) -> tuple[Path, Path]:
    """The report's and the plot's paths beside the arm file ``arm_file``."""
    arm_file = Path(arm_file)
    stem = arm_file.with_suffix("")
    return stem.with_name(stem.name + REPORT_SUFFIX), stem.with_name(stem.name + PLOT_SUFFIX)


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of the file's bytes, as hex."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def report_document(result: FitResult, base_name: str, log_path: str | Path, engine: str,
                    log: ArmLog) -> dict:
    """The report as plain data: the fitted values with standard errors (SI units of each field)
    and identifiability, the RMS tip errors (mm) and where the log came from."""
    return {
        "arm": result.spec.name,
        "base_preset": base_name,
        "engine": engine,
        "log": {"path": str(log_path), "sha256": file_sha256(log_path),
                "samples": log.n_samples, "fitted_samples": result.n_fit,
                "duration_s": float(log.times_s[-1] - log.times_s[0])},
        "unidentifiable_rule": (f"relative standard error > {UNIDENTIFIABLE_RELATIVE_SE:.0%} "
                                f"or J^T J singular along the parameter"),
        "parameters": {
            parameter.name: {
                "base": parameter.base, "value": parameter.value,
                "standard_error": parameter.standard_error,
                "relative_standard_error": parameter.relative_standard_error,
                "identifiable": parameter.identifiable, "at_bound": parameter.at_bound}
            for parameter in result.parameters},
        "rms_tip_error_mm": {"fit": result.fit_rms_mm, "held_out": result.held_out_rms_mm,
                             "base_arm": result.base_rms_mm},
        "evaluations": result.evaluations,
    }


def write_report(path: str | Path, document: dict) -> Path:
    """Write the report ``document`` as YAML to ``path`` (an infinite standard error as
    ``.inf``); returns the path."""
    path = Path(path)
    text = yaml.safe_dump(document, sort_keys=False, width=100)
    path.write_text(text, encoding="utf-8")
    return path


def plot_tip_paths(path: str | Path, result: FitResult, log: ArmLog) -> Path:
    """Save a PNG of the measured and simulated tip: x, y and z over time (the held-out part
    shaded) and the path seen from below the base (x against y), in mm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = log.times_s - log.times_s[0]
    measured = log.tip_positions_m * 1e3
    simulated = result.simulated_m * 1e3
    figure, axes = plt.subplots(2, 2, figsize=(10, 7), constrained_layout=True)
    for axis, column, label in zip(axes.flat[:3], range(3), "xyz"):
        axis.plot(times, measured[:, column], ".", markersize=2, color="0.4", label="measured")
        axis.plot(times, simulated[:, column], "-", linewidth=1, color="C1", label="simulated")
        axis.axvspan(times[result.n_fit], times[-1], color="C0", alpha=0.1, label="held out")
        axis.set_xlabel("t (s)")
        axis.set_ylabel(f"tip {label} (mm)")
    axes.flat[0].legend(loc="best", fontsize=8)
    path_axis = axes.flat[3]
    path_axis.plot(measured[:, 0], measured[:, 1], ".", markersize=2, color="0.4")
    path_axis.plot(simulated[:, 0], simulated[:, 1], "-", linewidth=0.8, color="C1")
    path_axis.set_xlabel("tip x (mm)")
    path_axis.set_ylabel("tip y (mm)")
    path_axis.set_aspect("equal", adjustable="datalim")
    figure.suptitle(f"{result.spec.name}: RMS tip error {result.fit_rms_mm:.2f} mm fitted, "
                    f"{result.held_out_rms_mm:.2f} mm held out")
    path = Path(path)
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path

