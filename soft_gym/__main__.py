"""soft_gym's command line.

    python -m soft_gym preset export NAME FILE [--force]
    python -m soft_gym identify --preset BASE --data LOG.csv --out ARM.yaml [--params NAME ...]

``preset export`` writes the arm preset NAME to the YAML arm file FILE, every field included
(geometry, material, actuation and timing, SI units; docs/architecture.md, "Your own arm").
Edit the copy (give it a name of its own) and use it wherever a preset name is taken:

    python -m soft_gym preset export wang2023 my_arm.yaml
    # edit my_arm.yaml: name: my_arm, segments[0].length_m: 0.12, ...
    gym.make("SoftArmReach-v0", preset="my_arm.yaml")

``identify`` fits an arm's physical parameters to a log of commanded pressures and measured tip
positions and writes the fitted arm file, a report and a plot (docs/architecture.md, "Fit the arm
to your data").
"""

from __future__ import annotations

import argparse
from pathlib import Path

from soft_gym._cli import CommandParser, HelpFormatter
from soft_gym.identify.command import add_identify
from soft_gym.papers import DEFAULT_PRESET
from soft_gym.robots.arm_file import save_preset
from soft_gym.robots.presets import PRESETS

PROG = "python -m soft_gym"


def build_parser() -> argparse.ArgumentParser:
    parser = CommandParser(prog=PROG, description=__doc__,
                                     formatter_class=HelpFormatter)
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    preset = commands.add_parser(
        "preset", help="arm presets as files", formatter_class=HelpFormatter,
        description="Arm presets as YAML arm files (docs/architecture.md, \"Your own arm\").")
    actions = preset.add_subparsers(dest="action", metavar="ACTION", required=True)
    export = actions.add_parser(
        "export", help="write a preset to a YAML arm file", formatter_class=HelpFormatter,
        description=("Write the arm preset NAME to the YAML arm file FILE, every field included,\n"
                     "as a template to edit. Load it back with soft_gym.robots.load_preset(FILE),\n"
                     "or pass the path as an env's preset= (a path ending in .yaml/.yml or\n"
                     "holding a path separator is a file)."),
        epilog=(f"example:\n  python -m soft_gym preset export {DEFAULT_PRESET} my_arm.yaml\n"
                "  then edit my_arm.yaml (its name too) and use "
                "gym.make(\"SoftArmReach-v0\", preset=\"my_arm.yaml\")"))
    export.add_argument("name", metavar="NAME",
                        help=f"the preset to write, one of {sorted(PRESETS)}")
    export.add_argument("file", metavar="FILE", type=Path,
                        help="the YAML file to write (its directory must exist)")
    export.add_argument("--force", action="store_true",
                        help="replace FILE if it exists (refused otherwise)")
    export.set_defaults(run=_export, command_parser=export)  # errors show its usage line
    add_identify(commands, HelpFormatter)
    return parser


def _export(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    if args.name not in PRESETS:
        parser.error(f"NAME {args.name!r} is not a preset: give one of {sorted(PRESETS)}")
    file: Path = args.file
    directory = file.parent
    if file.is_dir():
        parser.error(f"FILE {str(file)!r} is a directory: give the path of the file to write")
    if not directory.is_dir():
        state = "is not a directory" if directory.exists() else "does not exist"
        parser.error(f"FILE {str(file)!r}: its directory {str(directory)!r} {state}: make it "
                     f"first or give a path in an existing directory")
    if file.exists() and not args.force:
        parser.error(f"FILE {str(file)!r} exists: pass --force to replace it")
    written = save_preset(args.name, file)
    print(f"wrote preset {args.name} to {written}")


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    args.run(args, args.command_parser)


if __name__ == "__main__":
    main()
