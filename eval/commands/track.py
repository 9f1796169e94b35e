"""``python -m eval track``: baselines (and SB3 agents) tracking a path, several gains and seeds;
every run checked before the first, each run's CSV written as it finishes, then the table, JSON
and plots (:func:`run_tracks`, which ``benchmark`` runs with its fixed settings)."""

from __future__ import annotations

import argparse
import copy
import inspect
import itertools
import sys
from pathlib import Path
from typing import Any

import numpy as np

from agents.policies import BASELINES
from eval import runner  # runner.run_many, looked up at each call (tests stand in for it)
from eval.commands.options import add_video_flag, add_workers
from eval.metrics import add_improvement, improvement, summarize, summary_table
from eval.palette import policy_color, policy_label
from eval.report import (markdown_table, plot_error_time, plot_trajectory, write_records_csv,
                         write_results_json)
from eval.runner import ConfigError, RunConfig, check_configs
from eval.suite.spec import POLICY_ENV_DEFAULTS
from soft_gym._cli import (HelpFormatter, fail, json_or_name, json_value, positive_float,
                           positive_int, seed_int)
from soft_gym._validation import SEED_MAX
from soft_gym.engines import ENGINES, REFERENCE_ENGINE
from soft_gym.envs.observations import OBSERVATION_PARTS
from soft_gym.papers import DEFAULT_PRESET
from soft_gym.sensors.faults import FAULT_PRESETS, FAULTS
from soft_gym.robots.presets import PRESETS
from soft_gym.tasks.paths import PATH_SHAPES


TRACK_OPTIONS = {"env_kwargs.preset": "--preset", "env_kwargs.path": "--path",
                 "env_kwargs.cycles": "--cycles", "env_kwargs.feedback": "--feedback",
                 "env_kwargs.scenario": "--scenario", "env_kwargs.faults": "--faults",
                 "env_kwargs.obs": "--obs", "env_kwargs.engine": "--engine",
                 "policy": "--policies", "policy_params": "--kp", "seed": "--seeds"}
"""The part of a run configuration (:class:`eval.runner.ConfigError`) -> the ``track`` option
that sets it."""


def _check_configs(parser: argparse.ArgumentParser, configs: list,
                   options: dict[str, str]) -> None:
    """Check every run's configuration before the first run (:func:`eval.runner.check_configs`);
    a refusal is one ``parser.error`` line naming the option of the refused part (``options``:
    part -> option) and its value in the refused configuration; an SB3 agent refused for
    another arm than its training's ends with the preset option naming that arm."""
    try:
        check_configs(configs)
    except ConfigError as error:
        option = options.get(error.part) or options.get(error.part.split(".")[0])
        if option is None and error.config.policy.startswith("sb3:") and options:
            option = options.get("policy")  # the agent's own interface refused
        if option is None:
            parser.error(f"{error.part} of run {error.config.identity()}: {error.message}")
        if error.part == "policy":
            shown = error.config.policy
        elif error.part.startswith("env_kwargs."):
            shown = error.config.env_kwargs.get(error.part.split(".", 1)[1])
        else:
            shown = getattr(error.config, error.part, None)
        preset = options.get("env_kwargs.preset")
        hint = (f"; {preset} {error.trained_preset}" if error.trained_preset and preset
                else "")
        fail(parser, option, (f"{shown!r} refused: {error.message}" if shown is not None
                              else error.message) + hint)


