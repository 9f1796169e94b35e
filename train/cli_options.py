"""Command-line options that ``python -m train`` and ``python -m train sweep`` share."""

from __future__ import annotations

import argparse


def add_env_options(parser: argparse.ArgumentParser) -> None:
    """``--env``, ``--preset`` and ``--env-kwargs``: which env to train on, and how it is made."""
    parser.add_argument("--env", default=None,
                        help="Gymnasium id (default SoftArmTrack<Preset>-v0, e.g. "
                             "SoftArmTrackWang2023-v0)")
    parser.add_argument("--preset", default="wang2023",
                        help="arm preset when --env is not given (wang2023, zhao2021, zou2022, "
                             "ho2018)")
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=VALUE",
                        help="env keyword arguments over the config's (e.g. feedback=em)")


def parse_env_and_hyperparameters(parser: argparse.ArgumentParser,
                                  args: argparse.Namespace) -> tuple[dict, dict]:
    """``--env-kwargs`` and ``-hp`` as dicts; a malformed entry is a one-line CLI error."""
    from train.config import parse_key_values

    try:
        return (parse_key_values(args.env_kwargs, "--env-kwargs"),
                parse_key_values(args.hyperparams, "--hyperparams"))
    except ValueError as error:
        parser.error(str(error))
        raise  # parser.error exits; this keeps the return type honest
