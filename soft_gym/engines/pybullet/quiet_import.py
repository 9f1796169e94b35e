"""PyBullet, imported and connected without its chatter on standard output.

``import pybullet`` prints ``pybullet build time: ...`` (to stdout or stderr, depending on the
build) and every ``connect`` through a ``BulletClient`` prints ``argv[0]=``, from C code,
straight to the file descriptors: into a user's terminal, a captured test output or a pipe that
expects data. :mod:`soft_gym` imports this module before anything else
(``soft_gym/__init__.py``), so the package's first ``import pybullet`` happens here, and the
simulator connects through :func:`c_stdout_silenced`. Only file descriptor 1 is silenced, and
only for those calls; of standard error, where PyBullet reports real errors, only the banner line
of the import is held back, and what Python code prints meanwhile reaches standard output as
usual.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import tempfile
from typing import Iterator


def _flush_c_streams() -> None:
    """Flush the C library's output buffers (a pipe's stdout is block-buffered: without this,
    PyBullet's text would be written after file descriptor 1 is restored)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library to load by name (Windows)
        pass


@contextlib.contextmanager
def c_stdout_silenced() -> Iterator[None]:
    """Send what C code writes to file descriptor 1 to the null device while the block runs."""
    try:
        sys.stdout.flush()  # Python's own pending output goes out first, where it belongs
    except (AttributeError, ValueError, OSError):
        pass
    try:
        saved = os.dup(1)
    except OSError:  # no file descriptor 1 to silence
        yield
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
        finally:
            os.close(null)
        try:
            yield
        finally:
            _flush_c_streams()
            os.dup2(saved, 1)
    finally:
        os.close(saved)


@contextlib.contextmanager
def _banner_filtered_from_stderr(banner: bytes) -> Iterator[None]:
    """Hold back what C code writes to file descriptor 2 while the block runs, then pass it on
    without the lines starting with ``banner`` (nothing else is hidden)."""
    try:
        sys.stderr.flush()
    except (AttributeError, ValueError, OSError):
        pass
    try:
        saved = os.dup(2)
        held = tempfile.TemporaryFile()
    except OSError:
        yield
        return
    try:
        os.dup2(held.fileno(), 2)
        try:
            yield
        finally:
            _flush_c_streams()
            os.dup2(saved, 2)
        held.seek(0)
        rest = b"".join(line for line in held.read().splitlines(keepends=True)
                        if not line.startswith(banner))
        if rest:
            os.write(2, rest)
    finally:
        os.close(saved)
        held.close()


# the build-time banner goes to stdout or stderr depending on the PyBullet build
with c_stdout_silenced(), _banner_filtered_from_stderr(b"pybullet build time"):
    import pybullet  # noqa: E402,F401

__all__ = ["c_stdout_silenced", "pybullet"]
