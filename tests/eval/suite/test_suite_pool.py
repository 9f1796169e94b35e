"""A pool worker killed mid-run (``SIGKILL``) costs only its run: the run is tried once more in
a process of its own, the others go on, and a run whose process dies twice is reported failed
with the signal (:mod:`eval.pool`), the suite then exiting non-zero and naming it."""

from __future__ import annotations

import functools
import os

import pytest

import eval.__main__ as eval_main
from dying_jobs import dying_backend, square_or_die
from eval import suite
from eval.pool import WorkerDeathError, process_map
from suite_specs import tiny_suite

VALUES = list(range(8))
VICTIM = 3
CAUSE = "worker process died (exit code -9 / signal SIGKILL)"


def test_a_job_whose_worker_dies_once_succeeds_on_its_retry(tmp_path):
    marker = tmp_path / "died"
    run = functools.partial(square_or_die, victim=VICTIM, marker=str(marker))
    assert sorted(process_map(run, VALUES, workers=2)) == [v * v for v in VALUES]
    assert marker.exists()  # it did die once


def test_a_job_whose_worker_always_dies_is_reported_after_every_other_result():
    results = []
    with pytest.raises(WorkerDeathError, match="SIGKILL") as error:
        for result in process_map(functools.partial(square_or_die, victim=VICTIM), VALUES,
                                  workers=2):
            results.append(result)
    assert sorted(results) == [v * v for v in VALUES if v != VICTIM]
    assert [(death.item, death.cause) for death in error.value.deaths] == [(VICTIM, CAUSE)]


def test_the_serial_path_runs_every_job_here_in_order():
    assert list(process_map(lambda v: (v, os.getpid()), VALUES, workers=1)) == [
        (v, os.getpid()) for v in VALUES]


def _cells(tmp_path):
    spec_path = tmp_path / "pool.yaml"
    spec_path.write_text(tiny_suite("pool", (0, 1)))
    spec = suite.load_suite(spec_path)
    return spec_path, spec, suite.expand(spec)


def test_a_suite_run_whose_worker_always_dies_fails_alone_and_resume_redoes_it(tmp_path):
    _, spec, cells = _cells(tmp_path)
    victim, out = cells[2].key, tmp_path / "out"
    with pytest.raises(suite.SuiteRunError) as error:
        suite.run_suite(spec, out, workers=2, backend=dying_backend(victim), progress=False,
                        check=False)
    assert [f["key"] for f in error.value.failures] == [victim]
    assert f"1 run(s) failed: {victim}" in str(error.value) and CAUSE in str(error.value)
    assert CAUSE in (out / "errors" / f"{victim}.txt").read_text()
    assert [c.key for c in cells if not suite.is_finished(out, c.key)] == [victim]
    assert not (out / "locks").exists()

    suite.record_path(out, cells[0].key).unlink()  # two runs to resume: a pool, not in here
    marker = tmp_path / "died"  # dies once more, then the retry finishes it
    counts = suite.run_suite(spec, out, workers=2, resume=True, progress=False, check=False,
                             backend=dying_backend(victim, str(marker)))
    assert marker.exists() and all(suite.is_finished(out, c.key) for c in cells)
    assert (counts["skipped"], counts["n/a"]) == (len(cells) - 2, 2)


def test_a_suite_run_whose_worker_dies_once_is_recorded_like_the_others(tmp_path):
    _, spec, cells = _cells(tmp_path)
    victim = cells[0].key
    counts = suite.run_suite(spec, tmp_path / "out", workers=2, progress=False, check=False,
                             backend=dying_backend(victim, str(tmp_path / "died")))
    assert counts["n/a"] == len(cells) and not (tmp_path / "out" / "errors").exists()
    for cell in cells:
        assert suite.read_record(tmp_path / "out", cell.key)["reason"] == "a stand-in run"


def test_the_command_line_exits_non_zero_naming_the_run_whose_worker_always_dies(
        tmp_path, monkeypatch, capsys):
    pytest.importorskip("rliable")
    spec_path, _, cells = _cells(tmp_path)
    victim, out = cells[1].key, tmp_path / "out"
    monkeypatch.setitem(suite.BACKENDS, "process", dying_backend(victim))
    monkeypatch.setattr(suite, "check_suite", lambda spec, progress, checker: suite.expand(spec))
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", str(spec_path), "--out", str(out), "--workers", "2"])
    assert exit_info.value.code == 1
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if line.startswith("error:")]
    assert len(error) == 1 and f"1 run(s) failed: {victim}" in error[0] and CAUSE in error[0]
    assert (out / "leaderboard.md").is_file()  # the report of the others is written
