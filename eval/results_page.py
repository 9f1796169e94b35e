"""``python -m eval results``: ``docs/results.md``, every measured result, written from records.

    python -m eval results            # writes docs/results.md
    python -m eval results --check    # exit 1 naming the first stale line; 0 when current

The page is made of the default suite's last run (``docs/leaderboard/runs.csv``), the shipped
agents' own records (``agents/trained/<name>/``), the claims ledger's record
(``docs/claims/claims.json``; sections of :mod:`eval.results_records`) and the numbers measured
by hand with the command and revision that measured them (``docs/measurements.yaml``,
:mod:`eval.results_measurements`). Nothing on it is written by hand: a number changes when its
record does, and ``--check`` (run by ``tests/test_readme.py``) fails until the page is written
again.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from eval.results_measurements import measurements_section
from eval.results_records import (agents_section, arm_tables_section, claims_section,
                                  leaderboard_section)
from soft_gym._cli import HelpFormatter

REPOSITORY = Path(__file__).resolve().parents[1]
"""The repository's root, under which the records are read."""

PAGE = Path("docs") / "results.md"
"""The page, relative to the repository's root (its links are relative to its folder)."""

HEADER = ["# Results", "",
          "<!-- Written by python -m eval results from the records each section names; edit "
          "the records, not this page. -->", "",
          "Every measured number of soft-arm-gym: the benchmark suite, the shipped agents, the "
          "claims ledger and the timings measured by hand. `python -m eval results` writes this "
          "page from the records; `python -m eval results --check` says whether it is current "
          "(the test suite runs it).", ""]
"""The page's first lines."""


DESCRIPTION = """\
Write docs/results.md, every measured result of soft-arm-gym, from the records: the default
suite's last run (docs/leaderboard/runs.csv), the shipped agents' training.yaml, tracking curves
and evaluation.yaml (agents/trained/), the claims ledger (docs/claims/claims.json) and the numbers
measured by hand, each with its command and revision (docs/measurements.yaml). With --check,
write nothing and exit 1 naming the first line of the page that differs from what the records
give (0 when it is current).

    python -m eval results
    python -m eval results --check"""
"""The subcommand's ``--help`` text."""


def render_page(root: Path = REPOSITORY) -> str:
    """The page's text, from the records under ``root``."""
    lines = (HEADER + leaderboard_section(root) + arm_tables_section(root) + agents_section()
             + claims_section(root) + measurements_section(root))
    while lines and lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"


def first_stale_line(expected: str, written: str) -> tuple[int, str, str] | None:
    """The first line (1-based number, as written, as the records give it) where ``written``
    differs from ``expected``; ``None`` when they are equal. A line one text lacks is ``""``."""
    if expected == written:
        return None
    wanted, have = expected.splitlines(), written.splitlines()
    for number in range(1, max(len(wanted), len(have)) + 2):
        line = have[number - 1] if number <= len(have) else ""
        given = wanted[number - 1] if number <= len(wanted) else ""
        if line != given:
            return number, line, given
    return len(have) + 1, "", ""  # only the final newline differs


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``results`` subcommand's parser (``--out`` is stored as ``page``: the dispatcher
    checks a command's ``out`` as an output directory, and the page is a file)."""
    parser = sub.add_parser("results", help="write docs/results.md from the records (or check "
                            "that it is current)", description=DESCRIPTION,
                            formatter_class=HelpFormatter)
    parser.add_argument("--out", dest="page", default=None, metavar="FILE",
                        help=f"the page to write or check; left out: {PAGE} of this checkout")
    parser.add_argument("--check", action="store_true",
                        help="write nothing: exit 1 naming the first line of FILE that differs "
                             "from what the records give")
    parser.set_defaults(out=None)
    return parser


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``results``: write the page, or with ``--check`` compare it with the records."""
    page = REPOSITORY / PAGE if args.page is None else Path(args.page)
    if page.is_dir():
        parser.error(f"--out {str(page)!r} is a directory: give the page's file")
    try:
        text = render_page()
    except (OSError, ValueError, KeyError) as error:
        parser.error(f"the records cannot be read: {error}")
    if args.check:
        written = page.read_text(encoding="utf-8") if page.is_file() else ""
        stale = first_stale_line(text, written)
        if stale is not None:
            number, line, given = stale
            print(f"{page} is stale at line {number}: it has {line!r}, the records give "
                  f"{given!r}; run python -m eval results", file=sys.stderr)
            sys.exit(1)
        print(f"{page} is current")
        return
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(text, encoding="utf-8")
    print(f"wrote {page}")
