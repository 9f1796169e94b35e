"""Closed-loop tracking on the zou2022 arm with each of its shape sources as feedback, nominal and
with the stereo pair blind (Zou et al. 2022, key ``zou2022``).

What is run. Every baseline of :data:`CONTROL_POLICIES` (``cc_model``, ``hybrid_gpr``,
``lwpr_rwr``) tracks the same path on the ``zou2022`` preset (``SoftArmTrack-v0``) with every
feedback source of :data:`CONTROL_FEEDBACK`:

* ``encoder_cc``: RSES, the constant-curvature shape of the cable encoders' chamber lengths
  (zou2022 Section 3);
* ``stereo``: ASES, the stereo pair's SOM centreline (Section 4); while the pair is lost it holds
  its last good shape;
* ``encoder_dnn``: the DNN on the encoders, trained on ASES labels of a clear-view exploration
  (Section 5); built when its env is made, from ``dnn_options`` (the fields of
  :class:`~soft_gym.papers.zou2022.shape_dnn.ShapeDNNConfig`), and kept in the calibration cache;

under each condition of :data:`CONTROL_CONDITIONS`:

* ``nominal``: no visual fault;
* ``stereo faulted``: complete darkness on the stereo pair (``low_light`` at strength 1,
  :class:`~soft_gym.sensors.faults.LowLight`: "entire black image feedback") from the start of
  the last path cycle to the end of the run (:func:`stereo_fault`); with the default two cycles
  the pair is blind for the second half of the run, and ASES reports lost on every dark frame.
  Only the stereo pair is faulted: the encoders and the ground truth are untouched.

The path is the env's default circle (:data:`CONTROL_PATH`): 71 mm in diameter, in the
horizontal plane at the middle height of the reachable tips, one cycle in 20 s
(:data:`CYCLE_S`, 400 control steps of 0.05 s), :data:`CONTROL_CYCLES` cycles. The first cycle
includes the arm's extension from rest (77 mm long) to the circle ~187 mm below its base, and,
for ``lwpr_rwr``, the online learning's settling; the last cycle is the settled (or, under the
fault, the blind) tracking that the table reports.

Set-up in good conditions. A baseline is set up once per feedback source on the nominal env
(``cc_model`` and ``hybrid_gpr`` probe their actuation gains, ``lwpr_rwr`` pre-trains, both with
the seed) and every run starts from that set-up, so the two conditions differ only in what the
pair sees during the run (``lwpr_rwr``'s own pre-training also drops the env's loads and faults:
it is the lab's calibration).

The encoder sources under the fault. An env refuses visual faults unless it simulates a camera,
so an encoder-fed run under ``stereo faulted`` simulates the stereo pair beside its encoders
(``sensors=("stereo",)``), faulted and never read. Its record is then identical to the nominal
run's up to the fault's start (simulating the pair alone changes nothing), and after it differs
only because the dark frames' noise is drawn from the env's one noise generator, which shifts the
encoders' noise samples: measured with seed 0, 0.2-0.4 mm mean tip difference over the last cycle
for ``cc_model`` and ``lwpr_rwr`` (a loop that did not settle, as ``hybrid_gpr`` on this arm
before its modal length map, amplified that into a different trajectory, 13-24 mm), so compare
the encoder rows of the two conditions with that in mind. A difference before the fault's start
would mean the fault leaks into an encoder source.

Run time. The 18 runs take about 4 minutes on two busy cores once the DNN and ``lwpr_rwr``'s
pre-training are in the calibration cache (a run: 1.5-4 s for ``cc_model`` / ``hybrid_gpr`` on an
encoder source, 7-12 s with the dark pair rendered beside it, 8-21 s on ``stereo``, 8-25 s for
``lwpr_rwr``); cold, about 10.5 minutes, of which the 3000-sample DNN takes ~5 and
``lwpr_rwr``'s pre-training ~2 (``stereo``: 74 s). The modal probes of ``cc_model`` and
``hybrid_gpr`` (480 control steps per feedback source) add a set-up of 10-22 s on an encoder
source and ~72 s on ``stereo`` (measured on two cores shared with a benchmark suite).

Units. Records are SI (m, s, Pa); the table's errors are millimetres: the tracking error is the
distance from the target presented at each step to the ground-truth tip after it (never the
feedback), the path deviation the distance from the ground-truth tip to the path; both are the
mean over the last cycle, with the largest tracking error of that cycle; the feedback error is
the mean distance from the source's tip to the true tip over the last cycle. ``stereo lost`` is
the fraction of steps (%) on which ASES reported lost, over the run and over its last cycle
(``stereo`` only: the encoder sources never run ASES).

What is not in the paper. Zou et al. 2022 compare the three shape estimates open loop: the DNN
against ASES on its test set and along a continuous bend, with RSES beside it (Section 5,
Tables 3-4), after showing what defeats ASES (poor light, self-occlusion; Section 4.4, Fig. 13),
which is why the DNN reads the encoders. They run no closed-loop control with any of them. This
closed-loop comparison, its path, its baselines (wang2023's ``cc_model`` and ``hybrid_gpr``,
ho2018's ``lwpr_rwr``) and its fault are the project's own.

A baseline that cannot drive the arm with a source (its constructor or set-up raises
``ValueError``) gets a row saying ``refused`` with the reason, never a silent gap.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import soft_gym  # noqa: F401  (registers the env ids)
from agents.policies import BASELINES, BaselinePolicy, make_policy
from agents.rollout import run_episode
from eval.metrics import path_deviation_mm, tracking_error_mm
from eval.report import markdown_table, save_figure
from soft_gym.robots.presets import get_preset
from soft_gym.procedures.workspace import reachable_tips
from soft_gym.tasks import TrackTask

PRESET = "zou2022"
ENV_ID = "SoftArmTrack-v0"
CONTROL_POLICIES = ("cc_model", "hybrid_gpr", "lwpr_rwr")
"""The baselines compared (any name of :data:`agents.policies.BASELINES` may be run)."""
CONTROL_FEEDBACK = ("encoder_cc", "stereo", "encoder_dnn")
"""zou2022's three shape sources, as feedback of the ``pose`` part."""
CONTROL_CONDITIONS = ("nominal", "stereo faulted")
CONTROL_PATH = "circle"
CONTROL_CYCLES = 2
"""Path cycles per run: one to extend and settle, one reported (blind under the fault)."""
CYCLE_S = 20.0
"""Duration of one circle cycle at the env's default target speed (s)."""
DEFAULT_DNN_OPTIONS: dict[str, Any] = {"n_samples": 3000}
"""A moderate DNN (the paper's 29791 samples take ~25 min to explore on one core)."""


