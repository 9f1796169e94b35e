"""The suite's records verified when read (eval/suite/store.py) and its cells claimed by one process
(eval/suite/locks.py): every kind of tampering (a truncated ``.npz`` or JSON, a record copied
over another, null or edited metrics, ``[]``, changed arrays) is reported by path, left out of the
report and redone on ``resume``, the redone record equal to the original; ``out/records`` being a
file is refused before any work; a cell held by a live process is left to it, and a dead
process's claim is taken over."""

from __future__ import annotations

import importlib.util
import io
import json
import os
import shutil
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import eval.__main__ as eval_main
from eval import suite
from eval.suite import locks as claim_module
from eval.suite import report
from suite_specs import counting_backend, tiny_suite

pytest.importorskip("rliable")

TINY = tiny_suite("records")
"""Two quick wang2023 runs (nominal, 10 g tip) and one n/a (the wang2023 agent on ho2018)."""


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """``(spec, cells, out)``: the tiny suite run once, every record written."""
    root = tmp_path_factory.mktemp("records")
    path = root / "records.yaml"
    path.write_text(TINY)
    spec = suite.load_suite(path)
    out = root / "out"
    counts = suite.run_suite(spec, out, backend="serial", progress=False)
    assert (counts["done"], counts["n/a"]) == (2, 1)
    return spec, suite.expand(spec), out


@pytest.fixture
def records(finished, tmp_path):
    """A fresh copy of the finished records: ``(spec, cells by condition label, out)``."""
    spec, cells, out = finished
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    by_name = {f"{c.labels['preset']}/{c.labels['condition']}": c for c in cells}
    return spec, by_name, copy


def _comparable(record: dict) -> dict:
    """A record less what differs between two runs of one cell (wall time, revision)."""
    return {k: v for k, v in record.items() if k not in ("wall_s", "git_revision")}


@pytest.mark.smoke
def test_sound_records_verify_and_carry_the_digest_of_their_arrays(records):
    _, cells, out = records
    for name, cell in cells.items():
        record = suite.read_record(out, cell.key)
        assert suite.record_problem(out, cell.key) is None and suite.is_finished(out, cell.key)
        steps = suite.read_steps(out, cell.key)
        if record["status"] == "done":
            assert record["steps_sha256"] == suite.steps_digest(steps)
            # the digest is of the arrays (an independent hash here), not of the zip's bytes
            reference = __import__("hashlib").sha256()
            for array_name in sorted(steps):
                array = np.ascontiguousarray(steps[array_name])
                reference.update(json.dumps([array_name, array.dtype.str, list(array.shape)],
                                            separators=(",", ":")).encode())
                reference.update(array.tobytes())
            assert record["steps_sha256"] == reference.hexdigest()
        else:
            assert steps is None and record["steps_sha256"] is None


# ------------------------------------------------------------------------------- tampering
def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


def _edit_json(path: Path, change) -> None:
    record = json.loads(path.read_text())
    change(record)
    path.write_text(json.dumps(record))


def _copy_over(out: Path, cells, rekey: bool) -> None:
    """The loaded run's record (JSON and arrays) copied over the nominal run's."""
    source, target = cells["wang2023/load_10g"].key, cells["wang2023/nominal"].key
    shutil.copy(suite.steps_path(out, source), suite.steps_path(out, target))
    record = json.loads(suite.record_path(out, source).read_text())
    if rekey:  # the key edited to the file's: only the config's hash tells
        record["key"], record["steps_file"] = target, f"{target}.npz"
    suite.record_path(out, target).write_text(json.dumps(record))


def _change_arrays(path: Path) -> None:
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["tip_m"] = arrays["tip_m"] + 1e-4
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    path.write_bytes(buffer.getvalue())


NOMINAL = "wang2023/nominal"
TAMPERING = {  # name -> (cell, change(out, cells), words the problem must hold)
    "truncated npz": (NOMINAL, lambda out, c: _truncate(suite.steps_path(out, c[NOMINAL].key)),
                      "cannot be read"),
    "truncated json": (NOMINAL, lambda out, c: _truncate(suite.record_path(out, c[NOMINAL].key)),
                       "not readable JSON"),
    "copied over another": (NOMINAL, lambda out, c: _copy_over(out, c, rekey=False),
                            "copied over another"),
    "copied over, key edited": (NOMINAL, lambda out, c: _copy_over(out, c, rekey=True),
                                "does not hash to its key"),
    "null metrics": (NOMINAL, lambda out, c: _edit_json(
        suite.record_path(out, c[NOMINAL].key), lambda r: r.update(metrics=None)),
        "without metrics"),
    "edited score": (NOMINAL, lambda out, c: _edit_json(
        suite.record_path(out, c[NOMINAL].key),
        lambda r: r["metrics"].update(last_cycle_error_mm=r["metrics"]["last_cycle_error_mm"]
                                      + 1.0)), "per-step arrays give"),
    "an empty list": (NOMINAL, lambda out, c: suite.record_path(out, c[NOMINAL].key)
                      .write_text("[]"), "JSON object"),
    "changed arrays": (NOMINAL, lambda out, c: _change_arrays(
        suite.steps_path(out, c[NOMINAL].key)), "do not match the digest"),
    "arrays deleted": (NOMINAL, lambda out, c: suite.steps_path(out, c[NOMINAL].key).unlink(),
                       "missing"),
    "not utf-8": (NOMINAL, lambda out, c: suite.record_path(out, c[NOMINAL].key)
                  .write_bytes(b"\xff\xfe{}"), "not readable JSON"),
    "n/a without a reason": ("ho2018/nominal", lambda out, c: _edit_json(
        suite.record_path(out, c["ho2018/nominal"].key), lambda r: r.update(reason=None)),
        "needs a reason"),
    "unknown status": (NOMINAL, lambda out, c: _edit_json(
        suite.record_path(out, c[NOMINAL].key), lambda r: r.update(status="ok")), "status"),
}


