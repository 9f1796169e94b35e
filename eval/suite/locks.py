"""Claiming a suite's cells, so that two processes on one output directory never run the same cell
(:mod:`eval.suite`, "Running").

A claim is the lock file ``out/locks/<key>.lock`` holding its owner (``pid``, ``host`` and, on
Linux, the process's start time in clock ticks since boot, which tells a live owner from a
later process given the same pid). It is made atomically: written in full to a temporary file,
then hard-linked to its name, which fails when the name is taken, so a reader never sees half a
claim. A claim whose owner is on this host and no longer alive is stale: the next process takes
it over (renamed away first, so of two successors only one wins). A claim from another host is
never taken over (its owner cannot be checked from here): delete its file once that process is
known to be gone. A run removes the claims' directory when it ends empty
(:func:`remove_locks_dir`); a claim made meanwhile makes it again.
"""

from __future__ import annotations

import json
import os
import socket
import tempfile
from pathlib import Path
from typing import Any

LOCKS_DIR = "locks"
"""The claims' directory under a suite's output directory."""


def lock_path(out: str | os.PathLike, key: str) -> Path:
    """The claim (lock file) of cell ``key`` under the output directory ``out``."""
    return Path(out) / LOCKS_DIR / f"{key}.lock"


def _start_ticks(pid: int) -> int | None:
    """Process ``pid``'s start time (clock ticks after boot; Linux ``/proc``), or ``None``."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # the command name (field 2) is in parentheses and may hold spaces: split after it
    fields = stat[stat.rfind(")") + 2:].split()
    try:
        return int(fields[19])  # field 22 of proc(5), the third and later fields from 0
    except (IndexError, ValueError):
        return None


def this_owner() -> dict[str, Any]:
    """This process as the owner of a claim: ``{"pid", "host", "start_ticks"}``."""
    return {"pid": os.getpid(), "host": socket.gethostname(),
            "start_ticks": _start_ticks(os.getpid())}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    except OSError:
        return False
    return True


def is_stale(owner: Any) -> bool:
    """Whether a claim's ``owner`` is a process of this host that has ended (or an unreadable
    claim); a claim of another host is never stale."""
    if not isinstance(owner, dict):
        return True
    pid, host = owner.get("pid"), owner.get("host")
    if not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0 or not isinstance(host, str):
        return True
    if host != socket.gethostname():
        return False
    if not _alive(pid):
        return True
    ticks = owner.get("start_ticks")
    return ticks is not None and _start_ticks(pid) not in (None, ticks)  # pid reused since


def read_owner(path: Path) -> dict[str, Any] | None:
    """The owner written in the claim ``path``; ``None`` when it is absent or unreadable."""
    try:
        owner = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    return owner if isinstance(owner, dict) else None


def claim(out: str | os.PathLike, key: str) -> bool:
    """Claim cell ``key`` for this process: ``True`` when this process holds it now (made, taken
    over from a dead owner, or already its own), ``False`` when a live process holds it."""
    path = lock_path(out, key)
    me = this_owner()
    for _ in range(4):
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            handle, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                           dir=path.parent)
        except FileNotFoundError:  # another run removed the empty directory just now
            continue
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                json.dump(me, stream)
            os.link(tmp, path)  # atomic; fails when the name is taken
            return True
        except FileExistsError:
            pass
        finally:
            Path(tmp).unlink(missing_ok=True)
        owner = read_owner(path)
        if owner == me:
            return True
        if not is_stale(owner):
            return False
        # take the stale claim over: rename it away (one successor wins), check it is the one read
        moved = path.with_name(f".{path.name}.{me['pid']}.stale")
        try:
            os.replace(path, moved)
        except FileNotFoundError:
            continue
        if read_owner(moved) != owner:  # a fresh claim was made meanwhile: put it back
            try:
                os.link(moved, path)
            except FileExistsError:
                pass
            moved.unlink(missing_ok=True)
            return False
        moved.unlink(missing_ok=True)
    return False


def release(out: str | os.PathLike, key: str) -> None:
    """Give up this process's claim of cell ``key`` (another process's is left alone)."""
    path = lock_path(out, key)
    if read_owner(path) == this_owner():
        path.unlink(missing_ok=True)


def remove_locks_dir(out: str | os.PathLike) -> None:
    """Remove the claims' directory of the output directory ``out`` if it is empty (a run's
    end: the claims of other live processes keep it)."""
    try:
        (Path(out) / LOCKS_DIR).rmdir()
    except OSError:  # absent, or holding another process's claims
        pass


__all__ = ["LOCKS_DIR", "claim", "is_stale", "lock_path", "read_owner", "release",
           "remove_locks_dir", "this_owner"]