def cycle_duration_s(speed_m_s: float | None = None) -> float:
    """Duration of one cycle of :data:`CONTROL_PATH` on the zou2022 arm at ``speed_m_s`` (m/s;
    ``None``: the env's default speed, :data:`CYCLE_S`), in s."""
    spec = get_preset(PRESET)
    task = TrackTask(spec, reachable_tips(spec), path=CONTROL_PATH, cycles=1,
                     speed_m_s=speed_m_s)
    return task.episode_steps * spec.control_period_s


def stereo_fault(cycles: int = CONTROL_CYCLES, cycle_s: float = CYCLE_S) -> dict[str, Any]:
    """The ``stereo faulted`` condition's fault: darkness on the pair (strength 1) from the start
    of the last of ``cycles`` path cycles of ``cycle_s`` seconds each to the end of the run; with
    one cycle, from its middle (times in s on the simulator's clock)."""
    cycles = _check_int("cycles", cycles, 1)
    if not isinstance(cycle_s, (int, float, np.integer, np.floating)) \
            or not np.isfinite(cycle_s) or cycle_s <= 0:
        raise ValueError(f"cycle_s must be a positive number of seconds, got {cycle_s!r}")
    start_s = (cycles - 1) * float(cycle_s) if cycles > 1 else 0.5 * float(cycle_s)
    return {"name": "low_light", "strength": 1.0, "start_s": start_s}


