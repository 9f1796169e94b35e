"""The claims ledger's Ray backend (eval/claims/ray_backend.py, ``python -m eval claims --backend
ray``): on a local Ray of two CPUs each job is a task that writes the records the local run
writes (the same summaries and ledger), a resume runs only the records missing, a task lost with
its worker is run again, and a failed job is raised, a resume after it running only what is
missing; the map hands the suite's Ray map (tested in tests/eval/suite/test_suite_ray.py) the
jobs with their ``out`` absolute and the workers count; bad backend options fail in one line
before any work. The fake experiments are module-level functions, pickled by value for the Ray
workers (which cannot import this test module)."""

from __future__ import annotations

import functools
import json
import os
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from eval.__main__ import main
from eval.claims import CLAIMS, EXPERIMENTS, ClaimExperiment, graded
from eval.claims import ray_backend
from eval.claims.ledger import Claim
from eval.claims.run import read_record, record_file, run_ledger
from eval.suite import ray_backend as suite_ray
from eval.suite.store import RecordError

PAPERS = ["wang2023", "ho2018"]


def _logged_error(log: str, name: str, seed, quick, workers, progress):
    """A fake experiment: an error that depends on the experiment and the seed only; each run
    leaves a file in ``log`` (the Ray workers are other processes)."""
    Path(log, f"{name}_seed{seed}_{uuid.uuid4().hex}").touch()
    rng = np.random.default_rng([seed, len(name)])
    return {"error_mm": float(rng.normal(1.0, 0.5)), "seed": seed}


def _dies_once(log: str, name: str, seed, quick, workers, progress):
    """A fake experiment whose first run kills its worker process (a lost worker)."""
    marker = Path(log, f"died_{name}_seed{seed}")
    if not marker.exists():
        marker.touch()
        os._exit(1)
    return _logged_error(log, name, seed, quick, workers, progress)


def _raises_once(log: str, name: str, seed, quick, workers, progress):
    """A fake experiment whose first run, of any seed, raises (after a second, so that the sound
    jobs beside it most likely end first); then as :func:`_logged_error`."""
    marker = Path(log, f"raised_{name}")
    if not marker.exists():
        marker.touch()
        time.sleep(1.0)
        raise ValueError(f"the fake arm broke on seed {seed}")
    return _logged_error(log, name, seed, quick, workers, progress)


@pytest.fixture
def ray_claims(tmp_path):
    """Register fake experiments and a claim on each; yields ``make(kind)`` -> ``(keys, log)``:
    ``"shared"`` two wang2023 experiments sharing a build (one job per seed) and a ho2018 one,
    ``"dies"`` one whose first run kills its worker, ``"raises"`` one whose first run raises
    beside a sound one. Pickles this module by value for the Ray workers."""
    cloudpickle = pytest.importorskip("ray.cloudpickle")
    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)
    log = tmp_path / "log"
    log.mkdir()
    made: list[tuple[ClaimExperiment, Claim]] = []

    def experiment(name, paper, run, shares=""):
        built = ClaimExperiment(name, paper, "a fake run", "shorter",
                                functools.partial(run, str(log), name), shares=shares)
        claim = Claim(f"{name}_small", paper, "Fig. 99", "The error is small.", "1 mm",
                      "reproduced: under 1.5 mm", name,
                      lambda s: graded(s["error_mm"] < 1.5, False, f"{s['error_mm']:.3f} mm"))
        EXPERIMENTS.register(built.name, built)
        CLAIMS.register(claim.key, claim)
        made.append((built, claim))
        return claim.key

    def make(kind):
        if kind == "shared":
            keys = [experiment("wang2023.ray_a", "wang2023", _logged_error, "ray_build"),
                    experiment("wang2023.ray_b", "wang2023", _logged_error, "ray_build"),
                    experiment("ho2018.ray_c", "ho2018", _logged_error)]
        elif kind == "dies":
            keys = [experiment("wang2023.ray_dies", "wang2023", _dies_once)]
        else:
            keys = [experiment("wang2023.ray_raises", "wang2023", _raises_once),
                    experiment("ho2018.ray_sound", "ho2018", _logged_error)]
        return keys, log

    yield make
    for built, claim in made:
        EXPERIMENTS.unregister(built.name)
        CLAIMS.unregister(claim.key)
    cloudpickle.unregister_pickle_by_value(module)


def _runs(log: Path) -> list[str]:
    """The experiment runs logged, as ``name_seedN`` (sorted)."""
    return sorted(path.name.rsplit("_", 1)[0] for path in log.iterdir()
                  if not path.name.startswith(("died_", "raised_")))


def _record(out: Path, name: str, seed: int) -> dict:
    return read_record(record_file(out, name, seed, False), name, seed, False)


