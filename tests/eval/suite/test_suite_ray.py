"""The suite's Ray backend (eval/suite/ray_backend.py, ``python -m eval suite --backend ray``): a
small grid on a local Ray (two CPUs) writes the same records as the process pool; the map starts,
connects to and shuts down only the Ray it should (checked on a stand-in module, without Ray);
the command line's backend options fail in one line before any work. Ray is an optional extra:
the two tests that start a real local Ray run with ``-m slow``; the stand-in tests run always."""

from __future__ import annotations

import json
import math
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import eval.__main__ as eval_main
from eval import suite
from suite_specs import assert_suite_cli_error, tiny_suite
from eval.suite import ray_backend


GRID = tiny_suite("ray_grid", (0, 1))
"""Four quick wang2023 runs (a 26-step circle, one cycle) and two n/a (cc_model refuses
ho2018's two segments)."""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "grid.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def _without_wall_time(record: dict) -> dict:
    """A record less its wall time and the checkout's revision (read at each run's start: a
    commit by someone else between the two runs would change it)."""
    assert record["wall_s"] > 0 and "git_revision" in record
    return {key: value for key, value in record.items() if key not in ("wall_s", "git_revision")}


# ----------------------------------------------------------------------- on a local Ray
@pytest.mark.slow
def test_ray_records_equal_the_process_pool_records(tmp_path, local_ray, capsys):
    pytest.importorskip("rliable")
    spec_path = _write(tmp_path, GRID)
    spec = suite.load_suite(spec_path)
    cells = suite.expand(spec)
    assert len(cells) == 6
    process_out, ray_out = tmp_path / "process", tmp_path / "ray"
    counts = suite.run_suite(spec, process_out, workers=2, backend="process", progress=False,
                             check=False)
    assert (counts["done"], counts["n/a"]) == (4, 2)

    eval_main.main(["suite", str(spec_path), "--out", str(ray_out), "--backend", "ray",
                    "--workers", "2"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1] == f"output directory: {ray_out}"
    assert local_ray.is_initialized()  # a Ray the backend did not start is left running

    for cell in cells:
        by_process = suite.read_record(process_out, cell.key)
        by_ray = suite.read_record(ray_out, cell.key)
        assert _without_wall_time(by_ray) == _without_wall_time(by_process), cell.labels
        if by_process["status"] == "done":
            # the same numbers, to the last digit, in the JSON and the per-step arrays
            assert json.dumps(by_ray["metrics"]) == json.dumps(by_process["metrics"])
            assert math.isfinite(by_ray["metrics"]["last_cycle_error_mm"])
            steps_process = suite.read_steps(process_out, cell.key)
            steps_ray = suite.read_steps(ray_out, cell.key)
            assert sorted(steps_ray) == sorted(steps_process)
            for name, array in steps_process.items():
                np.testing.assert_array_equal(steps_ray[name], array, err_msg=name)
        else:
            assert by_ray["status"] == "n/a" and "does not fit the env" in by_ray["reason"]
    assert (ray_out / "leaderboard.md").is_file()


@pytest.mark.slow
def test_the_ray_backend_is_registered_and_yields_as_tasks_complete(local_ray):
    assert suite.BACKENDS["ray"] is ray_backend.ray_map
    results = list(ray_backend.ray_map(math.sqrt, [1.0, 4.0, 9.0, 16.0], workers=2))
    assert sorted(results) == [1.0, 2.0, 3.0, 4.0]
    assert list(ray_backend.ray_map(math.sqrt, [], workers=2)) == []
    assert local_ray.is_initialized()


# ------------------------------------------------------- starting and stopping (no Ray)
class FakeRay:
    """A stand-in for the ``ray`` module: runs tasks at once and records the calls."""

    def __init__(self, initialized: bool = False) -> None:
        self.initialized = initialized
        self.calls: list[tuple] = []

    def is_initialized(self) -> bool:
        return self.initialized

    def init(self, **options) -> None:
        self.calls.append(("init", options))
        self.initialized = True

    def shutdown(self) -> None:
        self.calls.append(("shutdown",))
        self.initialized = False

    def remote(self, **options):
        self.calls.append(("remote", options))

        def decorate(function):
            class Task:
                @staticmethod
                def remote(*args):
                    return ("ref", function(*args))
            return Task
        return decorate

    def wait(self, refs, num_returns=1):
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref):
        return ref[1]

    def cancel(self, ref) -> None:
        self.calls.append(("cancel",))