def env_kwargs(feedback: str, condition: str, cycles: int = CONTROL_CYCLES,
               dnn_options: Mapping[str, Any] | None = None,
               speed_m_s: float | None = None) -> dict[str, Any]:
    """``gymnasium.make`` keyword arguments of one run (see the module docstring; ``speed_m_s``:
    the target speed in m/s, ``None`` for the env's default)."""
    if feedback not in CONTROL_FEEDBACK:
        raise ValueError(f"feedback must be among {list(CONTROL_FEEDBACK)}, got {feedback!r}")
    if condition not in CONTROL_CONDITIONS:
        raise ValueError(f"condition must be among {list(CONTROL_CONDITIONS)}, got "
                         f"{condition!r}")
    kwargs: dict[str, Any] = {"preset": PRESET, "path": CONTROL_PATH, "cycles": cycles,
                              "feedback": feedback}
    if speed_m_s is not None:
        kwargs["speed_m_s"] = speed_m_s
    if feedback == "encoder_dnn":
        kwargs["sensing"] = dict(dnn_options or {})
    if condition == "stereo faulted":
        kwargs["faults"] = {"stereo": stereo_fault(cycles, cycle_duration_s(speed_m_s))}
        if feedback != "stereo":
            kwargs["sensors"] = ("stereo",)  # the pair is there, faulted, and not read
    return kwargs


def run_control(seed: int, dnn_options: Mapping[str, Any] | None = None,
                cycles: int = CONTROL_CYCLES, policies: Sequence[str] = CONTROL_POLICIES,
                feedback: Sequence[str] = CONTROL_FEEDBACK,
                conditions: Sequence[str] = CONTROL_CONDITIONS,
                speed_m_s: float | None = None, progress: bool = True) -> list[dict[str, Any]]:
    """Run every (policy, feedback, condition) and return one row per run.

    Args:
        seed: episode seed, and the seed of the baselines' set-up (probes, pre-training).
        dnn_options: the ``encoder_dnn`` source's options (fields of
            :class:`~soft_gym.papers.zou2022.shape_dnn.ShapeDNNConfig`, e.g. ``{"n_samples": 3000}``);
            ``None``: :data:`DEFAULT_DNN_OPTIONS`.
        cycles: path cycles per run (>= 1); the table reports the last.
        policies: baseline names (default :data:`CONTROL_POLICIES`).
        feedback: feedback sources among :data:`CONTROL_FEEDBACK`.
        conditions: among :data:`CONTROL_CONDITIONS`.
        speed_m_s: target speed (m/s); ``None``: the env's default, one cycle in
            :data:`CYCLE_S` (a faster path makes shorter runs, e.g. for tests).
        progress: print one line per run and show the episode bars.

    Returns:
        Rows in (policy, feedback, condition) order, each with the labels ``policy``,
        ``feedback``, ``condition``, ``seed``, ``cycles``; ``refused`` (``None``, or the reason
        the baseline gave); the metrics of the last cycle, ground-truth tip against target (mm):
        ``track_last_cycle_mm``, ``dev_last_cycle_mm``, ``max_last_cycle_mm``,
        ``feedback_error_last_cycle_mm``; ``track_mean_mm`` over the whole run; the stereo
        source's lost fractions ``stereo_lost_fraction`` and ``stereo_lost_last_cycle``
        (0-1; ``None`` for the encoder sources, which never run ASES); ``fault_start_s`` (s,
        ``None`` when nominal); timings (s, wall clock) ``setup_s`` (the baseline's set-up on
        the source's nominal env, shared by its conditions, with the env's making, a DNN's
        building included, plus this run's own) and ``run_s`` (the episode); and
        ``record``, the episode record (:mod:`eval.runner`; ``None`` when refused) for
        :func:`plot_control` (:func:`strip_records` drops it for JSON). A refused row has NaN
        metrics.

    Raises:
        ValueError: naming the parameter, for a bad ``seed``, ``cycles``, ``dnn_options``,
            ``speed_m_s`` or a name in ``policies``, ``feedback`` or ``conditions``.
    """
    seed = _check_int("seed", seed, 0)
    cycles = _check_int("cycles", cycles, 1)
    if dnn_options is None:
        dnn_options = DEFAULT_DNN_OPTIONS
    if not isinstance(dnn_options, Mapping):
        raise ValueError(f"dnn_options must be a dict of ShapeDNNConfig fields, got "
                         f"{dnn_options!r}")
    if speed_m_s is not None and (
            isinstance(speed_m_s, (bool, np.bool_))
            or not isinstance(speed_m_s, (int, float, np.integer, np.floating))
            or not np.isfinite(speed_m_s) or speed_m_s <= 0):
        raise ValueError(f"speed_m_s must be None or a positive speed in m/s, got "
                         f"{speed_m_s!r}")
    policies = _check_names("policies", policies, tuple(BASELINES))
    feedback = _check_names("feedback", feedback, CONTROL_FEEDBACK)
    conditions = _check_names("conditions", conditions, CONTROL_CONDITIONS)
    rows = []
    with tempfile.TemporaryDirectory(prefix="zou2022_control_") as scratch:
        for policy in policies:
            for source in feedback:
                setup = _PolicySetup(policy, source, cycles, dnn_options, speed_m_s, seed,
                                     Path(scratch))
                try:
                    for condition in conditions:
                        row = setup.run(condition, progress)
                        rows.append(row)
                        if progress:
                            print(_progress_line(row), flush=True)
                finally:
                    setup.close()
    return rows