@pytest.mark.parametrize("case", sorted(TAMPERING))
def test_a_tampered_record_is_reported_by_path_left_out_and_redone(case, records):
    spec, cells, out = records
    name, change, words = TAMPERING[case]
    key = cells[name].key
    original = _comparable(suite.read_record(out, key))
    change(out, cells)

    problem = suite.record_problem(out, key)
    assert problem is not None and words in str(problem), problem
    assert problem.path.name.startswith(key) and str(problem.path) in str(problem)
    assert not suite.is_finished(out, key)
    with pytest.raises(suite.RecordError):
        suite.read_record(out, key) if problem.path.suffix == ".json" else \
            suite.read_steps(out, key)
    others = [c.key for c in cells.values() if c.key != key]
    assert all(suite.record_problem(out, k) is None for k in others)

    rows = {row["key"]: row for row in report.collect_rows(list(cells.values()), out)}
    assert rows[key]["status"] == "bad" and str(problem.path) in rows[key]["reason"]
    text = report.write_report(spec, out, reps=50, profile_reps=20, plots=False)
    assert "1 bad record(s) left out" in text
    assert json.loads((out / "suite.json").read_text())["bad_records"] == [str(problem)]

    ran: list[str] = []
    counts = suite.run_suite(spec, out, resume=True, backend=counting_backend(ran),
                             progress=False, check=False)
    assert ran == [key] and counts["bad"] == 1 and counts["skipped"] == 2
    assert suite.record_problem(out, key) is None
    assert _comparable(suite.read_record(out, key)) == original


def test_report_only_flags_bad_records_by_path_and_exits_1(records, capsys):
    spec, cells, out = records
    key = cells[NOMINAL].key
    _truncate(suite.steps_path(out, key))
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", spec.source, "--out", str(out), "--report-only"])
    assert exit_info.value.code == 1
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if line.startswith("error:")]
    assert len(error) == 1 and str(suite.steps_path(out, key)) in error[0]
    assert "--resume" in error[0]
    assert captured.out.strip().splitlines()[-1] == f"output directory: {out}"
    board = (out / "leaderboard.md").read_text()
    assert "1 bad record(s)" in board and "record(s) bad" in board


def test_records_being_a_file_is_refused_before_any_work(tmp_path, capsys):
    spec_path = tmp_path / "s.yaml"
    spec_path.write_text(TINY)
    out = tmp_path / "out"
    out.mkdir()
    (out / "records").write_text("not a directory")
    with pytest.raises(ValueError, match="records is a file, not a directory"):
        suite.run_suite(suite.load_suite(spec_path), out, progress=False, check=False,
                        backend=counting_backend(ran := []))
    assert ran == []
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", str(spec_path), "--out", str(out), "--resume"])
    assert exit_info.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].startswith("python -m eval suite: error: --out:") and "records" in lines[-1]
    assert sorted(p.name for p in out.iterdir()) == ["records"]


# ---------------------------------------------------------------------------------- claims
def _sleeper() -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])


def _owner_of(pid: int, host: str | None = None) -> dict:
    return {"pid": pid, "host": host or socket.gethostname(),
            "start_ticks": claim_module._start_ticks(pid)}


def _hold(out: Path, key: str, owner: dict) -> None:
    path = suite.lock_path(out, key)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(owner))


