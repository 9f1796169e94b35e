"""``python -m eval claims``: the papers' headline claims as a ledger (:mod:`eval.claims`), each
reproduced, partly or not reproduced on every seed."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from eval.claims import CLAIMS, claim_papers
from eval.claims.report import ledger_table, summary_line, write_ledger
from eval.claims.run import run_ledger, select_claims
from eval.commands.options import add_backend, add_workers, ray_backend
from soft_gym._cli import HelpFormatter, check_output_dir, fail, seed_int
from soft_gym._validation import SEED_MAX


CLAIMS_DESCRIPTION = (
    "The papers' headline claims as a ledger: run the experiments behind each claim for every "
    "seed and report each claim reproduced, partly or not reproduced, with the numbers that "
    "decided it (the criteria are the papers' own figures; docs/claims.md holds the last full "
    "run). Writes claims.md, claims.json and records/ (one summary per experiment and seed, "
    "read back by --resume) to --out. A full run of every paper on seeds 0-2 takes hours "
    "(README: 'The claims ledger'); --quick runs a small version of every experiment in "
    "minutes, its verdicts marked quick.")
"""``claims --help``'s description."""

DOCS_LEDGER = Path(__file__).resolve().parents[2] / "docs" / "claims.md"
"""Where ``claims --docs`` writes the ledger of a full run (the repository's docs/claims.md)."""
DOCS_RECORDS = DOCS_LEDGER.with_suffix("")
"""``claims --docs``'s default ``--out``: docs/claims/, whose ``records/`` keep the experiments'
summaries behind docs/claims.md, so ``--resume --docs`` continues the repository's ledger."""


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``claims`` subcommand's parser."""
    claims = sub.add_parser("claims", help="the papers' claims as a ledger: reproduced, partly "
                            "or not, per seed", description=textwrap.fill(CLAIMS_DESCRIPTION, 96),
                            formatter_class=HelpFormatter)
    papers = list(claim_papers())
    claims.add_argument("--papers", nargs="+", default=papers, choices=papers,
                        help="whose claims")
    claims.add_argument("--claims", nargs="+", default=None, metavar="KEY",
                        help=f"only these claims (of {len(CLAIMS)}: " + ", ".join(CLAIMS) + ")")
    claims.add_argument("--seeds", type=seed_int, nargs="+", default=[0, 1, 2],
                        help=f"seeds every claim is judged on (integers in [0, {SEED_MAX}])")
    claims.add_argument("--quick", action="store_true",
                        help="a small version of every experiment (minutes; verdicts marked "
                             "quick)")
    claims.add_argument("--out", default=None,
                        help="output directory (made; must be writable); default: "
                             "results/claims, or docs/claims with --docs")
    claims.add_argument("--resume", action="store_true",
                        help="read the experiment records already in --out instead of running "
                             "them again")
    claims.add_argument("--report-only", action="store_true",
                        help="run nothing: judge each claim on the seeds whose records are in "
                             "--out (a claim with none is 'not run')")
    claims.add_argument("--docs", action="store_true",
                        help="also write the ledger to docs/claims.md, its records kept in "
                             "docs/claims/records (a full run of every claim only)")
    add_workers(claims)
    add_backend(claims, ["local", "ray"], "--workers local processes, or each job a Ray task")
    return claims


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``claims``: check the options, run the experiments, print and write the ledger."""
    try:
        select_claims(args.papers, args.claims)
    except ValueError as error:
        fail(parser, "--claims", error)
    if args.report_only and args.resume:
        parser.error("--resume runs the missing experiments; --report-only runs none: give one")
    backend = ray_backend(parser, args, "eval.claims.ray_backend")
    if args.docs and (args.quick or args.claims is not None
                      or list(args.papers) != list(claim_papers())):
        parser.error("--docs writes the full ledger: every paper and claim, without --quick")
    if args.docs:
        check_output_dir(parser, "--docs", DOCS_LEDGER.parent)
    if args.out is None:
        args.out = str(DOCS_RECORDS if args.docs else Path("results") / "claims")
        check_output_dir(parser, "--out", args.out)
    command = _claims_command(args)
    ledger = run_ledger(args.papers, args.seeds, quick=args.quick, out=args.out,
                        resume=args.resume, workers=args.workers, progress=True,
                        claims=args.claims, report_only=args.report_only, backend=backend)
    markdown_path, _ = write_ledger(ledger, args.out, command)
    print(ledger_table(ledger))
    print(summary_line(ledger))
    if args.docs:
        DOCS_LEDGER.write_text(markdown_path.read_text(encoding="utf-8"), encoding="utf-8")
        if Path(args.out).resolve() == DOCS_RECORDS.resolve():
            markdown_path.unlink()  # docs/claims.md is its one copy in the repository
        print(f"ledger written to {DOCS_LEDGER}")
    print(f"output directory: {args.out}")
    bad = ledger["bad_records"]
    if bad:
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        print(f"error: {len(bad)} bad record(s) left out of the ledger: {'; '.join(bad[:5])}"
              f"{more}; run again with --resume to redo them", file=sys.stderr)
        raise SystemExit(1)


def _claims_command(args: argparse.Namespace) -> str:
    """The command line that makes this ledger (for its header)."""
    parts = ["python -m eval claims"]
    if list(args.papers) != list(claim_papers()):
        parts.append("--papers " + " ".join(args.papers))
    if args.claims is not None:
        parts.append("--claims " + " ".join(args.claims))
    parts.append("--seeds " + " ".join(str(seed) for seed in args.seeds))
    if args.quick:
        parts.append("--quick")
    if args.report_only:
        parts.append("--report-only")
    if args.docs:
        parts.append("--docs")
    return " ".join(parts)