class _PolicySetup:
    """One baseline set up on the nominal env of one feedback source (see "Set-up in good
    conditions"); :meth:`run` drives a fresh copy of it through one condition."""

    def __init__(self, policy: str, feedback: str, cycles: int,
                 dnn_options: Mapping[str, Any], speed_m_s: float | None, seed: int,
                 scratch: Path) -> None:
        self.policy, self.feedback, self.cycles, self.seed = policy, feedback, cycles, seed
        self.speed_m_s = speed_m_s
        self.dnn_options = dict(dnn_options)
        self.refused: str | None = None
        self.saved: Path | None = None
        self.setup_s = 0.0
        self.params = {"seed": seed} if policy == "lwpr_rwr" else {}
        self.nominal_kwargs = env_kwargs(feedback, "nominal", cycles, self.dnn_options,
                                         speed_m_s)
        start = time.perf_counter()
        self.setup_env = gym.make(ENV_ID, **self.nominal_kwargs)  # builds the DNN if needed
        try:
            if policy == "lwpr_rwr":
                self._pretrain(scratch)
        except BaseException:
            self.close()
            raise
        self.setup_s = time.perf_counter() - start

    def _pretrain(self, scratch: Path) -> None:
        """Pre-train ``lwpr_rwr`` on the nominal env and keep it on disk for every condition."""
        try:
            twin = make_policy(self.policy, env=self.setup_env, **self.params)
            twin.pretrain()
        except ValueError as error:
            self.refused = str(error)
            return
        self.saved = scratch / f"{self.policy}_{self.feedback}.npz"
        twin.save(self.saved)

    def _policy_for(self, env: gym.Env) -> BaselinePolicy:
        """A freshly set-up baseline controlling ``env`` (``ValueError``: refused)."""
        policy = make_policy(self.policy, env=env, **self.params)
        if self.saved is not None:
            return type(policy).load(self.saved, env=env)
        if hasattr(policy, "calibrate"):
            # probes on the nominal env, seeded: the same gains for every condition
            policy.calibrate(seed=self.seed, env=self.setup_env)
        return policy

    def run(self, condition: str, progress: bool) -> dict[str, Any]:
        labels = {"policy": self.policy, "feedback": self.feedback, "condition": condition,
                  "seed": self.seed, "cycles": self.cycles}
        kwargs = env_kwargs(self.feedback, condition, self.cycles, self.dnn_options,
                            self.speed_m_s)
        fault_start = kwargs["faults"]["stereo"]["start_s"] if "faults" in kwargs else None
        if self.refused is not None:
            return _refused_row(labels, self.refused, fault_start)
        start = time.perf_counter()
        env = gym.make(ENV_ID, **kwargs)
        try:
            try:
                policy = self._policy_for(env)
            except ValueError as error:
                self.refused = str(error)
                return _refused_row(labels, self.refused, fault_start)
            setup_s = self.setup_s + time.perf_counter() - start
            start = time.perf_counter()
            record = run_episode(env, policy, seed=self.seed, progress=progress,
                                 description=f"{self.policy} {self.feedback} {condition}")
            run_s = time.perf_counter() - start
        finally:
            env.close()
        return {**labels, "refused": None, **summarize_control(record),
                "fault_start_s": fault_start, "setup_s": setup_s, "run_s": run_s,
                "record": record}

    def close(self) -> None:
        """Close the nominal env of the set-up."""
        self.setup_env.close()