def run_tracks(args: argparse.Namespace, parser: argparse.ArgumentParser,
               options: dict[str, str] | None = None) -> None:
    """Check every run, then run them, writing each run's CSV and trajectory plot as it
    finishes; then the table, ``track.json``/``track.md`` and the error plot.

    ``options``: the option naming each part of a configuration in errors (default
    :data:`TRACK_OPTIONS`; ``benchmark`` has its own).
    """
    out = Path(args.out)
    scenario, faults = args.scenario, args.faults  # parsed (``json_value``, ``json_or_name``)
    rows, records = [], {}
    # a policy without a K_p (an SB3 agent, local_ik_asdm) runs once per seed
    runs = [(kp, seed, policy) for kp, seed, policy in itertools.product(args.kp, args.seeds,
                                                                          args.policies)
            if _takes_kp(policy) or kp == args.kp[0]]
    video = getattr(args, "video", False)
    obs = getattr(args, "obs", None)

    def policy_env(policy: str) -> dict[str, Any]:
        """``--obs`` for every policy, else what the policy needs (POLICY_ENV_DEFAULTS)."""
        if obs is not None:
            return {"obs": list(obs)}
        return copy.deepcopy(POLICY_ENV_DEFAULTS.get(policy, {}))

    configs = [RunConfig(
        policy=policy, policy_params={"kp": kp} if _takes_kp(policy) else {}, seed=seed,
        env_kwargs={"preset": args.preset, "path": args.path, "cycles": args.cycles,
                    "scenario": scenario, "faults": faults, "feedback": args.feedback,
                    "engine": getattr(args, "engine", REFERENCE_ENGINE), **policy_env(policy)},
        video_path=str(out / f"{_track_label(policy, kp, seed)}.mp4") if video else None)
        for kp, seed, policy in runs]
    _check_configs(parser, configs, TRACK_OPTIONS if options is None else options)
    out.mkdir(parents=True, exist_ok=True)

    def keep(index: int, record: dict) -> None:  # on disk as soon as the run finishes
        kp, seed, policy = runs[index]
        label = _track_label(policy, kp, seed)
        write_records_csv(out / f"{label}.csv", record)
        plot_trajectory(out / f"{label}_trajectory.png", record, label)

    print(f"{len(configs)} runs on {args.workers} worker(s)", flush=True)
    try:
        records_in_order = runner.run_many(configs, workers=args.workers, progress=True,
                                           on_result=keep)
    except ValueError as error:  # refused mid-run, e.g. a feedback a baseline cannot calibrate from
        print(f"error: {' '.join(str(error).split())} (the runs finished before it are in "
              f"{out})", file=sys.stderr)
        raise SystemExit(1) from None
    for (kp, seed, policy), config, record in zip(runs, configs, records_in_order):
        records[_track_label(policy, kp, seed)] = record
        rows.append((config.identity(), summarize(record)))
    table = summary_table(rows)
    for row in table:  # the paper compares settled tracking: the last cycle, after learning
        row["track_last_cycle_mm"] = row.get(f"track_mean_mm_cycle{args.cycles}")
        row["dev_last_cycle_mm"] = row.get(f"dev_mean_mm_cycle{args.cycles}")
    table = add_improvement(table, baseline={"policy": "cc_model"})
    table = add_improvement(table, baseline={"policy": "cc_model"}, metric="track_last_cycle_mm",
                            column="improvement_last_%")
    table = add_improvement(table, baseline={"policy": "cc_model"}, metric="dev_last_cycle_mm",
                            column="dev_improvement_last_%")
    _agents_against_first_gain(table, args.kp[0])
    colors = {_track_label(policy, kp, seed): policy_color(policy) for kp, seed, policy in runs}
    plot_error_time(out / "error_time.png", records, _track_title(args, records),
                    colors=colors)
    write_results_json(out / "track.json", table)
    columns = ["policy", "kp", "seed", "track_mean_mm", "track_max_mm", "dev_mean_mm",
               "improvement_%", "track_last_cycle_mm", "dev_last_cycle_mm", "improvement_last_%",
               "dev_improvement_last_%"]
    text = markdown_table(table, columns=[c for c in columns if c in table[0]])
    (out / "track.md").write_text(text + "\n")
    print(text)


def _track_title(args: argparse.Namespace, records: dict[str, dict]) -> str:
    """The error plot's title: ``args.title`` where set (``benchmark``'s, whose ``{end_s}`` is
    the runs' end, s), else the preset and path."""
    title = getattr(args, "title", None)
    if not title:
        return f"{args.preset} {args.path}"
    end_s = max((float(np.max(record["time_s"])) for record in records.values()
                 if len(record.get("time_s", ()))), default=float("nan"))
    return title.format(end_s=end_s)


