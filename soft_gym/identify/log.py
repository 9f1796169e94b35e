"""A logged run of a real arm read from CSV: commanded chamber pressures and measured tip positions.

The file has a header row and one row per sample (docs/architecture.md, "Fit the arm to your
data"):

* ``t``: the sample's time (s), strictly increasing;
* ``p0 .. p{n-1}``: the pressure commanded to each chamber (gauge, Pa), one column per chamber
  of the arm (``ArmSpec.n_chambers``, in the simulator's chamber order), each within
  ``[0, p_max_pa]`` of its segment. Row ``i``'s command is sent at ``t[i]`` and held until
  ``t[i + 1]``;
* ``x``, ``y``, ``z``: the tip position measured at ``t[i]`` (m, in the arm's base frame,
  before row ``i``'s command acts);
* optionally ``qx``, ``qy``, ``qz``, ``qw``: the tip orientation (all four or none); kept, not
  fitted.

Other columns (a load, a comment) are ignored. Every problem is one ``ValueError`` naming the
column or the row (rows counted from 1 after the header, i.e. line ``row + 1`` of the file).
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from soft_gym.robots.spec import ArmSpec

POSITION_COLUMNS = ("x", "y", "z")
QUATERNION_COLUMNS = ("qx", "qy", "qz", "qw")
MILLIMETRE_FACTOR = 10.0
"""A tip farther from the base than this many times the arm's reach (``ArmSpec.max_reach_m``)
is taken for a log written in millimetres and refused."""
MIN_ROWS = 3
"""Fewest samples a log may hold."""

_COMMAND_COLUMN = re.compile(r"^p(\d+)$")


@dataclass(frozen=True)
class ArmLog:
    """A checked log of one run.

    Attributes:
        times_s: sample times, strictly increasing (s, (n,)).
        commands_pa: commanded chamber pressures (gauge Pa, (n, n_chambers)).
        tip_positions_m: measured tip positions in the base frame (m, (n, 3)).
        tip_quaternions: measured tip orientations (x, y, z, w) ((n, 4)), or ``None``.
    """

    times_s: np.ndarray
    commands_pa: np.ndarray
    tip_positions_m: np.ndarray
    tip_quaternions: np.ndarray | None = None

    @property
    def n_samples(self) -> int:
        """Rows in the log."""
        return int(self.times_s.shape[0])

    def head(self, n: int) -> "ArmLog":
        """The log's first ``n`` samples (``n`` in ``[MIN_ROWS, n_samples]``).

        Raises:
            ValueError: ``n`` out of that range.
        """
        if not MIN_ROWS <= n <= self.n_samples:
            raise ValueError(f"n must be an integer in [{MIN_ROWS}, {self.n_samples}], got {n!r}")
        quaternions = None if self.tip_quaternions is None else self.tip_quaternions[:n]
        return ArmLog(self.times_s[:n], self.commands_pa[:n], self.tip_positions_m[:n],
                      quaternions)


def read_log(path: str | Path, spec: ArmSpec) -> ArmLog:
    """Read and check the CSV log ``path`` of the arm ``spec`` (format in the module docstring).

    Args:
        path: the CSV file.
        spec: the arm the log was recorded on (its chamber count, pressure range and reach).

    Returns:
        the log.

    Raises:
        ValueError: an unreadable file, missing columns, a command column count that does not
            match ``spec.n_chambers``, a value that is not a finite number, a time not after the
            one before, a tip position that looks like millimetres or a command outside
            ``[0, p_max_pa]``; one error naming the column or the row.
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"log {str(path)!r} cannot be read as a CSV text file: {error}") \
            from error
    while rows and not any(cell.strip() for cell in rows[-1]):
        rows.pop()  # blank lines at the end
    if not rows:
        raise ValueError(f"log {str(path)!r} is empty: give a header row and samples")
    header = [name.strip() for name in rows[0]]
    columns = _columns(header, spec, path)
    values = _numbers(rows[1:], header, columns, path)
    return check_log(values[:, columns["t"]], values[:, columns["commands"]],
                     values[:, columns["position"]],
                     None if not columns["quaternion"] else values[:, columns["quaternion"]],
                     spec, source=str(path))