_METRICS = ("track_last_cycle_mm", "dev_last_cycle_mm", "max_last_cycle_mm",
            "feedback_error_last_cycle_mm", "track_mean_mm")


def summarize_control(record: Mapping[str, Any]) -> dict[str, Any]:
    """The row metrics of one episode record (see :func:`run_control`; mm and fractions)."""
    track = tracking_error_mm(record)
    cycle = np.asarray(record.get("cycle", np.zeros(len(track), dtype=int)))
    last = cycle == cycle.max()
    deviation = path_deviation_mm(record)
    feedback = np.linalg.norm(np.asarray(record["feedback_m"]) - np.asarray(record["tip_m"]),
                              axis=1) * 1000.0
    lost = record.get("lost")
    return {
        "track_last_cycle_mm": _mean(track[last]),
        "dev_last_cycle_mm": _mean(deviation[last]),
        "max_last_cycle_mm": float(np.nanmax(track[last])) if np.isfinite(track[last]).any()
        else float("nan"),
        "feedback_error_last_cycle_mm": _mean(feedback[last]),
        "track_mean_mm": _mean(track),
        "stereo_lost_fraction": None if lost is None else float(np.mean(lost)),
        "stereo_lost_last_cycle": None if lost is None else float(np.mean(np.asarray(lost)[last])),
    }


