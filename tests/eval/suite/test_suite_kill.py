"""A suite killed mid-way (``kill -9`` of ``python -m eval suite`` on the process pool) leaves no
process behind within 10 s (its pool workers end with it, and the pool's resource tracker with
them), and ``--resume`` then finishes it with records identical to an uninterrupted run's (the
per-step arrays bit for bit), taking over the dead process's claims."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from eval import suite
from suite_specs import tiny_suite

pytest.importorskip("rliable")

ROOT = Path(__file__).resolve().parents[3]
SPEC = tiny_suite("killed", (0, 1))
"""Four quick wang2023 runs and two n/a: enough that the first record comes before the last."""

GONE_S = 10.0
"""How long the killed suite's processes may outlive it (s)."""


def _children() -> dict[int, list[int]]:
    """Parent pid -> its children's pids, from ``/proc``."""
    tree: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        ppid = int(stat[stat.rfind(")") + 2:].split()[1])
        tree.setdefault(ppid, []).append(int(entry.name))
    return tree


def _descendants(pid: int) -> set[int]:
    tree, found, todo = _children(), set(), [pid]
    while todo:
        for child in tree.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def _alive(pids: set[int]) -> set[int]:
    alive = set()
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text()
        except OSError:
            continue
        if state[state.rfind(")") + 2] != "Z":  # a zombie has ended
            alive.add(pid)
    return alive


def _comparable(record: dict) -> dict:
    return {k: v for k, v in record.items() if k not in ("wall_s", "git_revision")}


def _suite(spec: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "eval", "suite", str(spec), "--out", str(out), "--workers", "2",
            *extra]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc")
def test_a_killed_suite_leaves_no_process_and_resumes_to_identical_records(tmp_path):
    spec_path = tmp_path / "killed.yaml"
    spec_path.write_text(SPEC)
    spec = suite.load_suite(spec_path)
    cells = suite.expand(spec)
    reference = tmp_path / "reference"
    suite.run_suite(spec, reference, backend="serial", progress=False, check=False)

    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    main = subprocess.Popen(_suite(spec_path, out), cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while not list(suite.records_dir(out).glob("*.json")):
            assert main.poll() is None, "the suite ended before its first record"
            assert time.monotonic() < deadline, "no record within 300 s"
            time.sleep(0.05)
        family = _descendants(main.pid)
        main.send_signal(signal.SIGKILL)
        main.wait()
    finally:
        if main.poll() is None:
            main.kill()
    finished = [c for c in cells if suite.is_finished(out, c.key)]
    assert 0 < len(finished) < len(cells), "killed after the end, not mid-way"
    assert len(family) >= 2  # the pool's workers (and its resource tracker)

    deadline = time.monotonic() + GONE_S
    while _alive(family) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _alive(family), f"processes left {GONE_S} s after the kill: {_alive(family)}"

    resumed = subprocess.run(_suite(spec_path, out, "--resume"), cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"{len(cells)} runs ({len(finished)} already done)" in resumed.stdout
    for cell in cells:
        record, expected = suite.read_record(out, cell.key), suite.read_record(reference, cell.key)
        assert _comparable(record) == _comparable(expected), cell.labels
        steps, expected_steps = suite.read_steps(out, cell.key), suite.read_steps(reference,
                                                                                   cell.key)
        if expected_steps is None:
            assert steps is None
            continue
        assert sorted(steps) == sorted(expected_steps)
        for name, array in expected_steps.items():
            assert steps[name].dtype == array.dtype and steps[name].tobytes() == array.tobytes()
    assert not list((out / "locks").glob("*.lock"))  # the dead process's claims taken over
    counts = json.loads((out / "suite.json").read_text())["counts"]
    assert counts == {"cells": len(cells), "done": 4, "n/a": 2, "missing": 0, "bad": 0}
