"""Numbers measured by hand, which no run record holds, as ``docs/results.md`` shows them.

``docs/measurements.yaml`` is a list of entries, each a mapping of exactly these keys, every
value a non-empty string:

* ``title``: what was measured (the entry's heading on the page);
* ``command``: the command that measured it (shell lines, ``;``-separated where several; no
  backquote: the page writes it as code);
* ``machine``: where it ran (cores, and whether other jobs shared them);
* ``revision``: the git commit that recorded the numbers (7 to 40 hex digits);
* ``text``: the measurement in Markdown (tables, times, ratios), its links relative to
  ``docs/``.

A number of the page's other sections comes from a run's own record; one here changes only
when someone measures it again and edits its entry, revision included.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

MEASUREMENTS_YAML = Path("docs") / "measurements.yaml"
"""The hand-measured numbers, relative to the repository's root."""

FIELDS = ("title", "command", "machine", "revision", "text")
"""The keys of an entry, in the order the file writes them."""

_REVISION = re.compile(r"^[0-9a-f]{7,40}$")


@dataclass(frozen=True)
class Measurement:
    """One entry of ``docs/measurements.yaml`` (see the module's docstring for each field)."""

    title: str
    command: str
    machine: str
    revision: str
    text: str


def _entry(path: Path, index: int, item: Any) -> Measurement:
    """Entry ``index`` of the file at ``path``, checked; ``ValueError`` naming the entry and the
    key otherwise."""
    where = f"{path}: entry {index}"
    if not isinstance(item, dict):
        raise ValueError(f"{where} must be a mapping of {', '.join(FIELDS)}, got "
                         f"{type(item).__name__}")
    unknown = sorted(set(item) - set(FIELDS))
    missing = [key for key in FIELDS if key not in item]
    if unknown or missing:
        raise ValueError(f"{where} has keys {sorted(item)}: allowed and required are "
                         f"{', '.join(FIELDS)}")
    for key in FIELDS:
        if not isinstance(item[key], str) or not item[key].strip():
            raise ValueError(f"{where} ({item.get('title')!r}): {key} must be a non-empty "
                             f"string, got {item[key]!r}")
    if "`" in item["command"]:
        raise ValueError(f"{where} ({item['title']!r}): command must not hold a backquote (the "
                         f"page writes it as code), got {item['command']!r}")
    if not _REVISION.match(item["revision"]):
        raise ValueError(f"{where} ({item['title']!r}): revision must be a git commit of 7-40 "
                         f"lowercase hex digits, got {item['revision']!r}")
    return Measurement(**{key: item[key].strip() for key in FIELDS})


def load_measurements(path: Path) -> list[Measurement]:
    """The entries of the measurements file at ``path``, in its order.

    Raises:
        ValueError: the file is not a YAML list of entries, or an entry is malformed (the
            message names the file, the entry and the key).
    """
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as error:
        raise ValueError(f"{path} is not readable YAML ({type(error).__name__})") from None
    if not isinstance(data, list) or not data:
        raise ValueError(f"{path} must hold a non-empty list of entries, got "
                         f"{type(data).__name__}")
    return [_entry(path, index, item) for index, item in enumerate(data)]


def measurements_section(root: Path) -> list[str]:
    """The page's lines for every entry of ``docs/measurements.yaml`` under ``root``."""
    lines = ["## Measured by hand", "",
             "Numbers no run record holds, and what the records above were found to show, from "
             "[`measurements.yaml`](measurements.yaml): each with the command that measured it, "
             "the machine it ran on and the commit that recorded it. Times are wall times; most "
             "of the work is single-threaded and CPU-bound, so CPU time is close to wall time on "
             "an idle machine, and on a machine loaded by other jobs the same commands took 3-4 "
             "times as long.", ""]
    for entry in load_measurements(root / MEASUREMENTS_YAML):
        lines += [f"### {entry.title}", "",
                  f"Measured by `{entry.command}` on {entry.machine}; recorded at "
                  f"{entry.revision}.", "", entry.text, ""]
    return lines
