"""``python -m soft_gym identify``: an arm file fitted to a log, with its report and plot.

Every option is checked before the fit starts (one line naming the option, exit status 2); on
any failure nothing is written.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from tqdm import tqdm

from soft_gym._cli import check_file, fail
from soft_gym._progress import heartbeat
from soft_gym.engines import ENGINES, FAST_ENGINE
from soft_gym.identify.fit import fit_arm, fit_split
from soft_gym.identify.log import read_log
from soft_gym.identify.parameters import FAMILIES, default_parameters, parse_parameters
from soft_gym.identify.report import (companion_paths, plot_tip_paths, report_document,
                                      write_report)
from soft_gym.robots.arm_file import ARM_FILE_SUFFIXES, arm_from_preset, save_preset


def add_identify(commands: argparse._SubParsersAction, formatter: type) -> None:
    """Add the ``identify`` subcommand to ``commands`` (the top parser's subparsers)."""
    identify = commands.add_parser(
        "identify", help="fit an arm to a log of commands and tip positions",
        formatter_class=formatter,
        description=("Fit physical parameters of the arm BASE to a CSV log (columns t, p0..p{n-1}\n"
                     "in Pa, x, y, z in m; docs/architecture.md, \"Fit the arm to your data\")\n"
                     "and write the fitted arm file OUT, its report OUT.identify.yaml and a plot\n"
                     "OUT.identify.png of measured against simulated tip paths."),
        epilog=("example:\n  python -m soft_gym identify --preset wang2023 --data run.csv "
                "--out my_arm.yaml --params youngs_modulus_pa pneumatic_time_constant_s"))
    identify.add_argument("--preset", required=True, metavar="BASE",
                          help="the arm to start from: a preset name or an arm file")
    identify.add_argument("--data", required=True, metavar="LOG", type=Path,
                          help="the CSV log to fit")
    identify.add_argument("--out", required=True, metavar="ARM.yaml", type=Path,
                          help="the fitted arm file to write (.yaml or .yml)")
    identify.add_argument("--params", nargs="+", metavar="NAME", default=None,
                          help=f"what to fit, from {list(FAMILIES)} (a segment field with [k] "
                               f"for segment k alone); default: every one, the tip mass only "
                               f"where BASE has one")
    identify.add_argument("--engine", default=FAST_ENGINE, choices=sorted(ENGINES),
                          help="the engine simulating each candidate arm")
    identify.add_argument("--name", default=None,
                          help="the fitted arm's name; default: OUT's file stem")
    identify.add_argument("--force", action="store_true",
                          help="replace OUT and its report and plot if they exist")
    identify.set_defaults(run=run_identify, command_parser=identify)


def run_identify(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    """Check every option, fit, then write the arm file, report and plot (nothing on failure)."""
    try:
        base = arm_from_preset(args.preset)
    except ValueError as error:
        fail(parser, "--preset", error)
    if base.cylinders is not None:
        fail(parser, "--preset", f"arm {base.name!r} drives its chambers' volumes with cylinders; "
                                 f"a log is replayed as chamber pressures: give the arm without "
                                 f"its cylinders section")
    out: Path = args.out
    outputs = (out, *companion_paths(out))
    _check_outputs(parser, out, outputs, args.force)
    name = args.name if args.name is not None else out.stem
    try:
        replace(base, name=name)
    except ValueError as error:
        fail(parser, "--name", error)
    check_file(parser, "--data", args.data, "a CSV log")
    try:
        log = read_log(args.data, base)
    except ValueError as error:
        fail(parser, "--data", error)
    try:
        parameters = (default_parameters(base) if args.params is None
                      else parse_parameters(args.params, base))
    except ValueError as error:
        fail(parser, "--params", error)

    try:
        fit_split(log.n_samples, len(parameters))
    except ValueError as error:
        fail(parser, "--data", error)

    with tqdm(desc="identify: simulations", unit="sim", file=sys.stderr) as bar, heartbeat(bar):
        result = fit_arm(base, log, parameters, engine=args.engine,
                         on_evaluation=lambda: bar.update(1))
    fitted = replace(result.spec, name=name)
    result = replace(result, spec=fitted)
    report_path, plot_path = outputs[1], outputs[2]
    written: list[Path] = []
    try:
        written.append(write_report(report_path, report_document(
            result, base.name, args.data, args.engine, log)))
        written.append(plot_tip_paths(plot_path, result, log))
        written.append(save_preset(fitted, out))
    except BaseException:
        for path in written:
            path.unlink(missing_ok=True)
        raise
    for parameter in result.parameters:
        flag = "" if parameter.identifiable else "  (unidentifiable)"
        print(f"{parameter.name}: {parameter.value:.6g} +- {parameter.standard_error:.2g} "
              f"(base {parameter.base:.6g}){flag}")
    print(f"RMS tip error {result.fit_rms_mm:.3f} mm fitted, {result.held_out_rms_mm:.3f} mm "
          f"held out (base arm {result.base_rms_mm:.3f} mm)")
    print(f"wrote {out}, {report_path} and {plot_path}")


def _check_outputs(parser: argparse.ArgumentParser, out: Path, outputs: tuple[Path, ...],
                   force: bool) -> None:
    """``parser.error`` unless ``out`` names an arm file whose directory exists and none of
    ``outputs`` exists (or ``force``)."""
    if out.suffix.lower() not in ARM_FILE_SUFFIXES:
        parser.error(f"--out {str(out)!r} must end in {' or '.join(ARM_FILE_SUFFIXES)} (an arm "
                     f"file)")
    if not out.parent.is_dir():
        parser.error(f"--out {str(out)!r}: its directory {str(out.parent)!r} does not exist or "
                     f"is not a directory: make it first")
    for path in outputs:
        if path.is_dir():
            parser.error(f"--out {str(out)!r}: {str(path)!r} is a directory")
        if path.exists() and not force:
            parser.error(f"--out {str(out)!r}: {str(path)!r} exists: pass --force to replace it")
