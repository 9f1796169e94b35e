"""The four-arm benchmark suite: a declarative grid of arms, paths, conditions, policies and seeds.

A suite is a YAML file (the bundled ones are ``eval/suites/<name>.yaml``: ``default``, ``small``).
It is loaded and checked (:func:`load_suite`, :func:`check_suite`), expanded into cells, one run
each (:func:`expand`), and run (:func:`run_suite`), every finished run written at once as one
record; :mod:`eval.suite.report` turns the records into the leaderboard, aggregate scores and plots.

The file's schema (top level, arm blocks, policy entries), how the grid expands into cells and
their keys, and what :func:`check_suite` refuses before any run are in ``docs/suite.md``.

Running
-------
:func:`run_suite` runs every cell whose record is not there yet (all of them without
``resume``). A run that finishes writes ``out/records/<key>.json`` at once and, when it ran, the
per-step record ``out/records/<key>.npz`` (the arrays of :func:`agents.rollout.run_episode`: m, s,
Pa), each to a temporary file renamed into place, the JSON last, so a killed suite leaves no
half record and ``resume`` redoes exactly the unfinished cells.

Every record is verified when it is read (:func:`eval.suite.store.read_record`): readable JSON
holding an object, its ``key`` the file's and the hash of its ``config`` (a record copied over
another's is caught), a known ``status``, finite metrics >= 0 (:data:`REQUIRED_METRICS`) when
done, and the per-step arrays matching the digest ``steps_sha256`` written with it. A bad
record (truncated, copied over, null metrics, ...) is never trusted: ``resume`` reports it by
path and runs its cell again; the report leaves it out and lists it (``suite.json``,
``bad_records``), and the command line then exits with status 1. ``out/records`` being a file
is refused before any work.

Before running a cell the process claims it with the lock file ``out/locks/<key>.lock``
(:mod:`eval.suite.locks`: made atomically, holding the owner's pid and host), so two processes
on one output directory never run the same cell: the second leaves the cells the first holds
to it. A claim whose process has died is taken over by the next run; a run that ends
with ``out/locks/`` empty removes it. Pool workers end with the
process that started them (:func:`exit_with_parent`), so a killed suite leaves no process
behind; a dead worker costs only its run, tried once more in a process of its own and failed
with the signal that killed it if that one dies too (:mod:`eval.pool`). The JSON record::

    {"key", "suite", "labels": {"preset", "path", "condition", "policy", "seed"},
     "config": resolved config, "status": "done" | "n/a", "reason": why n/a (else null),
     "metrics": {"last_cycle_error_mm", "mean_error_mm", "max_error_mm", "rmse_error_mm",
                 "final_error_mm", "last_cycle_max_error_mm", "path_deviation_mm",
                 "last_cycle_path_deviation_mm", "feedback_error_mm", "per_cycle_error_mm",
                 "per_cycle_path_deviation_mm", "n_steps", "n_cycles"} (null when n/a),
     "wall_s", "versions": {soft_arm_gym, gymnasium, stable_baselines3, torch, numpy,
     pybullet, python}, "git_revision", "steps_file", "steps_sha256"}

``n/a``: the policy declined the cell's env while it was made and calibrated, with the specific
refusal :class:`agents.policies.PolicyRefusal` (an arm of another layout, e.g. ``lwpr_rwr`` on
an arm without three chambers per segment; an observation without the parts it reads; an
agent on an arm whose observation it cannot read); the reason is the refusal's text. Any other
error, a ``ValueError`` of the env or the policy too (a bad ``sensing`` option, a feedback pose
that does not respond to a calibration's probes), is an error, never ``n/a``: it leaves no
record, the other runs go on, and :class:`SuiteRunError` lists the failed cells at the end
(their tracebacks in ``out/errors/<key>.txt``; the command line exits with status 1);
``resume`` retries them.

Backends. A backend is a function ``map(fn, items, workers)`` that applies ``fn`` to every item
and yields the results as they complete (:data:`MapFunction`). ``"process"`` (default) runs them
in ``workers`` spawned processes (in this process when ``workers == 1``), ``"serial"`` in this
process. Another backend (a cluster) is registered from its own module with
:func:`register_backend` and chosen by name, or passed as the function itself. Cells are
ordered round-robin over (arm, policy, seed) groups, so that the first run of each group, which
builds and caches its calibration or pre-training, starts before its siblings.
"""