@pytest.mark.smoke
def test_a_claim_is_exclusive_and_taken_over_only_from_a_dead_owner(tmp_path):
    out, key = tmp_path / "out", "0123456789abcdef"
    assert suite.claim(out, key) and suite.claim(out, key)  # made, then already ours
    owner = json.loads(suite.lock_path(out, key).read_text())
    assert owner == {"pid": os.getpid(), "host": socket.gethostname(),
                     "start_ticks": claim_module._start_ticks(os.getpid())}
    suite.release(out, key)
    assert not suite.lock_path(out, key).exists()

    sleeper = _sleeper()
    try:
        _hold(out, key, _owner_of(sleeper.pid))
        assert not suite.claim(out, key)  # a live process holds it
        suite.release(out, key)  # not ours: left alone
        assert json.loads(suite.lock_path(out, key).read_text())["pid"] == sleeper.pid
        reused = dict(_owner_of(sleeper.pid), start_ticks=_owner_of(sleeper.pid)["start_ticks"]
                      - 1)
        _hold(out, key, reused)  # the same pid, another process (the pid was reused)
        assert suite.claim(out, key)
        _hold(out, key, _owner_of(sleeper.pid))
    finally:
        sleeper.kill()
        sleeper.wait()
    assert suite.claim(out, key)  # its owner died: taken over
    assert json.loads(suite.lock_path(out, key).read_text())["pid"] == os.getpid()

    _hold(out, key, _owner_of(sleeper.pid, host="another-host.invalid"))
    assert not suite.claim(out, key)  # another host's: never taken over from here
    suite.lock_path(out, key).write_text("{trunc")
    assert suite.claim(out, key)  # an unreadable claim is no one's
    assert not list(suite.lock_path(out, key).parent.glob(".*"))  # no temporary files left


def test_run_suite_leaves_a_cell_held_by_a_live_process_to_it(records):
    spec, cells, out = records
    key = cells[NOMINAL].key
    suite.record_path(out, key).unlink()
    sleeper = _sleeper()
    try:
        _hold(out, key, _owner_of(sleeper.pid))
        ran: list[str] = []
        counts = suite.run_suite(spec, out, resume=True, backend=counting_backend(ran),
                                 progress=False, check=False)
        assert ran == [] and counts["claimed_elsewhere"] == 1
        assert suite.read_record(out, key) is None
    finally:
        sleeper.kill()
        sleeper.wait()
    ran = []
    counts = suite.run_suite(spec, out, resume=True, backend=counting_backend(ran),
                             progress=False, check=False)
    assert ran == [key] and counts["done"] == 1 and counts["claimed_elsewhere"] == 0
    assert not any(suite.lock_path(out, c.key).exists() for c in cells.values())


_CLAIMER = textwrap.dedent("""\
    import importlib.util, json, sys, time
    spec = importlib.util.spec_from_file_location("claim", sys.argv[1])
    claim = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(claim)
    while time.time() < float(sys.argv[3]):
        time.sleep(0.001)
    won = [key for key in sys.argv[4:] if claim.claim(sys.argv[2], key)]
    print(json.dumps(won), flush=True)
    time.sleep(3)  # alive while the other claims: its claims are not stale
""")


def test_two_processes_claiming_at_once_never_both_win_a_cell(tmp_path):
    module = Path(claim_module.__file__)
    keys = [f"{i:016x}" for i in range(200)]
    start = time.time() + 2.0
    processes = [subprocess.Popen([sys.executable, "-c", _CLAIMER, str(module),
                                   str(tmp_path), str(start), *keys],
                                  stdout=subprocess.PIPE, text=True) for _ in range(2)]
    won = [json.loads(p.communicate(timeout=60)[0]) for p in processes]
    assert all(p.returncode == 0 for p in processes)
    assert not set(won[0]) & set(won[1])
    assert sorted(won[0] + won[1]) == keys


def _load_claim_module_alone():
    """The locks module loads on its own (the claimer processes above rely on it)."""
    spec = importlib.util.spec_from_file_location("claim_alone", claim_module.__file__)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_locks_module_needs_only_the_standard_library():
    assert _load_claim_module_alone().lock_path("o", "k") == Path("o") / "locks" / "k.lock"


def _failing_backend(ran: list[str]):
    """A suite backend that runs nothing: every cell comes back failed."""
    def map_function(fn, items, workers):
        for item in items:
            ran.append(item["key"])
            yield {"key": item["key"], "labels": item["labels"], "status": "error",
                   "error": "RuntimeError: boom", "traceback": "boom"}
    return map_function


def test_a_run_leaves_no_empty_locks_folder_behind(tmp_path):
    """The claims' folder goes with the last claim; a live process's claim keeps it."""
    path = tmp_path / "records.yaml"
    path.write_text(TINY)
    spec = suite.load_suite(path)
    out = tmp_path / "out"
    ran: list[str] = []
    with pytest.raises(suite.SuiteRunError):
        suite.run_suite(spec, out, backend=_failing_backend(ran), progress=False, check=False)
    assert len(ran) == 3 and (out / "errors").is_dir()
    assert not (out / claim_module.LOCKS_DIR).exists()

    key = suite.expand(spec)[0].key
    sleeper = _sleeper()
    try:
        _hold(out, key, _owner_of(sleeper.pid))
        ran = []
        with pytest.raises(suite.SuiteRunError):
            suite.run_suite(spec, out, backend=_failing_backend(ran), progress=False,
                            check=False)
        assert key not in ran and len(ran) == 2
        assert [p.name for p in (out / claim_module.LOCKS_DIR).iterdir()] == [f"{key}.lock"]
    finally:
        sleeper.kill()
        sleeper.wait()
