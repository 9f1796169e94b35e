"""What every command line of the repository shares (``python -m eval``, ``python -m train``,
``python -m train.ship``, ``python -m soft_gym.demo``, ``bench/*.py``): the help formatter, the
value types of ``add_argument(type=...)`` that refuse bad numbers in argparse's own one-line
error, and checks of output directories and files made before any work starts.

A refused value is reported the argparse way: ``parser.error(...)`` prints the usage and one line
``<prog>: error: <option> ...`` naming the option, the value and what is allowed, and exits 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Any, Callable, NoReturn

from soft_gym._validation import SEED_MAX


class HelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Keeps the description's line breaks (a module docstring with its examples) and appends
    each option's default to its help, ``(default: ...)``.

    Options whose default is ``None`` (their help says what leaving them out means) and flags
    (``store_true`` and the like, which take no value) get no default appended.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or action.nargs == 0:
            return action.help
        return super()._get_help_string(action)


class CommandParser(argparse.ArgumentParser):
    """The parser of every command line: a refusal is the error line after a one-line usage
    hint, never argparse's usage block of every option.

    ``argparse`` prints the whole usage (9-17 lines for ``python -m eval track`` or ``python -m
    train``) above the one line that says what is wrong; here the usage is kept only where it
    fits one line, else replaced by ``usage: PROG [options] (PROG --help lists them)``. The
    exit status stays 2. Subparsers made by :meth:`add_subparsers` are of this class too.
    """

    def short_usage(self) -> str:
        """The usage in one line: argparse's own when it fits, else a pointer to ``--help``."""
        usage = " ".join(self.format_usage().split())
        if len(usage) <= 100:
            return usage
        return f"usage: {self.prog} [options] ({self.prog} --help lists them)"

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.short_usage()}\n{self.prog}: error: {message}\n")


# ------------------------------------------------------------------ argparse value types
def _named(function: Callable[[str], Any], name: str) -> Callable[[str], Any]:
    function.__name__ = name  # argparse names the type in some messages
    return function


def int_at_least(low: int, high: int | None = None) -> Callable[[str], int]:
    """An ``add_argument`` type: an integer >= ``low`` (and <= ``high`` when given; ``"3"``, not
    ``"3.0"`` or ``"abc"``)."""
    wanted = f">= {low}" + ("" if high is None else f" and <= {high}")

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer {wanted}, got {text!r}") \
                from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be an integer {wanted}, got {text!r}")
        return value

    return _named(parse, f"int>={low}" if high is None else f"int[{low},{high}]")


positive_int = int_at_least(1)
"""An integer >= 1 (counts: cycles, steps, workers, threads, episodes)."""
non_negative_int = int_at_least(0)
"""An integer >= 0 (frequencies where 0 means "never", sample counts)."""
seed_int = int_at_least(0, SEED_MAX)
"""A seed: an integer in ``[0, SEED_MAX]`` (:data:`soft_gym._validation.SEED_MAX`)."""


def finite_float(low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> Callable[[str], float]:
    """An ``add_argument`` type: a finite number within ``[low, high]`` (``(`` / ``)`` with
    ``low_open`` / ``high_open``; ``None``: unbounded). ``nan`` and ``inf`` are refused."""
    left = "(" if low_open else "["
    right = ")" if high_open else "]"
    allowed = "a finite number"
    if low is not None and high is not None:
        allowed += f" in {left}{low:g}, {high:g}{right}"
    elif low is not None:
        allowed += f" {'>' if low_open else '>='} {low:g}"
    elif high is not None:
        allowed += f" {'<' if high_open else '<='} {high:g}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {allowed}, got {text!r}") from None
        if (not math.isfinite(value)
                or (low is not None and (value < low or (low_open and value == low)))
                or (high is not None and (value > high or (high_open and value == high)))):
            raise argparse.ArgumentTypeError(f"must be {allowed}, got {text!r}")
        return value

    return _named(parse, "number")


positive_float = finite_float(0.0, low_open=True)
"""A finite number > 0 (gains, durations)."""


def json_value(text: str) -> Any:
    """An ``add_argument`` type: JSON text (``'{"name": "tip_mass", "mass_kg": 0.01}'``,
    ``'"low_light"'``); a syntax error names where it is."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(
            f"must be JSON (e.g. '{{\"name\": \"tip_mass\", \"mass_kg\": 0.01}}' or "
            f"'\"low_light\"'), got {text!r}: {error.msg} at character {error.pos}") \
            from None


json_value.__name__ = "JSON"


_PLAIN_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def json_or_name(text: str) -> Any:
    """An ``add_argument`` type: JSON text, or a plain name (``wang2023_occlusion``, as the
    shell leaves it unquoted) taken as that string; anything else is refused as
    :func:`json_value` refuses it."""
    if _PLAIN_NAME.match(text) and text not in ("true", "false", "null"):
        return text
    return json_value(text)


json_or_name.__name__ = "JSON or name"


# ------------------------------------------------------------------ checks before any work
def output_dir_error(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot be (made into) a writable directory, or ``None`` when it can.

    Nothing is left behind: the path must be a directory in which a file can be made, or not
    exist below a directory (its nearest existing parent) in which a directory can be made;
    both are tried with a temporary entry that is removed at once (permission bits alone do not
    tell, e.g. for root or on read-only file systems).
    """
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            return "exists and is not a directory"
        try:
            with tempfile.TemporaryFile(dir=path):
                pass
        except OSError as error:
            return f"is a directory this user cannot write to ({error.strerror})"
        return None
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        return f"cannot be made: {str(parent)!r} is not a directory"
    try:
        os.rmdir(tempfile.mkdtemp(dir=parent, prefix=".write_check_"))
    except OSError as error:
        return f"cannot be made in {str(parent)!r} ({error.strerror})"
    return None


def check_output_dir(parser: argparse.ArgumentParser, option: str,
                     path: str | os.PathLike) -> None:
    """``parser.error`` unless ``path`` can be the writable output directory of ``option``."""
    reason = output_dir_error(path)
    if reason is not None:
        parser.error(f"{option} {str(path)!r} {reason}: give a writable directory")


def check_file(parser: argparse.ArgumentParser, option: str, path: str | os.PathLike,
               what: str = "a file") -> None:
    """``parser.error`` unless ``path`` is an existing readable file (``what`` it should be)."""
    path = Path(path)
    if not path.is_file():
        state = "is a directory" if path.is_dir() else "does not exist"
        parser.error(f"{option} {str(path)!r} {state}: give {what}")
    if not os.access(path, os.R_OK):
        parser.error(f"{option} {str(path)!r} is not readable: give {what}")


def check_environment(parser: argparse.ArgumentParser) -> None:
    """Refuse (one line, exit 2) a bad setting of the environment variables the package reads
    (``SOFT_GYM_CACHE``), before any work rather than mid-run."""
    from soft_gym.sensing.calibration_cache import CACHE_ENV_VARIABLE, disk_cache_enabled

    try:
        disk_cache_enabled()
    except ValueError as error:
        parser.error(f"environment variable {CACHE_ENV_VARIABLE}: {error}")


def fail(parser: argparse.ArgumentParser, option: str, message: Any) -> NoReturn:
    """``parser.error`` naming ``option``, with ``message`` (an exception's text) on one line."""
    text = " ".join(str(message).split())
    parser.error(f"{option}: {text}")
    raise AssertionError("unreachable")  # parser.error exits
