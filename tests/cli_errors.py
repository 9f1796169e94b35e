"""The check of a command line's one-line error, shared by the command-line tests and the bad-input
sweep: exit status 2, a one-line usage hint, one error line naming the option, no traceback,
nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest


def assert_one_line_error(main, argv: list[str], option: str, capsys, out: Path | None = None,
                          also: str | None = None) -> str:
    """``main(argv)`` exits 2 printing a one-line usage hint and one error line that names
    ``option`` (and ``also``), with no traceback, before writing ``out``; returns the line."""
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2, argv
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    errors = [line for line in lines if ": error:" in line]
    assert len(errors) == 1 and lines[-1] == errors[0], lines
    assert len(lines) == 2 and lines[0].startswith("usage:"), lines  # not the whole usage block
    assert "Traceback" not in "\n".join(lines)
    assert option in errors[0], (option, errors[0])
    assert also is None or also in errors[0], (also, errors[0])
    assert out is None or not out.exists(), "wrote output before refusing"
    return errors[0]