def _same_part(record: dict) -> dict:
    """A record less what differs between two runs of it: its times and digest, and the
    revision (a commit by someone else between the runs would change it)."""
    assert record["seconds"] >= 0.0 and record["cpu_seconds"] >= 0.0
    return {key: value for key, value in record.items()
            if key not in ("seconds", "cpu_seconds", "sha256", "git_revision")}


NAMES = ("wang2023.ray_a", "wang2023.ray_b", "ho2018.ray_c")


# ----------------------------------------------------------------------- on a local Ray
def test_ray_jobs_write_the_local_records_and_ledger(ray_claims, local_ray, tmp_path):
    keys, log = ray_claims("shared")
    local = run_ledger(PAPERS, seeds=[0, 1], out=tmp_path / "local", claims=keys,
                       progress=False)
    by_ray = run_ledger(PAPERS, seeds=[0, 1], out=tmp_path / "ray", claims=keys,
                        progress=False, workers=2, backend="ray")
    assert local_ray.is_initialized()  # a Ray the backend did not start is left running
    assert by_ray["claims"] == local["claims"]
    assert [e["verdict"] for e in by_ray["claims"]] == [e["verdict"] for e in local["claims"]]
    for name in NAMES:
        for seed in (0, 1):
            on_ray, here = _record(tmp_path / "ray", name, seed), _record(tmp_path / "local",
                                                                         name, seed)
            assert on_ray["summary"] == here["summary"] == {"error_mm": on_ray["summary"]
                                                            ["error_mm"], "seed": seed}
            assert _same_part(on_ray) == _same_part(here)
        assert len(by_ray["experiments"][name]["seconds"]) == 2
    assert _runs(log) == sorted([f"{name}_seed{seed}" for name in NAMES for seed in (0, 1)] * 2)


def test_a_ray_resume_runs_only_the_missing_records(ray_claims, local_ray, tmp_path, capsys):
    keys, log = ray_claims("shared")
    out = tmp_path / "out"
    run_ledger(PAPERS, seeds=[0, 1], out=out, claims=keys, progress=False)
    kept = {name: record_file(out, name, 0, False).read_bytes() for name in NAMES}
    for name in ("wang2023.ray_b", "ho2018.ray_c"):  # as if stopped mid-job on seed 1
        record_file(out, name, 1, False).unlink()
    for path in log.iterdir():
        path.unlink()

    main(["claims", "--papers", *PAPERS, "--claims", *keys, "--seeds", "0", "1", "--out",
          str(out), "--resume", "--backend", "ray", "--workers", "2"])
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"output directory: {out}"
    assert _runs(log) == ["ho2018.ray_c_seed1", "wang2023.ray_b_seed1"]
    for name in NAMES:
        assert record_file(out, name, 0, False).read_bytes() == kept[name]
        assert _record(out, name, 1)["summary"]["seed"] == 1
    ledger = json.loads((out / "claims.json").read_text())
    assert [seed["seed"] for seed in ledger["claims"][0]["seeds"]] == [0, 1]


def test_a_task_lost_with_its_worker_is_run_again(ray_claims, local_ray, tmp_path):
    keys, log = ray_claims("dies")
    ledger = run_ledger(["wang2023"], seeds=[3], out=tmp_path / "out", claims=keys,
                        progress=False, backend="ray")
    assert (log / "died_wang2023.ray_dies_seed3").exists()  # the first try killed its worker
    assert _runs(log) == ["wang2023.ray_dies_seed3"]
    assert ledger["claims"][0]["seeds"][0]["seed"] == 3
    assert _record(tmp_path / "out", "wang2023.ray_dies", 3)["summary"]["seed"] == 3


def _missing(out: Path, names, seeds) -> list[str]:
    """The records not under ``out`` (or not whole), as ``name_seedN`` (sorted)."""
    missing = []
    for name in names:
        for seed in seeds:
            try:
                whole = _record(out, name, seed) is not None
            except RecordError:
                whole = False
            if not whole:
                missing.append(f"{name}_seed{seed}")
    return sorted(missing)


def _wait_until_quiet(folder: Path, quiet_s: float = 1.5, limit_s: float = 15.0) -> None:
    """Wait until no file appears in ``folder`` for ``quiet_s`` (at most ``limit_s``)."""
    start = last_change = time.monotonic()
    seen = set(folder.rglob("*.json"))
    while time.monotonic() - last_change < quiet_s and time.monotonic() - start < limit_s:
        time.sleep(0.25)
        now = set(folder.rglob("*.json"))
        if now != seen:
            seen, last_change = now, time.monotonic()


