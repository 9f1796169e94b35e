"""Command line of the benchmark runner.

    python -m eval estimation --experiments clean occlusion lighting --steps 4000 --out results/estimation
    python -m eval track --policies cc_model hybrid_gpr --kp 0.04 0.1 --path circle --out results/track

``suite``: the four-arm benchmark grid of a YAML spec; ``python -m eval suite small`` is the
README's main job (the schema of a spec: docs/suite.md).

``datasets``: the papers' exploration and calibration data as Minari datasets
(``python -m eval datasets --help``; README.md, "Datasets").

``benchmark``: the wang2023 comparison on a loaded circle with fused feedback and a partly
occluding hand (``python -m eval benchmark --help``).

``compare``: the SB3 agents against the baselines, nominal and out of distribution (see
``eval/compare.py``).

``claims``: the papers' headline claims as a ledger, each reproduced, partly or not reproduced
on every seed against a criterion from the paper's own figures (``eval/claims/``; the last full
run is docs/claims.md).

``estimation``: the wang2023 estimation experiments (camera, F-emp and fusion vs ground truth;
Figs. 6-7, Tables III, IV, VI). ``track``: baselines tracking a path on an arm preset, with loads,
visual faults and a feedback source, several gains and seeds; a Markdown table with mean +- std,
max, per cycle and the improvement over ``cc_model``, per-step CSVs and plots.

Every command ends by printing the output directory it wrote to (``--out``); its JSON summary
records the soft-arm-gym version that made it (``soft_arm_gym_version``). ``--video`` (``track``,
``benchmark``, ``compare``, ``estimation``) also writes an MP4 of each run next to its CSV (a GIF
where ffmpeg is absent): the scene with the target, path, loads, true tip and estimate, and the
camera sensors' frames beside it, one frame per control step (see ``eval/video.py``).

Every option is checked before any work starts: a bad value (a count below 1, a negative seed, a
gain that is not a finite positive number, JSON that does not parse, an output directory that
cannot be written, an unknown preset, path, feedback source or policy, an ``sb3:PATH`` that holds
no model or one whose observation or action space differs from its env's) exits with status 2
and one line naming the option, the value and what is allowed. ``track``, ``benchmark`` and
``compare`` check every run's configuration (each env built once without calibration, every
baseline made, every agent loaded) before the first run, and write each run's CSV as it
finishes, so a run failing later keeps the finished ones.
"""

from __future__ import annotations

import argparse

from eval import results_page
from eval.commands import Command, claims, compare, datasets, suite, track
from eval.papers import evaluations
from soft_gym._cli import CommandParser, HelpFormatter, check_environment, check_output_dir

SHARED_COMMANDS: dict[str, Command] = {
    "track": Command(track.add_parser, track.run),
    "compare": Command(compare.add_parser, compare.run),
    "claims": Command(claims.add_parser, claims.run),
    "suite": Command(suite.add_parser, suite.run),
    "datasets": Command(datasets.add_parser, datasets.run),
    "results": Command(results_page.add_parser, results_page.run),
}
"""The subcommands of no paper in particular."""


def commands() -> dict[str, Command]:
    """Every subcommand by name, in the order ``--help`` lists them: the shared ones, then each
    registered paper's own (its evaluation folder's ``COMMANDS``), in registration order.

    Raises:
        ValueError: a paper's subcommand whose name is already taken.
    """
    found = dict(SHARED_COMMANDS)
    for paper, module in evaluations().items():
        for name, command in getattr(module, "COMMANDS", {}).items():
            if name in found:
                raise ValueError(f"subcommand {name!r} of paper {paper!r} is already taken")
            found[name] = command
    return found


COMMANDS: dict[str, Command] = commands()
"""Every subcommand of the registered papers at import (:func:`commands` gives the present)."""

DISTINCT_OPTIONS = ("policies", "kp", "seeds", "paths", "conditions", "experiments", "baselines",
                    "papers", "claims")
"""List options whose values must not repeat (each run once)."""


def _check_distinct(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse (one line, exit 2) a list option that names a value twice."""
    for option in DISTINCT_OPTIONS:
        values = getattr(args, option, None)
        if isinstance(values, list) and len(set(values)) != len(values):
            parser.error(f"--{option} must be distinct (each run once), got {values}")


def main(argv: list[str] | None = None) -> None:
    """``python -m eval``: parse and check every option (one-line errors, exit 2), then run."""
    parser = CommandParser(prog="python -m eval", description=__doc__,
                                     formatter_class=HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    present = commands()
    parsers = {name: command.add_parser(sub) for name, command in present.items()}
    args = parser.parse_args(argv)
    command_parser = parsers[args.command]
    check_environment(command_parser)
    _check_distinct(command_parser, args)
    if args.out is not None:  # suite's default output directory is checked once the spec is read
        check_output_dir(command_parser, "--out", args.out)
    present[args.command].run(command_parser, args)


if __name__ == "__main__":
    main()
