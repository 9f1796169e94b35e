"""``python -m eval suite``: the four-arm benchmark grid of a YAML spec (:mod:`eval.suite`):
every option and the spec checked before any run, the runs, the report."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from eval import suite as suite_module
from eval.commands.options import add_backend, add_workers, ray_backend
from soft_gym._cli import HelpFormatter, check_output_dir, fail, seed_int
from soft_gym._validation import SEED_MAX
from soft_gym.engines import ENGINES


SUITE_DESCRIPTION = (
    "Run the benchmark grid a YAML spec declares (presets x paths x conditions x policies x "
    "seeds): a bundled suite by name ('small' is the README's main job, 'default' every arm "
    "with its paper's conditions, 'demos' SAC started from demonstrations against SAC from "
    "scratch) or a file of your own. The spec is checked before any run; "
    "each run's record is written as it finishes (--resume continues an interrupted grid); the "
    "report ranks the policies per arm and condition (leaderboard.md, runs.csv, suite.json, "
    "plots). The spec's schema is in docs/suite.md.")
"""``suite --help``'s description (the schema itself is in docs/suite.md)."""


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``suite`` subcommand's parser."""
    suite = sub.add_parser(
        "suite", help="the four-arm benchmark suite of a YAML spec (the README's main job: "
        "suite small): leaderboard, IQM with bootstrap CIs, performance profiles",
        description=textwrap.fill(SUITE_DESCRIPTION, 96), formatter_class=HelpFormatter)
    suite.add_argument("spec", help="suite YAML file, or a bundled suite: "
                       f"{', '.join(suite_module.bundled_suites())}")
    suite.add_argument("--out", default=None,
                       help="output directory (made); default: results/suite_<suite "
                            "name>[_<engine>]")
    add_workers(suite)
    suite.add_argument("--resume", action="store_true",
                       help="skip the runs already recorded in --out")
    suite.add_argument("--seeds", type=seed_int, nargs="+", default=None,
                       help="episode seeds replacing the suite's own (distinct integers in "
                            f"[0, {SEED_MAX}])")
    suite.add_argument("--report-only", action="store_true",
                       help="run nothing: write the report from the records there")
    suite.add_argument("--engine", default=None, choices=list(ENGINES), metavar="ENGINE",
                       help=f"run every arm on ENGINE ({', '.join(ENGINES)}), less what it "
                            "cannot run (listed); default: each arm's own")
    suite.add_argument("--record", choices=["minari"], default=None,
                       help="also write the runs as Minari datasets, one per arm and "
                            "condition, in <out>/datasets (README: Datasets)")
    add_backend(suite, ["process", "serial", "ray"],
                 "--workers spawned processes, this process, or Ray tasks")
    return suite


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``suite``: check every option and the spec before any run, run, report."""
    backend = ray_backend(parser, args, "eval.suite.ray_backend")  # it registers "ray"
    if args.seeds is not None and (any(not 0 <= seed <= SEED_MAX for seed in args.seeds)
                                   or len(set(args.seeds)) != len(args.seeds)):
        parser.error(f"--seeds must be distinct integers >= 0 and <= {SEED_MAX}, got "
                     f"{args.seeds}")
    if args.report_only and args.resume:
        parser.error("--resume runs the missing runs; --report-only runs none: give one")
    if args.record is not None and args.report_only:
        parser.error("--record records the runs; --report-only runs none: give one")
    try:
        suite_module.require_rliable()
    except ImportError as error:
        parser.error(str(error))
    try:
        spec = suite_module.load_suite(args.spec)
        if args.seeds is not None:
            spec = spec.with_seeds(args.seeds)
    except ValueError as error:
        parser.error(f"spec: {error}")
    checker = suite_module.EnvChecker()
    if args.engine is not None:
        try:
            spec, left_out = suite_module.on_engine(spec, args.engine, checker)
        except ValueError as error:
            parser.error(f"--engine: {error}")
        for item in left_out:
            print(f"left out on {args.engine}: {item.label()}: {item.reason}", file=sys.stderr,
                  flush=True)
    out = Path(args.out or f"results/suite_{spec.name}"
               + (f"_{args.engine}" if args.engine else ""))
    if args.out is None:
        check_output_dir(parser, "--out", out)
    try:
        suite_module.check_records_dir(out)
    except ValueError as error:
        fail(parser, "--out", str(error))
    try:
        cells = (suite_module.expand(spec) if args.report_only
                 else suite_module.check_suite(spec, progress=True, checker=checker))
    except ValueError as error:
        parser.error(f"spec: {error}")
    if args.report_only and not suite_module.records_dir(out).is_dir():
        parser.error(f"--report-only: no records under {out} (give the --out of a suite run)")
    failure = None
    if not args.report_only:
        finished = (sum(suite_module.is_finished(out, cell.key) for cell in cells)
                    if args.resume else 0)
        print(f"{len(cells)} runs ({finished} already done) on {args.workers} worker(s)",
              flush=True)
        try:
            suite_module.run_suite(spec, out, workers=args.workers, resume=args.resume,
                                   progress=True, check=False, backend=backend,
                                   record=args.record is not None)
        except suite_module.SuiteRunError as error:
            failure = str(error)
    print(suite_module.write_report(spec, out, cells=cells, progress=True))
    if args.record is not None:
        from eval.datasets.suite import write_suite_datasets

        recorded = write_suite_datasets(spec.name, out, cells)
        for dataset_id, episodes in recorded["datasets"].items():
            print(f"{dataset_id}: {episodes} episode(s)")
        if recorded["missing"]:
            print(f"{len(recorded['missing'])} run(s) without a recorded episode (n/a, failed, "
                  "or finished before --record): not in the datasets", file=sys.stderr)
        print(f"datasets: {recorded['root']}")
    bad = [problem for cell in cells
           if (problem := suite_module.record_problem(out, cell.key)) is not None]
    if bad and failure is None:
        shown = "; ".join(str(problem) for problem in bad[:5])
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        failure = (f"{len(bad)} bad record(s) left out of the report: {shown}{more}; run "
                   f"again with --resume to redo them")
    if failure is not None:
        print(f"error: {failure}", file=sys.stderr)
    print(f"output directory: {out}")
    if failure is not None:
        raise SystemExit(1)