def check_log(times_s: np.ndarray, commands_pa: np.ndarray, tip_positions_m: np.ndarray,
              tip_quaternions: np.ndarray | None, spec: ArmSpec, source: str = "log") -> ArmLog:
    """A log's arrays checked against the arm ``spec`` and made into an :class:`ArmLog`.

    Args:
        times_s: sample times (s, (n,)).
        commands_pa: commanded pressures (Pa, (n, n_chambers)).
        tip_positions_m: tip positions (m, (n, 3)).
        tip_quaternions: tip orientations ((n, 4)) or ``None``.
        spec: the arm.
        source: what the messages call the log (its file).

    Raises:
        ValueError: see :func:`read_log`; rows counted from 1.
    """
    times = np.asarray(times_s, dtype=float)
    commands = np.asarray(commands_pa, dtype=float)
    positions = np.asarray(tip_positions_m, dtype=float)
    n = times.shape[0]
    if n < MIN_ROWS:
        raise ValueError(f"{source}: {n} samples, at least {MIN_ROWS} are needed")
    if commands.shape != (n, spec.n_chambers) or positions.shape != (n, 3):
        raise ValueError(f"{source}: commands must have shape ({n}, {spec.n_chambers}) and tip "
                         f"positions ({n}, 3), got {commands.shape} and {positions.shape}")
    for name, array in (("t", times), ("command", commands), ("tip position", positions)):
        bad = ~np.isfinite(array.reshape(n, -1)).all(axis=1)
        if bad.any():
            raise ValueError(f"{source}: row {int(np.argmax(bad)) + 1} holds a {name} that is "
                             f"not a finite number (NaN or inf): remove or fill that row")
    steps = np.diff(times)
    if (steps <= 0).any():
        row = int(np.argmax(steps <= 0)) + 2
        kind = "repeats" if steps[row - 2] == 0 else "goes back from"
        raise ValueError(f"{source}: column t at row {row}: time {float(times[row - 1])!r} s "
                         f"{kind} the row before ({float(times[row - 2])!r} s); t must be "
                         f"strictly increasing")
    distance = np.linalg.norm(positions, axis=1)
    limit = MILLIMETRE_FACTOR * spec.max_reach_m
    if (distance > limit).any():
        row = int(np.argmax(distance > limit)) + 1
        raise ValueError(f"{source}: columns x, y, z at row {row}: the tip is {distance[row - 1]:g}"
                         f" m from the base, more than {MILLIMETRE_FACTOR:g} times the arm's reach "
                         f"({spec.max_reach_m:g} m); the log looks like millimetres: give metres")
    p_max = np.asarray(spec.p_max_pa, dtype=float)
    outside = (commands < 0.0) | (commands > p_max)
    if outside.any():
        row, chamber = (int(i) for i in np.argwhere(outside)[0])
        raise ValueError(f"{source}: column p{chamber} at row {row + 1}: command "
                         f"{float(commands[row, chamber])!r} Pa is outside [0, {p_max[chamber]:g}] Pa "
                         f"(0 to the segment's p_max_pa, gauge)")
    quaternions = None
    if tip_quaternions is not None:
        quaternions = np.asarray(tip_quaternions, dtype=float)
        bad = ~np.isfinite(quaternions).all(axis=1)
        if bad.any():
            raise ValueError(f"{source}: row {int(np.argmax(bad)) + 1} holds a quaternion that "
                             f"is not a finite number (NaN or inf): remove or fill that row")
    return ArmLog(times, commands, positions, quaternions)


def write_log(path: str | Path, log: ArmLog) -> Path:
    """Write ``log`` as a CSV file :func:`read_log` reads (floats written exactly).

    Returns:
        the path written.
    """
    path = Path(path)
    n_chambers = log.commands_pa.shape[1]
    header = ["t", *(f"p{i}" for i in range(n_chambers)), *POSITION_COLUMNS]
    parts = [log.times_s[:, None], log.commands_pa, log.tip_positions_m]
    if log.tip_quaternions is not None:
        header += QUATERNION_COLUMNS
        parts.append(log.tip_quaternions)
    table = np.hstack(parts)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows([[repr(float(value)) for value in row] for row in table])
    return path


def _columns(header: list[str], spec: ArmSpec, path: Path) -> dict:
    """Where each needed column is in ``header``: ``t``, ``commands`` (chamber order),
    ``position`` and ``quaternion`` (empty when not logged)."""
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        raise ValueError(f"log {str(path)!r}: column {duplicated[0]!r} appears more than once")
    chambers = sorted(int(match.group(1)) for name in header
                      if (match := _COMMAND_COLUMN.match(name)))
    wanted = [f"p{i}" for i in range(spec.n_chambers)]
    missing = [name for name in ("t", *wanted, *POSITION_COLUMNS) if name not in header]
    present_q = [name for name in QUATERNION_COLUMNS if name in header]
    if present_q and len(present_q) < len(QUATERNION_COLUMNS):
        missing += [name for name in QUATERNION_COLUMNS if name not in header]
    extra = [f"p{i}" for i in chambers if i >= spec.n_chambers]
    if extra:
        raise ValueError(
            f"log {str(path)!r}: {len(chambers)} command columns "
            f"({', '.join(f'p{i}' for i in chambers)}), but arm {spec.name!r} has "
            f"{spec.n_chambers} chambers: give columns {', '.join(wanted)}")
    if missing:
        count = (f"; arm {spec.name!r} has {spec.n_chambers} chambers, one column each"
                 if any(name in wanted for name in missing) else "")
        raise ValueError(f"log {str(path)!r}: missing column{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(missing)} (needed: t, {', '.join(wanted)}, x, y, z in s, "
                         f"Pa and m; optional qx, qy, qz, qw){count}")
    return {"t": header.index("t"), "commands": [header.index(name) for name in wanted],
            "position": [header.index(name) for name in POSITION_COLUMNS],
            "quaternion": [header.index(name) for name in present_q]}


def _numbers(rows: list[list[str]], header: list[str], columns: dict, path: Path) -> np.ndarray:
    """The needed columns of ``rows`` as floats ((n, len(header))); unneeded columns are NaN."""
    needed = [columns["t"], *columns["commands"], *columns["position"], *columns["quaternion"]]
    values = np.full((len(rows), len(header)), np.nan)
    for row, cells in enumerate(rows, start=1):
        if len(cells) != len(header):
            raise ValueError(f"log {str(path)!r}: row {row} has {len(cells)} cells, the header "
                             f"{len(header)}")
        for column in needed:
            text = cells[column].strip()
            try:
                values[row - 1, column] = float(text)
            except ValueError:
                raise ValueError(f"log {str(path)!r}: column {header[column]} at row {row}: "
                                 f"{text!r} is not a number") from None
            if not np.isfinite(values[row - 1, column]):
                raise ValueError(f"log {str(path)!r}: column {header[column]} at row {row}: "
                                 f"{text!r} is not a finite number (NaN or inf): remove or fill "
                                 f"that row")
    return values