def test_a_failed_job_is_raised_and_a_resume_after_it_runs_only_what_is_missing(
        ray_claims, local_ray, tmp_path, capsys):
    keys, log = ray_claims("raises")
    out, names = tmp_path / "out", ("wang2023.ray_raises", "ho2018.ray_sound")
    with pytest.raises(ValueError, match="the fake arm broke on seed [01]"):
        run_ledger(PAPERS, seeds=[0, 1], out=out, claims=keys, progress=False, backend="ray")
    assert local_ray.is_initialized()
    _wait_until_quiet(out / "records")  # a job being cancelled may still be ending
    missing = _missing(out, names, (0, 1))  # the jobs not finished were cancelled
    assert [run for run in missing if run.startswith("wang2023.ray_raises_seed")]
    kept = {path.name: path.read_bytes() for path in (out / "records").rglob("*.json")}
    for path in log.iterdir():
        if not path.name.startswith("raised_"):
            path.unlink()

    main(["claims", "--papers", *PAPERS, "--claims", *keys, "--seeds", "0", "1", "--out",
          str(out), "--resume", "--backend", "ray", "--workers", "2"])
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"output directory: {out}"
    assert _runs(log) == missing
    assert _missing(out, names, (0, 1)) == []
    for path in (out / "records").rglob("*.json"):
        if path.name in kept:
            assert path.read_bytes() == kept[path.name], path.name


# ------------------------------------------------------------ delegation (no Ray needed)
def test_the_map_hands_the_suites_map_absolute_outs_and_the_workers(monkeypatch):
    calls = []

    def suite_map(fn, items, workers=1, *, address=None, runtime_env=None):
        calls.append((fn, items, workers, address, runtime_env))
        return iter([fn(item) for item in items])

    def job(task):
        experiments, seed, quick, out, progress = task
        return {(name, seed): {"out": out} for name in experiments}

    monkeypatch.setattr(suite_ray, "ray_map", suite_map)
    tasks = [(["a"], 0, False, "rel/out", False), (["b", "c"], 1, True, "rel/out", True)]
    absolute = str(Path("rel/out").resolve())  # the tasks write where this process would
    assert list(ray_backend.ray_map(job, tasks, workers=3)) == [
        {("a", 0): {"out": absolute}}, {("b", 1): {"out": absolute}, ("c", 1): {"out": absolute}}]
    assert calls == [(job, [(["a"], 0, False, absolute, False),
                            (["b", "c"], 1, True, absolute, True)], 3, None, None)]
    runtime_env = {"working_dir": "."}
    map_function = ray_backend.make_ray_map("ray://head:10001", runtime_env=runtime_env)
    assert len(list(map_function(job, tasks[:1], 2))) == 1
    assert calls[-1][2:] == (2, "ray://head:10001", runtime_env)
    with pytest.raises(ValueError, match="address"):
        ray_backend.make_ray_map(" ")


def test_run_ledger_refuses_a_bad_backend_before_any_run(monkeypatch, tmp_path):
    ran = []
    experiment = ClaimExperiment("wang2023.ray_never", "wang2023", "a fake run", "shorter",
                                 lambda *args: ran.append(args) or {"error_mm": 1.0})
    claim = Claim("wang2023.ray_never_small", "wang2023", "Fig. 99", "Small.", "1 mm",
                  "reproduced: under 1.5 mm", experiment.name,
                  lambda s: graded(s["error_mm"] < 1.5, False, "1 mm"))
    EXPERIMENTS.register(experiment.name, experiment)
    CLAIMS.register(claim.key, claim)
    try:
        with pytest.raises(ValueError, match="backend must be 'local', 'ray' or a map"):
            run_ledger(["wang2023"], seeds=[0], out=tmp_path, claims=[claim.key],
                       progress=False, backend="dask")
        monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
        with pytest.raises(ImportError, match=r'pip install "soft-arm-gym\[ray\]"'):
            run_ledger(["wang2023"], seeds=[0], out=tmp_path, claims=[claim.key],
                       progress=False, backend="ray")
    finally:
        EXPERIMENTS.unregister(experiment.name)
        CLAIMS.unregister(claim.key)
    assert ran == [] and not (tmp_path / "records").exists()


# ----------------------------------------------------------------------- command line
@pytest.mark.parametrize("argv, option", [
    (["--backend", "dask"], "--backend"),
    (["--address", "auto"], "--address"),
    (["--backend", "local", "--address", "auto"], "--address"),
    (["--backend", "ray", "--address", " "], "--address"),
])
def test_cli_bad_backend_options_exit_2_with_one_line(argv, option, capsys, tmp_path):
    with pytest.raises(SystemExit) as error:
        main(["claims", "--papers", "ho2018", "--out", str(tmp_path / "out")] + argv)
    assert error.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("python -m eval claims: error:") and option in err[-1], err
    assert not (tmp_path / "out").exists()


def test_cli_backend_ray_without_ray_names_the_option_and_the_extra(capsys, tmp_path,
                                                                    monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(SystemExit) as error:
        main(["claims", "--papers", "ho2018", "--out", str(tmp_path / "out"), "--backend",
              "ray"])
    assert error.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("python -m eval claims: error: --backend ray:")
    assert 'pip install "soft-arm-gym[ray]"' in err
    assert not (tmp_path / "out").exists()