def _mean(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if finite.size else float("nan")


def _refused_row(labels: dict[str, Any], reason: str, fault_start: float | None) -> dict:
    return {**labels, "refused": reason, **{key: float("nan") for key in _METRICS},
            "stereo_lost_fraction": None, "stereo_lost_last_cycle": None,
            "fault_start_s": fault_start, "setup_s": float("nan"), "run_s": float("nan"),
            "record": None}


def strip_records(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The rows without their episode records (JSON-ready apart from NaN)."""
    return [{key: value for key, value in row.items() if key != "record"} for row in rows]


# ---------------------------------------------------------------------------- table and plot
def control_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of :func:`run_control`'s rows: the last cycle's errors (mm), the stereo
    source's lost steps (% of the run / of its last cycle) and the run time (s)."""
    shown = []
    for row in rows:
        line = {"policy": row["policy"], "feedback": row["feedback"],
                "condition": row["condition"]}
        if row.get("refused"):
            line["track"] = f"refused: {_first_clause(row['refused'])}"
            shown.append(line)
            continue
        lost = row.get("stereo_lost_fraction")
        line.update({
            "track": row["track_last_cycle_mm"], "dev": row["dev_last_cycle_mm"],
            "max": row["max_last_cycle_mm"], "feedback error": row["feedback_error_last_cycle_mm"],
            "lost": "n/a (not read)" if lost is None
            else f"{100 * lost:.0f} / {100 * row['stereo_lost_last_cycle']:.0f}",
            "run": row.get("run_s")})
        shown.append(line)
    columns = {"policy": "policy", "feedback": "feedback", "condition": "condition",
               "track": "tracking, last cycle (mm)", "dev": "path deviation (mm)",
               "max": "max (mm)", "feedback error": "feedback error (mm)",
               "lost": "stereo lost (% run / last cycle)", "run": "run (s)"}
    return markdown_table(shown, columns=columns, float_format="{:.1f}")


def _first_clause(reason: str) -> str:
    return reason.split(":")[0].split(";")[0].strip()


def plot_control(path: str | Path,
                 records: Sequence[Mapping[str, Any]] | Mapping[tuple[str, str, str], Any]
                 ) -> Path:
    """Tracking error (mm, ground truth) against time (s): one panel per policy, one colour per
    feedback source, nominal solid and stereo-faulted dashed, the fault's start dotted.

    Args:
        path: output PNG.
        records: :func:`run_control`'s rows (their ``record``; refused rows are left out), or a
            mapping ``(policy, feedback, condition) -> record`` (then without the fault's
            start, which only the rows hold).

    Returns:
        The path written.
    """
    if isinstance(records, Mapping):
        runs = {tuple(key): record for key, record in records.items() if record is not None}
        fault_starts = []
    else:
        runs = {(row["policy"], row["feedback"], row["condition"]): row["record"]
                for row in records if row.get("record") is not None}
        fault_starts = [row["fault_start_s"] for row in records
                        if row.get("fault_start_s") is not None]
    if not runs:
        raise ValueError("records must hold at least one run that was not refused")
    policies = list(dict.fromkeys(key[0] for key in runs))
    sources = list(dict.fromkeys(key[1] for key in runs))
    fig = Figure(figsize=(5.0 * len(policies), 3.8))
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, len(policies), sharey=True, squeeze=False)[0])
    for ax, policy in zip(axes, policies):
        for (name, source, condition), record in runs.items():
            if name != policy:
                continue
            color = f"C{sources.index(source) % 10}"
            style = "--" if condition != "nominal" else "-"
            ax.plot(np.asarray(record["time_s"]), tracking_error_mm(record), style, color=color,
                    lw=1.0, label=f"{source}, {condition}")
        for start in sorted(set(fault_starts)):
            ax.axvline(start, color="0.3", ls=":", lw=1.0)
        ax.set(title=policy, xlabel="time (s)")
        ax.set_yscale("log")
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("tracking error, ground truth (mm)")
    fig.suptitle(f"{PRESET}: tracking with each feedback source (dotted: the stereo pair "
                 f"goes dark)", fontsize=10)
    return save_figure(fig, path)


# ---------------------------------------------------------------------------- helpers
def _check_int(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _check_names(name: str, values: Sequence[str], allowed: Sequence[str]) -> tuple[str, ...]:
    if isinstance(values, str) or not isinstance(values, Sequence) or not values:
        raise ValueError(f"{name} must be a non-empty sequence of names from {list(allowed)}, "
                         f"got {values!r}")
    unknown = [value for value in values if value not in allowed]
    if unknown:
        raise ValueError(f"{name} must be names from {list(allowed)}, got {unknown}")
    return tuple(values)


def _progress_line(row: Mapping[str, Any]) -> str:
    label = f"{row['policy']} / {row['feedback']} / {row['condition']}"
    if row.get("refused"):
        return f"{label}: refused ({_first_clause(row['refused'])})"
    return (f"{label}: {row['track_last_cycle_mm']:.1f} mm last cycle "
            f"(set-up {row['setup_s']:.1f} s, run {row['run_s']:.1f} s)")


__all__ = ["CONTROL_POLICIES", "CONTROL_FEEDBACK", "CONTROL_CONDITIONS", "CONTROL_PATH",
           "CONTROL_CYCLES", "CYCLE_S", "DEFAULT_DNN_OPTIONS", "cycle_duration_s", "stereo_fault",
           "env_kwargs", "run_control", "summarize_control", "strip_records", "control_table",
           "plot_control"]