from __future__ import annotations

# The package, one module per job:
#   spec.py          the YAML spec: loading, the schema's checks, the file's SHA-256
#   grid.py          spec -> cells (one run each) and their keys (the hash of a resolved config)
#   check.py         the spec checked before any run (envs built, baselines made, agents loaded)
#   engine.py        the suite on another physics engine, less what that engine cannot run
#   run.py           one cell in a worker, the backends (eval.pool: process pool, serial),
#                    run_suite
#   store.py         the records on disk: write, read and verify, finished or not (resume),
#                    provenance
#   locks.py         a cell claimed by one process (lock files), taken over from a dead one
#   report.py        records -> leaderboard, aggregates with bootstrap CIs, plots
#   ray_backend.py   the optional "ray" backend (importing it registers it)
from eval.pool import exit_with_parent, process_map, serial_map
from eval.suite.check import EnvChecker, check_suite
from eval.suite.engine import LeftOut, on_engine
from eval.suite.grid import ENV_ID, KEY_DIGITS, Cell, canonical_json, cell_key, expand
from eval.suite.locks import claim, lock_path, release
from eval.suite.report import (DEFAULT_REPS, PROFILE_REPS, SCORE, aggregate_scores,
                               collect_rows, fraction_within, leaderboard_markdown,
                               leaderboards, performance_profiles, profile_taus,
                               require_rliable, score_matrices, write_report)
from eval.suite.run import (BACKENDS, MapFunction, SuiteRunError, cell_metrics,
                            one_compute_thread, order_cells, register_backend, run_cell,
                            run_suite)
from eval.suite.spec import (ARM_KEYS, DEFAULT_CYCLES, ENV_KEYS, POLICY_ENV_DEFAULTS,
                             POLICY_KEYS, SUITE_ENV_KEYS, SUITES_DIR, TOP_KEYS, ArmEntry,
                             PolicyEntry, SuiteError, SuiteSpec, bundled_suites, load_suite,
                             parse_suite, resolve_suite_path)
from eval.suite.store import (REQUIRED_METRICS, RecordError, check_records_dir, git_revision,
                              is_finished, library_versions, read_record, read_steps,
                              record_path, record_problem, records_dir, steps_digest,
                              steps_path, write_record)

__all__ = ["ARM_KEYS", "BACKENDS", "DEFAULT_CYCLES", "DEFAULT_REPS", "ENV_ID", "ENV_KEYS",
           "KEY_DIGITS", "POLICY_ENV_DEFAULTS", "POLICY_KEYS", "PROFILE_REPS",
           "REQUIRED_METRICS", "SCORE", "SUITES_DIR", "SUITE_ENV_KEYS", "TOP_KEYS", "ArmEntry",
           "Cell", "EnvChecker", "LeftOut", "MapFunction", "PolicyEntry", "RecordError",
           "SuiteError", "SuiteRunError",
           "SuiteSpec", "aggregate_scores", "bundled_suites", "canonical_json", "cell_key",
           "cell_metrics", "check_records_dir", "check_suite", "claim", "collect_rows",
           "exit_with_parent", "expand", "fraction_within", "git_revision", "is_finished",
           "leaderboard_markdown", "leaderboards", "library_versions", "load_suite",
           "lock_path", "on_engine", "one_compute_thread", "order_cells", "parse_suite",
           "performance_profiles", "process_map", "profile_taus", "read_record", "read_steps",
           "record_path", "record_problem", "records_dir", "register_backend", "release",
           "require_rliable", "resolve_suite_path", "run_cell", "run_suite", "score_matrices",
           "serial_map", "steps_digest", "steps_path", "write_record", "write_report"]