def _takes_kp(policy: str) -> bool:
    """Whether ``policy`` is a baseline with a ``kp`` gain (``--kp``); SB3 agents and
    ``local_ik_asdm`` have none (a name that is no baseline is refused later, by the checks)."""
    if policy.startswith("sb3:") or policy not in BASELINES:
        return False
    return "kp" in inspect.signature(BASELINES[policy].__init__).parameters


def _track_label(policy: str, kp: float, seed: int) -> str:
    """File stem of one track run's CSV, plots and video."""
    gain = f"_kp{kp}" if _takes_kp(policy) else ""
    return f"{policy_label(policy)}{gain}_seed{seed}"


def _agents_against_first_gain(table: list[dict], kp: float) -> None:
    """SB3 agents have no K_p: their improvement is over ``cc_model`` at the first gain."""
    columns = {"improvement_%": "track_mean_mm", "improvement_last_%": "track_last_cycle_mm",
               "dev_improvement_last_%": "dev_last_cycle_mm"}
    for row in table:
        if not str(row["policy"]).startswith("sb3:"):
            continue
        baseline = [other for other in table if other["policy"] == "cc_model"
                    and other.get("kp") == kp and other["seed"] == row["seed"]]
        for column, metric in columns.items():
            if baseline:
                row[column] = 100.0 * improvement(baseline[0][metric], row[metric])


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``track`` subcommand's parser."""
    track = sub.add_parser("track", help="baselines tracking a path",
                           formatter_class=HelpFormatter)
    track.add_argument("--policies", nargs="+", default=["cc_model", "hybrid_gpr"],
                       help="baseline names (cc_model, hybrid_gpr, lwpr_rwr, local_ik_asdm) or "
                            "sb3:PATH (a model .zip, a run directory or a shipped agent's name; "
                            "its observation and action spaces must match the env's)")
    track.add_argument("--kp", type=positive_float, nargs="+", default=[0.06],
                       help="K_p gains of eq. (26), finite numbers > 0 (paper: 0.04 0.06 0.08 "
                            "0.10)")
    track.add_argument("--preset", default=DEFAULT_PRESET,
                       help=f"arm preset: {', '.join(sorted(PRESETS))}")
    track.add_argument("--path", default="circle",
                       help=", ".join(sorted(PATH_SHAPES)))
    track.add_argument("--cycles", type=positive_int, default=3,
                       help="path cycles per run (>= 1)")
    track.add_argument("--feedback", default="ground_truth",
                       help="pose feedback: fused, camera, fbg, em, ground_truth (or another "
                            "source the preset supports)")
    track.add_argument("--scenario", type=json_value, default=None,
                       help='loads as JSON, e.g. \'{"name": "tip_mass", "mass_kg": 0.01}\'')
    track.add_argument("--faults", type=json_or_name, default=None,
                       help=f"visual faults: a fault's or a paper's preset name "
                            f"({', '.join([*FAULTS, *FAULT_PRESETS])}) "
                            'or JSON, e.g. \'{"name": "moving_occluder", "mode": "full"}\'')
    track.add_argument("--obs", nargs="+", default=None, choices=list(OBSERVATION_PARTS),
                       metavar="PART",
                       help="observation parts of every run's env, in order (from "
                            f"{', '.join(OBSERVATION_PARTS)}); default: the env's, or what a "
                            "baseline needs (local_ik_asdm: "
                            f"{' '.join(POLICY_ENV_DEFAULTS['local_ik_asdm']['obs'])}); SB3 "
                            "agents always get the parts they were trained with")
    track.add_argument("--seeds", type=seed_int, nargs="+", default=[0],
                       help=f"episode seeds (integers in [0, {SEED_MAX}])")
    track.add_argument("--engine", choices=list(ENGINES), default=REFERENCE_ENGINE,
                       help="physics engine (mujoco: no cameras or bodies beside the arm, "
                            "refused before any run)")
    track.add_argument("--out", default="results/track",
                       help="output directory (made; must be writable)")
    add_workers(track)
    add_video_flag(track)
    return track


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``track``: every run checked, then run (:func:`run_tracks`)."""
    run_tracks(args, parser)
    print(f"output directory: {args.out}")