def test_a_local_ray_gets_the_workers_cpus_and_is_shut_down(monkeypatch):
    fake = FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    assert list(ray_backend.ray_map(math.sqrt, [1.0, 4.0], workers=3)) == [1.0, 2.0]
    assert fake.calls[0] == ("init", {"num_cpus": 3, "include_dashboard": False})
    assert ("remote", {"num_cpus": 1}) in fake.calls
    assert fake.calls[-1] == ("shutdown",) and not fake.initialized


def test_an_address_connects_to_that_cluster_and_disconnects(monkeypatch):
    fake = FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    runtime_env = {"working_dir": "."}
    map_function = ray_backend.make_ray_map("ray://head:10001", runtime_env=runtime_env)
    assert list(map_function(math.sqrt, [9.0], 2)) == [3.0]
    assert fake.calls[0] == ("init", {"address": "ray://head:10001", "include_dashboard": False,
                                      "runtime_env": runtime_env})
    assert fake.calls[-1] == ("shutdown",)


def test_a_ray_initialised_before_is_used_and_left_running(monkeypatch):
    fake = FakeRay(initialized=True)
    monkeypatch.setitem(sys.modules, "ray", fake)
    assert list(ray_backend.make_ray_map("auto")(math.sqrt, [4.0], 2)) == [2.0]
    assert not [call for call in fake.calls if call[0] in ("init", "shutdown")]
    assert fake.initialized


def test_stopping_early_cancels_the_unfinished_tasks(monkeypatch):
    fake = FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    results = ray_backend.ray_map(math.sqrt, [1.0, 4.0, 9.0], workers=2)
    assert next(results) == 1.0
    results.close()
    assert fake.calls.count(("cancel",)) == 2 and fake.calls[-1] == ("shutdown",)


@pytest.mark.parametrize("call, name", [
    (lambda: ray_backend.ray_map(math.sqrt, [1.0], workers=0), "workers"),
    (lambda: ray_backend.ray_map(math.sqrt, [1.0], workers=True), "workers"),
    (lambda: ray_backend.ray_map(math.sqrt, [1.0], address=" "), "address"),
    (lambda: ray_backend.make_ray_map(""), "address"),
])
def test_bad_arguments_are_refused_before_any_work(call, name, monkeypatch):
    fake = FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    with pytest.raises(ValueError, match=name):
        call()
    assert fake.calls == []


def test_without_ray_the_map_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    with pytest.raises(ImportError, match=r'pip install "soft-arm-gym\[ray\]"'):
        ray_backend.ray_map(math.sqrt, [1.0], workers=1)


# ----------------------------------------------------------------------- command line
@pytest.mark.parametrize("argv, option", [
    (["--address", "auto"], "--address"),
    (["--backend", "serial", "--address", "auto"], "--address"),
    (["--backend", "ray", "--address", ""], "--address"),
    (["--backend", "dask"], "--backend"),
])
def test_cli_bad_backend_options_exit_2_with_one_line(argv, option, tmp_path, capsys):
    assert_suite_cli_error(argv, option, tmp_path, capsys)


def test_cli_backend_ray_without_ray_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", "small", "--out", str(tmp_path / "o"), "--backend", "ray"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m eval suite: error: --backend ray:")
    assert 'pip install "soft-arm-gym[ray]"' in error
    assert not (tmp_path / "o").exists()
