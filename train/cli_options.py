"""Command-line options and checks that ``python -m train`` and ``python -m train sweep`` share.

Every check here runs before any work starts and reports a refusal the argparse way: one line
``<prog>: error: <option> ...`` naming the option, the value and what is allowed, exit status 2.
"""

from __future__ import annotations

import argparse
import difflib
from pathlib import Path
from typing import Any, Callable

import gymnasium
import yaml

import soft_gym  # noqa: F401  (registers the env ids)
from soft_gym._cli import check_file, fail
from soft_gym.engines import EngineFeatureError
from soft_gym.envs.registration import preset_env_id
from soft_gym.papers import DEFAULT_PRESET
from soft_gym.envs.uncalibrated import make_uncalibrated_env
from soft_gym.robots.presets import PRESETS
from train.config import CONFIG_DIR, TrainSettings, check_hyperparameters, parse_key_values

MUJOCO_RANDOMIZATION = CONFIG_DIR / "randomization_mujoco.yaml"
"""The randomisation file that draws no swaying mass (which the MuJoCo engine cannot simulate)."""


def add_env_options(parser: argparse.ArgumentParser) -> None:
    """``--env``, ``--preset`` and ``--env-kwargs``: which env to train on, and how it is made."""
    parser.add_argument("--env", default=None,
                        help=f"Gymnasium id (default SoftArmTrack<Preset>-v0, e.g. "
                             f"{preset_env_id('track', DEFAULT_PRESET)})")
    parser.add_argument("--preset", default=DEFAULT_PRESET,
                        help=f"arm preset when --env is not given ({', '.join(PRESETS)})")
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=VALUE",
                        help="env keyword arguments over the config's (e.g. feedback=em); "
                             "checked by building the env before training")


def parse_env_and_hyperparameters(parser: argparse.ArgumentParser,
                                  args: argparse.Namespace) -> tuple[dict, dict]:
    """``--env-kwargs`` and ``-hp`` as dicts; a malformed entry is a one-line CLI error."""
    try:
        env_kwargs = parse_key_values(args.env_kwargs, "--env-kwargs")
    except ValueError as error:
        parser.error(str(error))
    try:
        hyperparameters = parse_key_values(args.hyperparams, "--hyperparams")
    except ValueError as error:
        parser.error(str(error))
    return env_kwargs, hyperparameters


def resolve_env_id(parser: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """``--env`` when given (a registered id), else the track id of ``--preset`` (a known
    preset); a refusal names the option, the value and the ids or presets allowed."""
    if args.env is None:
        if args.preset not in PRESETS:
            parser.error(f"--preset must be one of {sorted(PRESETS)}, got {args.preset!r}")
        return preset_env_id("track", args.preset)
    if args.env not in gymnasium.registry:
        ids = sorted(name for name in gymnasium.registry if name.startswith("SoftArm"))
        close = difflib.get_close_matches(args.env, ids, n=1, cutoff=0.8)
        hint = f": did you mean {close[0]!r}?" if close else ""
        parser.error(f"--env must be a registered id ({', '.join(ids)}), got {args.env!r}{hint}")
    return args.env


def check_hyperparameter_overrides(parser: argparse.ArgumentParser, algo: str,
                                   hyperparameters: dict[str, Any]) -> None:
    """``-hp``: keys ``algo`` takes (the refusal lists them) and values in range."""
    try:
        check_hyperparameters(algo, hyperparameters)
    except ValueError as error:
        fail(parser, "--hyperparams", error)


def check_conf_file(parser: argparse.ArgumentParser, path: str | None) -> None:
    """``--conf-file``: an existing YAML file whose top level maps env ids to entries."""
    if path is None:
        return
    check_file(parser, "--conf-file", path, "a hyperparameter YAML file (train/configs/*.yml)")
    try:
        with open(path) as handle:
            table = yaml.safe_load(handle)
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        fail(parser, "--conf-file", f"{path!r} is not YAML: {error}")
    if not isinstance(table, dict) or not all(isinstance(v, dict) for v in table.values()):
        parser.error(f"--conf-file {path!r} must map env ids (or 'default') to hyperparameter "
                     f"mappings, as train/configs/*.yml do")


def shown_path(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it, else absolute."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def randomization_hint(option: str) -> Callable[[Exception], str]:
    """For :func:`check_env_kwargs`: where the refusal is randomisation drawing what the engine
    lacks (swaying masses), the option ``option`` (``"--randomization-config "``, ``"--env-kwargs
    randomization="``) with :data:`MUJOCO_RANDOMIZATION`, which draws none."""
    def hint(error: Exception) -> str:
        if isinstance(error, EngineFeatureError) and "randomization" in error.need.arguments:
            return f"; {option}{shown_path(MUJOCO_RANDOMIZATION)} draws none"
        return ""
    return hint


def check_env_kwargs(parser: argparse.ArgumentParser, env_id: str, env_kwargs: dict[str, Any],
                     overrides: dict[str, str],
                     hint: Callable[[Exception], str] | None = None) -> None:
    """Build the env ``env_id`` with ``env_kwargs`` (without calibrating its feedback) and close
    it; a refusal names the option that gave the refused keyword argument (``overrides``: key
    -> option, e.g. ``{"feedback": "--env-kwargs"}``; other keys came from ``--conf-file``),
    followed by ``hint(error)`` (e.g. :func:`randomization_hint`: the option that lifts it)."""
    try:
        make_uncalibrated_env(env_id, env_kwargs).close()
        return
    except Exception as error:  # noqa: BLE001  (any refusal is the user's input)
        message = " ".join(str(error).split())
        hinted = message + (hint(error) if hint is not None else "")
    # which option: the first keyword argument (config entry's first) whose addition fails the
    # way the whole set does; a subset can fail for another reason that a later keyword lifts
    # (engine=mujoco alone meets the preset's camera feedback, which feedback=em replaces)
    ordered = [k for k in env_kwargs if k not in overrides] + [k for k in env_kwargs
                                                               if k in overrides]
    partial: dict[str, Any] = {}
    for key in ordered:
        partial[key] = env_kwargs[key]
        try:
            make_uncalibrated_env(env_id, partial).close()
        except Exception as error:  # noqa: BLE001
            if " ".join(str(error).split()) == message:
                option = overrides.get(key, "--conf-file")
                fail(parser, option, f"env keyword {key}={env_kwargs[key]!r} refused by "
                                     f"{env_id}: {hinted}")
    fail(parser, "--env", f"{env_id} refused {env_kwargs}: {hinted}")


def check_arm_env_kwargs(parser: argparse.ArgumentParser, env_id: str, settings: TrainSettings,
                         vec: str, option: str) -> None:
    """A recipe's ``arm_env_kwargs`` (:class:`~train.config.TrainSettings`): only with
    ``--vec batched``, and every arm's keyword arguments over the recipe's build the env
    (without calibrating); a refusal is one line naming ``option`` (the option that gave the
    recipe) and the entry."""
    if settings.arm_env_kwargs is None:
        return
    if vec != "batched":
        parser.error(f"{option}: the recipe's arm_env_kwargs give the arms of one batch their "
                     f"own env keyword arguments: add --vec batched")
    for arm in settings.arm_variants():
        try:
            make_uncalibrated_env(env_id, {**settings.env_kwargs, **arm}).close()
        except Exception as error:  # noqa: BLE001  (any refusal is the recipe's input)
            fail(parser, option, f"arm_env_kwargs entry {arm!r} refused by {env_id}: "
                                 f"{' '.join(str(error).split())}")
