"""Command line of the benchmark runner.

    python -m eval estimation --experiments clean occlusion lighting --steps 4000 --out results/estimation
    python -m eval track --policies cc_model hybrid_gpr --kp 0.04 0.1 --path circle --out results/track

``suite``: the four-arm benchmark grid of a YAML spec; ``python -m eval suite small`` is the
README's main job (the schema of a spec: docs/suite.md).

``datasets``: the papers' exploration and calibration data as Minari datasets
(``python -m eval datasets --help``; README.md, "Datasets").

``benchmark``: the wang2023 comparison on a loaded circle with fused feedback and a partly
occluding hand (``python -m eval benchmark --help``).

``compare``: the SB3 agents against the baselines, nominal and out of distribution (see
``eval/compare.py``).

``claims``: the papers' headline claims as a ledger, each reproduced, partly or not reproduced
on every seed against a criterion from the paper's own figures (``eval/claims/``; the last full
run is docs/claims.md).

``estimation``: the wang2023 estimation experiments (camera, F-emp and fusion vs ground truth;
Figs. 6-7, Tables III, IV, VI). ``track``: baselines tracking a path on an arm preset, with loads,
visual faults and a feedback source, several gains and seeds; a Markdown table with mean +- std,
max, per cycle and the improvement over ``cc_model``, per-step CSVs and plots.

Every command ends by printing the output directory it wrote to (``--out``); its JSON summary
records the soft-arm-gym version that made it (``soft_arm_gym_version``). ``--video`` (``track``,
``benchmark``, ``compare``, ``estimation``) also writes an MP4 of each run next to its CSV (a GIF
where ffmpeg is absent): the scene with the target, path, loads, true tip and estimate, and the
camera sensors' frames beside it, one frame per control step (see ``eval/video.py``).

Every option is checked before any work starts: a bad value (a count below 1, a negative seed, a
gain that is not a finite positive number, JSON that does not parse, an output directory that
cannot be written, an unknown preset, path, feedback source or policy, an ``sb3:PATH`` that holds
no model or one whose observation or action space differs from its env's) exits with status 2
and one line naming the option, the value and what is allowed. ``track``, ``benchmark`` and
``compare`` check every run's configuration (each env built once without calibration, every
baseline made, every agent loaded) before the first run, and write each run's CSV as it
finishes, so a run failing later keeps the finished ones.
"""

from __future__ import annotations

import argparse
import copy
import inspect
import itertools
import os
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from agents.policies import BASELINES, shipped_agents
from eval import compare as compare_module
from eval import runner  # runner.run_many, looked up at each call (tests stand in for it)
from eval import datasets as datasets_module
from eval import results_page
from eval import suite as suite_module
from eval.claims import CLAIMS, claim_papers
from eval.datasets import write as dataset_write
from eval.claims.report import ledger_table, summary_line, write_ledger
from eval.claims.run import run_ledger, select_claims
from eval.metrics import add_improvement, improvement, summarize, summary_table
import eval.papers.wang2023.estimation as estimation_module
import eval.papers.ho2018.experiments as ho2018_module
import eval.papers.zhao2021.experiments as zhao2021_module
import eval.papers.zou2022.experiments as zou2022_module
import eval.papers.zou2022.levers as zou2022_levers
from eval.papers.wang2023.estimation import EXPERIMENTS, run_experiments
from eval.palette import policy_color, policy_label
from eval.report import (markdown_table, plot_error_time, plot_trajectory, write_records_csv,
                         write_results_json)
from eval.runner import ConfigError, RunConfig, check_configs
from eval.suite.spec import POLICY_ENV_DEFAULTS
from soft_gym._cli import (HelpFormatter, check_environment, check_output_dir, fail,
                           finite_float, int_at_least, json_or_name, json_value,
                           non_negative_int, positive_float, positive_int, seed_int)
from soft_gym._validation import SEED_MAX
from soft_gym.engines import ENGINES, REFERENCE_ENGINE
from soft_gym.envs.observations import OBSERVATION_PARTS
from soft_gym.papers.zou2022.shape_dnn import ShapeDNNConfig
from soft_gym.papers.zhao2021.backbone_fit import BACKBONE_CURVES
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig


DEFAULT_WORKERS = max(1, min(2, os.cpu_count() or 1))


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


def _track(args: argparse.Namespace, parser: argparse.ArgumentParser,
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


def _add_video_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--video", action="store_true",
                        help="also write an MP4 of each run next to its CSV (a GIF without "
                             "ffmpeg)")


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


def _check_baselines(parser: argparse.ArgumentParser, baselines: list[str],
                     check_agent=None) -> None:
    """``--baselines``: known baseline names or ``sb3:PATH``, before any work; ``check_agent``
    (the experiment module's ``check_baselines``) then tries each on the experiment's env."""
    unknown = [name for name in baselines
               if name not in BASELINES and not (name.startswith("sb3:") and len(name) > 4)]
    if unknown:
        parser.error(f"--baselines must be names from {sorted(BASELINES)} or sb3:PATH, "
                     f"got {unknown}")
    if check_agent is not None:
        try:
            check_agent(tuple(baselines))
        except ValueError as error:
            fail(parser, "--baselines", error)


def _paper_parser(sub, name: str, module, help_text: str,
                  seeds_help: str) -> argparse.ArgumentParser:
    """The subcommand of one paper's experiments: ``--experiments`` among the module's
    ``EXPERIMENTS`` (default all) and ``--seeds``; its description is the module's docstring."""
    paper = sub.add_parser(name, help=help_text, description=module.__doc__,
                           formatter_class=HelpFormatter)
    default = list(getattr(module, "DEFAULT_EXPERIMENTS", module.EXPERIMENTS))
    paper.add_argument("--experiments", nargs="+", default=default,
                       choices=list(module.EXPERIMENTS),
                       help="which experiments (default: " + " ".join(default) + ")")
    paper.add_argument("--seeds", type=seed_int, nargs="+", default=[0],
                       help=f"{seeds_help}; integers in [0, {SEED_MAX}]")
    return paper


def _add_workers(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--workers", type=positive_int, default=DEFAULT_WORKERS,
                        help="runs in parallel processes, >= 1 (up to 2 helps, one per core)")


def _add_backend(parser: argparse.ArgumentParser, choices: list[str], what: str) -> None:
    """``--backend`` (``choices``, the first the default; ``what`` says what they run) and its
    ``--address``."""
    parser.add_argument("--backend", default=choices[0], choices=choices,
                        help=f"{what} (a local Ray or --address; extra: soft-arm-gym[ray])")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="with --backend ray: an existing Ray cluster (auto, "
                             "ray://host:10001, host:6379); the package must be importable on "
                             "every node. Default: a local Ray")


def _ray_backend(parser: argparse.ArgumentParser, args: argparse.Namespace,
                 ray_module: str) -> Any:
    """The backend of ``--backend`` and ``--address`` (checked, a parser error otherwise): the
    name given, or with ``ray`` the map of ``make_ray_map(--address)`` of ``ray_module`` (the
    Ray backend's module, imported only then: Ray is an optional extra)."""
    if args.address is not None and args.backend != "ray":
        parser.error(f"--address is the Ray cluster of --backend ray, got --backend "
                     f"{args.backend}")
    if args.address is not None and not args.address.strip():
        parser.error("--address must be a Ray address (auto, ray://host:10001, host:6379), "
                     "got ''")
    if args.backend != "ray":
        return args.backend
    from importlib import import_module

    module = import_module(ray_module)
    try:
        module.require_ray()
    except ImportError as error:
        parser.error(f"--backend ray: {error}")
    return module.make_ray_map(args.address)


# ------------------------------------------------------------------------------------ benchmark
BENCHMARK_LOAD_KG = 0.010
"""The tip mass of ``benchmark``'s runs (kg)."""

BENCHMARK_OCCLUDER = {"name": "moving_occluder", "mode": "partial", "strength": 0.8,
                      "start_s": 40.0}
"""The visual fault of ``benchmark``'s runs: a partly occluding hand from 40 s on."""

BENCHMARK_DESCRIPTION = (
    "The wang2023 comparison: cc_model, hybrid_gpr and the shipped SB3 agents trained on "
    "SoftArmTrackWang2023-v0 track the circle for 3 cycles with a "
    f"{BENCHMARK_LOAD_KG * 1000:g} g tip load, fused camera/FBG feedback, and a partly occluding "
    f"hand moving in front of the camera from {BENCHMARK_OCCLUDER['start_s']:g} s on. Prints the "
    "table and writes per-run CSVs, a JSON summary and plots to --out (about 1 minute on 2 idle "
    "cores, 2 beside another job). The README's main job is 'suite small'.")
"""``benchmark --help``'s description (its runs are fixed)."""


def benchmark_title() -> str:
    """The title of ``benchmark``'s error plot: the arm, path, load, feedback and the occlusion
    window (``{end_s}``: the runs' end, filled in once they are done)."""
    occluder = BENCHMARK_OCCLUDER
    return (f"wang2023 circle, {BENCHMARK_LOAD_KG * 1000:g} g tip load, fused feedback; "
            f"{occluder['mode']} occluder (strength {occluder['strength']:g}) "
            f"from {occluder['start_s']:g} s to {{end_s:.0f}} s (the end)")


def _benchmark_parser(sub) -> argparse.ArgumentParser:
    """The ``benchmark`` subcommand's parser (its runs are fixed)."""
    benchmark = sub.add_parser("benchmark", help="the wang2023 comparison: loaded circle, fused "
                               "feedback, an occluding hand",
                               description=textwrap.fill(BENCHMARK_DESCRIPTION, 96),
                               formatter_class=HelpFormatter)
    benchmark.add_argument("--out", default="results/benchmark",
                           help="output directory (made; must be writable)")
    _add_workers(benchmark)
    _add_video_flag(benchmark)
    return benchmark


def _run_benchmark(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``benchmark``: ``track`` with the README's main job's fixed settings."""
    args = argparse.Namespace(
        policies=["cc_model", "hybrid_gpr"] + [f"sb3:{name}" for name in
                                               shipped_agents("SoftArmTrackWang2023-v0")],
        kp=[0.06], preset="wang2023", path="circle",
        cycles=3, feedback="fused", scenario={"name": "tip_mass", "mass_kg": BENCHMARK_LOAD_KG},
        faults=dict(BENCHMARK_OCCLUDER), seeds=[0], out=args.out, workers=args.workers,
        video=args.video, title=benchmark_title())
    # benchmark's settings are fixed: a refusal names the part (a shipped agent, ...)
    _track(args, parser, options={})
    print(f"output directory: {args.out}")


# ----------------------------------------------------------------------------------- estimation
def _estimation_parser(sub) -> argparse.ArgumentParser:
    """The ``estimation`` subcommand's parser."""
    estimation = sub.add_parser("estimation", help="wang2023 estimation experiments",
                                description=estimation_module.__doc__,
                                formatter_class=HelpFormatter)
    estimation.add_argument("--experiments", nargs="+", default=["clean"],
                            choices=list(EXPERIMENTS) + ["all"],
                            help="which runs ('all' for every one)")
    estimation.add_argument("--steps", type=int, default=4000,
                            help="control steps of 0.05 s per run, >= 600 (paper: ~4000)")
    estimation.add_argument("--seed", type=seed_int, default=0,
                            help="episode seed (integer >= 0)")
    estimation.add_argument("--out", default="results/estimation",
                            help="output directory (made; must be writable)")
    _add_video_flag(estimation)
    return estimation


def _run_estimation(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``estimation``: the chosen experiments, then their table."""
    if args.steps < 600:
        parser.error(f"--steps must be >= 600 (the F-emp calibration alone takes 450), "
                     f"got {args.steps}")
    experiments = list(EXPERIMENTS) if "all" in args.experiments else args.experiments
    rows = run_experiments(experiments, args.out, steps=args.steps, seed=args.seed,
                           **({"video": True} if args.video else {}))
    print(markdown_table(rows, float_format="{:.2f}"))
    print(f"output directory: {args.out}")


# ---------------------------------------------------------------------------------------- track
def _track_parser(sub) -> argparse.ArgumentParser:
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
    track.add_argument("--preset", default="wang2023",
                       help="arm preset: wang2023, ho2018, zhao2021 or zou2022")
    track.add_argument("--path", default="circle",
                       help="circle, pentagram, rectangle, spiral, star")
    track.add_argument("--cycles", type=positive_int, default=3,
                       help="path cycles per run (>= 1)")
    track.add_argument("--feedback", default="ground_truth",
                       help="pose feedback: fused, camera, fbg, em, ground_truth (or another "
                            "source the preset supports)")
    track.add_argument("--scenario", type=json_value, default=None,
                       help='loads as JSON, e.g. \'{"name": "tip_mass", "mass_kg": 0.01}\'')
    track.add_argument("--faults", type=json_or_name, default=None,
                       help="visual faults: a fault's name (wang2023_occlusion, low_light, ...) "
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
    _add_workers(track)
    _add_video_flag(track)
    return track


def _run_track(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``track``: every run checked, then run (:func:`_track`)."""
    _track(args, parser)
    print(f"output directory: {args.out}")


# --------------------------------------------------------------------------------------- ho2018
def _ho2018_parser(sub) -> argparse.ArgumentParser:
    """The ``ho2018`` subcommand's parser."""
    ho2018 = _paper_parser(sub, "ho2018", ho2018_module,
                           "ho2018 static and varying tip-load experiments",
                           "seeds (pre-training waypoints and episode)")
    ho2018.add_argument("--quick", action="store_true",
                        help="the shorter protocol: 40 s static and 30 s varying cycles, "
                             "decisions at 10 Hz, a 15 s lead-in (default: the paper's, 133.3 s "
                             "static cycles at 20 Hz, 45 s varying cycles at 20 Hz offline "
                             "and 6.7 Hz online, a 30 s lead-in)")
    ho2018.add_argument("--cycle-s", type=finite_float(5.0, 3600.0), default=None,
                        help="seconds per rectangle cycle (s), in [5, 3600]; default: the "
                             "protocol's")
    ho2018.add_argument("--baselines", nargs="*", default=[],
                        help="further policies on the online run's load, e.g. cc_model "
                             "hybrid_gpr sb3:PATH")
    ho2018.add_argument("--lead-in-s", type=finite_float(0.0, 3600.0), default=None,
                        help="seconds tracking the first corner before recording (s), in "
                             "[0, 3600]; default: the protocol's")
    ho2018.add_argument("--out", default="results/ho2018",
                        help="output directory (made; must be writable)")
    return ho2018


def _run_ho2018(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``ho2018``: the further baselines checked, then the experiments."""
    _check_baselines(parser, args.baselines, ho2018_module.check_baselines)
    ho2018_module.run_and_report(args.experiments, args.seeds, args.out,
                                 protocol="quick" if args.quick else "paper",
                                 cycle_s=args.cycle_s, lead_in_s=args.lead_in_s,
                                 baselines=tuple(args.baselines))
    print(f"output directory: {args.out}")


# ------------------------------------------------------------------------------------- zhao2021
def _zhao2021_parser(sub) -> argparse.ArgumentParser:
    """The ``zhao2021`` subcommand's parser."""
    zhao2021 = _paper_parser(sub, "zhao2021", zhao2021_module,
                             "zhao2021 shape reconstruction and local-IK control experiments",
                             "seeds (exploration, training and episodes)")
    zhao2021.add_argument("--samples", type=non_negative_int, nargs=2, default=[4000, 2000],
                          metavar=("FREE", "LOADED"),
                          help="exploration samples free and with the 75 g tip, >= 0 each and "
                               ">= 24 together (paper: 4000 2000)")
    zhao2021.add_argument("--iterations", type=positive_int, default=1000,
                          help="most training iterations of the networks, >= 1 (paper: 1000)")
    zhao2021.add_argument("--backbone-curve", choices=BACKBONE_CURVES, default="paper",
                          help="the curve fitted through the key points (shape and control): "
                               "paper = eqs. 7-10 in each subsegment's frame (default), "
                               "paper_base_frame = all in the base frame, cubic_fallback = a "
                               "cubic where the paper's curve misses a key point by > 1 mm")
    zhao2021.add_argument("--paper-training", action="store_true",
                          help="train the networks with the paper's settings where the defaults "
                               "differ: SFE-PD dropout 0.3 and Adam at 0.001, the local IK "
                               "network at 0.001 without its skip connection (separate cache "
                               "entries; about as long to build as the defaults)")
    zhao2021.add_argument("--goal-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                          default=list(zhao2021_module.P2P_GOAL_MM),
                          help="the point-to-point goal in the paper's frame (mm; paper: "
                               "-50 70 210); refused unless the arm holds it with every load")
    zhao2021.add_argument("--p2p-loads-g", type=float, nargs="*",
                          default=[1000 * m for m in zhao2021_module.P2P_LOADS_KG[1:]],
                          help="tip loads of the loaded ASDM point-to-point runs (g; paper: "
                               "50 75 100)")
    zhao2021.add_argument("--circle-load-g", type=float,
                          default=1000 * zhao2021_module.CIRCLE_MASS_KG,
                          help="the block added at step 29 and removed at step 60 of the "
                               "circle (g; paper: 263)")
    zhao2021.add_argument("--baselines", nargs="*", default=[],
                          help="further policies on the free point-to-point run and circle, "
                               "e.g. lwpr_rwr cc_model sb3:PATH")
    zhao2021.add_argument("--out", default="results/zhao2021",
                          help="output directory (made; must be writable)")
    return zhao2021


def _run_zhao2021(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``zhao2021``: the sample counts and further baselines checked, then the experiments."""
    free, loaded = args.samples
    if free + loaded < 24:
        parser.error(f"--samples must be two counts >= 0 adding up to >= 24, got "
                     f"{args.samples}")
    _check_baselines(parser, args.baselines, zhao2021_module.check_baselines)
    setup = {"goal_mm": tuple(args.goal_mm),
             "p2p_loads_kg": tuple(g / 1000.0 for g in args.p2p_loads_g),
             "circle_mass_kg": args.circle_load_g / 1000.0}
    if {"p2p", "sway", "circle"} & set(args.experiments):
        try:
            zhao2021_module.check_setup(**setup)
        except ValueError as error:  # "goal_mm: ..." names its option: "--goal-mm: ..."
            name, _, reason = str(error).partition(":")
            parser.error(f"--{name.replace('_', '-')}:{reason}")
    paper = zhao2021_module.PAPER_TRAINING if args.paper_training else {}
    config = ReconstructionConfig(n_free=free, n_loaded=loaded,
                                  max_iterations=args.iterations,
                                  backbone_curve=args.backbone_curve,
                                  **paper.get("sensing", {}))
    zhao2021_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                   baselines=tuple(args.baselines),
                                   controller=paper.get("controller"), **setup)
    print(f"output directory: {args.out}")


# -------------------------------------------------------------------------------------- zou2022
def _zou2022_parser(sub) -> argparse.ArgumentParser:
    """The ``zou2022`` subcommand's parser."""
    zou2022 = _paper_parser(sub, "zou2022", zou2022_module,
                            "zou2022 shape estimation (RSES, ASES, DNN) and control with each "
                            "shape source", "seeds (exploration, training, sensor noise, poses)")
    zou2022.add_argument("--samples", type=int_at_least(20), default=29791,
                         help="exploration samples of the DNN's data set, >= 20 (paper: 31^3 = "
                              "29791, ~25 min on one core, cached)")
    zou2022.add_argument("--epochs", type=positive_int, default=500,
                         help="DNN training epochs, >= 1 (paper: 500)")
    zou2022.add_argument("--lever-samples", type=int_at_least(20), default=3000,
                         help="exploration samples of the DNN trained at each lever of the "
                              "'levers' experiment (Table 4 at braid-twist levers 0-5 mm), "
                              ">= 20")
    zou2022.add_argument("--poses", type=positive_int, default=20,
                         help="random poses of the ASES fault experiment (>= 1)")
    zou2022.add_argument("--out", default="results/zou2022",
                         help="output directory (made; must be writable)")
    return zou2022


def _run_zou2022(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``zou2022``: the experiments with the given DNN data set and training."""
    config = ShapeDNNConfig(n_samples=args.samples, epochs=args.epochs)
    zou2022_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                  n_poses=args.poses)
    if "levers" in args.experiments:
        zou2022_levers.run_and_report(args.seeds, args.out, ShapeDNNConfig(
            n_samples=args.lever_samples, epochs=args.epochs))
    print(f"output directory: {args.out}")


# --------------------------------------------------------------------------------------- claims
CLAIMS_DESCRIPTION = (
    "The papers' headline claims as a ledger: run the experiments behind each claim for every "
    "seed and report each claim reproduced, partly or not reproduced, with the numbers that "
    "decided it (the criteria are the papers' own figures; docs/claims.md holds the last full "
    "run). Writes claims.md, claims.json and records/ (one summary per experiment and seed, "
    "read back by --resume) to --out. A full run of every paper on seeds 0-2 takes hours "
    "(README: 'The claims ledger'); --quick runs a small version of every experiment in "
    "minutes, its verdicts marked quick.")
"""``claims --help``'s description."""

DOCS_LEDGER = Path(__file__).resolve().parents[1] / "docs" / "claims.md"
"""Where ``claims --docs`` writes the ledger of a full run (the repository's docs/claims.md)."""
DOCS_RECORDS = DOCS_LEDGER.with_suffix("")
"""``claims --docs``'s default ``--out``: docs/claims/, whose ``records/`` keep the experiments'
summaries behind docs/claims.md, so ``--resume --docs`` continues the repository's ledger."""


def _claims_parser(sub) -> argparse.ArgumentParser:
    """The ``claims`` subcommand's parser."""
    claims = sub.add_parser("claims", help="the papers' claims as a ledger: reproduced, partly "
                            "or not, per seed", description=textwrap.fill(CLAIMS_DESCRIPTION, 96),
                            formatter_class=HelpFormatter)
    claims.add_argument("--papers", nargs="+", default=list(claim_papers()), choices=list(claim_papers()),
                        help="whose claims")
    claims.add_argument("--claims", nargs="+", default=None, metavar="KEY",
                        help=f"only these claims (of {len(CLAIMS)}: " + ", ".join(CLAIMS) + ")")
    claims.add_argument("--seeds", type=seed_int, nargs="+", default=[0, 1, 2],
                        help=f"seeds every claim is judged on (integers in [0, {SEED_MAX}])")
    claims.add_argument("--quick", action="store_true",
                        help="a small version of every experiment (minutes; verdicts marked "
                             "quick)")
    claims.add_argument("--out", default=None,
                        help="output directory (made; must be writable); default: "
                             "results/claims, or docs/claims with --docs")
    claims.add_argument("--resume", action="store_true",
                        help="read the experiment records already in --out instead of running "
                             "them again")
    claims.add_argument("--report-only", action="store_true",
                        help="run nothing: judge each claim on the seeds whose records are in "
                             "--out (a claim with none is 'not run')")
    claims.add_argument("--docs", action="store_true",
                        help="also write the ledger to docs/claims.md, its records kept in "
                             "docs/claims/records (a full run of every claim only)")
    _add_workers(claims)
    _add_backend(claims, ["local", "ray"], "--workers local processes, or each job a Ray task")
    return claims


def _run_claims(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``claims``: check the options, run the experiments, print and write the ledger."""
    try:
        select_claims(args.papers, args.claims)
    except ValueError as error:
        fail(parser, "--claims", error)
    if args.report_only and args.resume:
        parser.error("--resume runs the missing experiments; --report-only runs none: give one")
    backend = _ray_backend(parser, args, "eval.claims.ray_backend")
    if args.docs and (args.quick or args.claims is not None
                      or list(args.papers) != list(claim_papers())):
        parser.error("--docs writes the full ledger: every paper and claim, without --quick")
    if args.docs:
        check_output_dir(parser, "--docs", DOCS_LEDGER.parent)
    if args.out is None:
        args.out = str(DOCS_RECORDS if args.docs else Path("results") / "claims")
        check_output_dir(parser, "--out", args.out)
    command = _claims_command(args)
    ledger = run_ledger(args.papers, args.seeds, quick=args.quick, out=args.out,
                        resume=args.resume, workers=args.workers, progress=True,
                        claims=args.claims, report_only=args.report_only, backend=backend)
    markdown_path, _ = write_ledger(ledger, args.out, command)
    print(ledger_table(ledger))
    print(summary_line(ledger))
    if args.docs:
        DOCS_LEDGER.write_text(markdown_path.read_text(encoding="utf-8"), encoding="utf-8")
        if Path(args.out).resolve() == DOCS_RECORDS.resolve():
            markdown_path.unlink()  # docs/claims.md is its one copy in the repository
        print(f"ledger written to {DOCS_LEDGER}")
    print(f"output directory: {args.out}")
    bad = ledger["bad_records"]
    if bad:
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        print(f"error: {len(bad)} bad record(s) left out of the ledger: {'; '.join(bad[:5])}"
              f"{more}; run again with --resume to redo them", file=sys.stderr)
        raise SystemExit(1)


def _claims_command(args: argparse.Namespace) -> str:
    """The command line that makes this ledger (for its header)."""
    parts = ["python -m eval claims"]
    if list(args.papers) != list(claim_papers()):
        parts.append("--papers " + " ".join(args.papers))
    if args.claims is not None:
        parts.append("--claims " + " ".join(args.claims))
    parts.append("--seeds " + " ".join(str(seed) for seed in args.seeds))
    if args.quick:
        parts.append("--quick")
    if args.report_only:
        parts.append("--report-only")
    if args.docs:
        parts.append("--docs")
    return " ".join(parts)


# -------------------------------------------------------------------------------------- compare
def _compare_parser(sub) -> argparse.ArgumentParser:
    """The ``compare`` subcommand's parser."""
    compare = sub.add_parser(
        "compare", help="SB3 agents against the baselines, nominal and out of distribution",
        description=compare_module.__doc__, formatter_class=HelpFormatter)
    compare.add_argument("--policies", nargs="+", default=None,
                         help="baselines, sb3:PATH or shipped agent names as sb3:<name> "
                              "(default: cc_model, hybrid_gpr and every shipped agent)")
    compare.add_argument("--paths", nargs="+", default=["circle", "pentagram"],
                         help="paths to track (circle, pentagram, rectangle, spiral, star)")
    compare.add_argument("--conditions", nargs="+", default=list(compare_module.CONDITIONS),
                         choices=list(compare_module.CONDITIONS), help="test conditions")
    compare.add_argument("--seeds", type=seed_int, nargs="+", default=[0, 1],
                         help=f"episode seeds (integers in [0, {SEED_MAX}])")
    compare.add_argument("--cycles", type=positive_int, default=2,
                         help="path cycles per run (>= 1)")
    compare.add_argument("--feedback", default="fused",
                         help="pose feedback of every policy: fused, camera, fbg, em, ground_truth")
    compare.add_argument("--kp", type=positive_float, default=0.06,
                         help="K_p of the CC baselines, a finite number > 0")
    compare.add_argument("--out", default="results/compare",
                         help="output directory (made; must be writable)")
    _add_workers(compare)
    _add_video_flag(compare)
    return compare


COMPARE_OPTIONS = {"env_kwargs.path": "--paths", "env_kwargs.cycles": "--cycles",
                   "env_kwargs.feedback": "--feedback", "env_kwargs.scenario": "--conditions",
                   "env_kwargs.faults": "--conditions", "policy": "--policies",
                   "policy_params": "--kp", "seed": "--seeds"}
"""The part of a run configuration -> the ``compare`` option that sets it."""


def _run_compare(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``compare``: check the options and every run, run (each run's CSV written as it
    finishes), print the table."""
    policies = args.policies or (["cc_model", "hybrid_gpr"]
                                 + [f"sb3:{name}" for name in
                                    shipped_agents("SoftArmTrackWang2023-v0")])
    if args.feedback not in ("fused", "camera") and "occlusion" in args.conditions:
        parser.error("the occlusion condition needs camera feedback: --feedback fused or "
                     f"camera, got {args.feedback!r}")
    try:
        rows = compare_module.run_comparison(
            policies, args.paths, args.conditions, args.seeds, args.out, cycles=args.cycles,
            feedback=args.feedback, kp=args.kp, workers=args.workers,
            **({"video": True} if args.video else {}), check=True)
    except ConfigError as error:
        option = COMPARE_OPTIONS.get(error.part, "--policies")
        shown = {"--paths": error.config.env_kwargs.get("path"), "--kp": args.kp,
                 "--feedback": args.feedback, "--cycles": args.cycles,
                 "--conditions": error.config.labels.get("condition"),
                 "--policies": error.config.policy, "--seeds": error.config.seed}[option]
        fail(parser, option, f"{shown!r} refused: {error.message}")
    print(markdown_table(rows, float_format="{:.2f}"))
    print(f"output directory: {args.out}")


# ---------------------------------------------------------------------------------------- suite
SUITE_DESCRIPTION = (
    "Run the benchmark grid a YAML spec declares (presets x paths x conditions x policies x "
    "seeds): a bundled suite by name ('small' is the README's main job, 'default' every arm "
    "with its paper's conditions, 'demos' SAC started from demonstrations against SAC from "
    "scratch) or a file of your own. The spec is checked before any run; "
    "each run's record is written as it finishes (--resume continues an interrupted grid); the "
    "report ranks the policies per arm and condition (leaderboard.md, runs.csv, suite.json, "
    "plots). The spec's schema is in docs/suite.md.")
"""``suite --help``'s description (the schema itself is in docs/suite.md)."""


def _suite_parser(sub) -> argparse.ArgumentParser:
    """The ``suite`` subcommand's parser."""
    suite = sub.add_parser(
        "suite", help="the four-arm benchmark suite of a YAML spec (the README's main job: "
        "suite small): leaderboard, IQM with bootstrap CIs, performance profiles",
        description=textwrap.fill(SUITE_DESCRIPTION, 96), formatter_class=HelpFormatter)
    suite.add_argument("spec", help="suite YAML file, or a bundled suite: "
                       f"{', '.join(suite_module.bundled_suites())}")
    suite.add_argument("--out", default=None,
                       help="output directory (made); default: results/suite_<suite "
                            "name>[_<engine>]")
    _add_workers(suite)
    suite.add_argument("--resume", action="store_true",
                       help="skip the runs already recorded in --out")
    suite.add_argument("--seeds", type=seed_int, nargs="+", default=None,
                       help="episode seeds replacing the suite's own (distinct integers in "
                            f"[0, {SEED_MAX}])")
    suite.add_argument("--report-only", action="store_true",
                       help="run nothing: write the report from the records there")
    suite.add_argument("--engine", default=None, choices=list(ENGINES), metavar="ENGINE",
                       help=f"run every arm on ENGINE ({', '.join(ENGINES)}), less what it "
                            "cannot run (listed); default: each arm's own")
    suite.add_argument("--record", choices=["minari"], default=None,
                       help="also write the runs as Minari datasets, one per arm and "
                            "condition, in <out>/datasets (README: Datasets)")
    _add_backend(suite, ["process", "serial", "ray"],
                 "--workers spawned processes, this process, or Ray tasks")
    return suite


def _run_suite(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``suite``: check every option and the spec before any run, run, report."""
    backend = _ray_backend(parser, args, "eval.suite.ray_backend")  # it registers "ray"
    if args.seeds is not None and (any(not 0 <= seed <= SEED_MAX for seed in args.seeds)
                                   or len(set(args.seeds)) != len(args.seeds)):
        parser.error(f"--seeds must be distinct integers >= 0 and <= {SEED_MAX}, got "
                     f"{args.seeds}")
    if args.report_only and args.resume:
        parser.error("--resume runs the missing runs; --report-only runs none: give one")
    if args.record is not None and args.report_only:
        parser.error("--record records the runs; --report-only runs none: give one")
    try:
        suite_module.require_rliable()
    except ImportError as error:
        parser.error(str(error))
    try:
        spec = suite_module.load_suite(args.spec)
        if args.seeds is not None:
            spec = spec.with_seeds(args.seeds)
    except ValueError as error:
        parser.error(f"spec: {error}")
    checker = suite_module.EnvChecker()
    if args.engine is not None:
        try:
            spec, left_out = suite_module.on_engine(spec, args.engine, checker)
        except ValueError as error:
            parser.error(f"--engine: {error}")
        for item in left_out:
            print(f"left out on {args.engine}: {item.label()}: {item.reason}", file=sys.stderr,
                  flush=True)
    out = Path(args.out or f"results/suite_{spec.name}"
               + (f"_{args.engine}" if args.engine else ""))
    if args.out is None:
        check_output_dir(parser, "--out", out)
    try:
        suite_module.check_records_dir(out)
    except ValueError as error:
        fail(parser, "--out", str(error))
    try:
        cells = (suite_module.expand(spec) if args.report_only
                 else suite_module.check_suite(spec, progress=True, checker=checker))
    except ValueError as error:
        parser.error(f"spec: {error}")
    if args.report_only and not suite_module.records_dir(out).is_dir():
        parser.error(f"--report-only: no records under {out} (give the --out of a suite run)")
    failure = None
    if not args.report_only:
        finished = (sum(suite_module.is_finished(out, cell.key) for cell in cells)
                    if args.resume else 0)
        print(f"{len(cells)} runs ({finished} already done) on {args.workers} worker(s)",
              flush=True)
        try:
            suite_module.run_suite(spec, out, workers=args.workers, resume=args.resume,
                                   progress=True, check=False, backend=backend,
                                   record=args.record is not None)
        except suite_module.SuiteRunError as error:
            failure = str(error)
    print(suite_module.write_report(spec, out, cells=cells))
    if args.record is not None:
        from eval.datasets.suite import write_suite_datasets

        recorded = write_suite_datasets(spec.name, out, cells)
        for dataset_id, episodes in recorded["datasets"].items():
            print(f"{dataset_id}: {episodes} episode(s)")
        if recorded["missing"]:
            print(f"{len(recorded['missing'])} run(s) without a recorded episode (n/a, failed, "
                  "or finished before --record): not in the datasets", file=sys.stderr)
        print(f"datasets: {recorded['root']}")
    bad = [problem for cell in cells
           if (problem := suite_module.record_problem(out, cell.key)) is not None]
    if bad and failure is None:
        shown = "; ".join(str(problem) for problem in bad[:5])
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        failure = (f"{len(bad)} bad record(s) left out of the report: {shown}{more}; run "
                   f"again with --resume to redo them")
    if failure is not None:
        print(f"error: {failure}", file=sys.stderr)
    print(f"output directory: {out}")
    if failure is not None:
        raise SystemExit(1)


# ------------------------------------------------------------------------------------ datasets
DATASETS_DESCRIPTION = (
    "Write each paper's exploration or calibration data as a Minari dataset "
    "(soft-arm/<paper>/<name>-v0): the commands, the raw readings the method learns from and "
    "the ground truth, with the env that produced them recoverable "
    "(dataset.recover_environment()). Ids: " + ", ".join(
        f"{paper} {recipe.dataset_id}" for paper, recipe in datasets_module.PAPER_DATASETS.items())
    + ". Load one with minari.load_dataset(ID) (with MINARI_DATASETS_PATH=OUT when --out is "
    "given) or eval.datasets.load_dataset(ID, root=OUT). Fields, units and data cards: "
    "README.md (Datasets) and docs/datasets.md; each dataset's card.md sits beside its data/.")


def _datasets_parser(sub) -> argparse.ArgumentParser:
    """The ``datasets`` subcommand's parser."""
    datasets = sub.add_parser(
        "datasets", help="the papers' exploration and calibration data as Minari datasets",
        description=DATASETS_DESCRIPTION, formatter_class=HelpFormatter)
    papers = list(datasets_module.PAPER_DATASETS)
    datasets.add_argument("--papers", nargs="+", choices=papers, default=papers,
                          help="papers whose datasets to write")
    datasets.add_argument("--size", choices=list(dataset_write.SIZES), default="paper",
                          help="the papers' sample counts (zhao2021 4000 + 2000, zou2022 29791,"
                               " wang2023 450, ho2018 80 waypoints; minutes to an hour), or "
                               "quick ones (seconds)")
    datasets.add_argument("--seed", type=seed_int, default=0,
                          help="the procedures' seed (0: the one the baselines calibrate with)")
    datasets.add_argument("--out", default=None,
                          help="datasets root (made; must be writable); default: Minari's "
                               "(MINARI_DATASETS_PATH, else ~/.minari/datasets)")
    datasets.add_argument("--force", action="store_true",
                          help="replace datasets that exist (otherwise refused before any work)")
    datasets.add_argument("--no-cache", action="store_true",
                          help="collect afresh even where the calibration cache holds the "
                               "collection (zhao2021, zou2022)")
    return datasets


def _run_datasets(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``datasets``: every target checked (nothing replaced without --force), then written."""
    root = datasets_module.default_root() if args.out is None else Path(args.out)
    if args.out is None:
        check_output_dir(parser, "--out", root)
    for paper in args.papers:
        try:
            dataset_write.check_target(paper, root, args.force)
        except ValueError as error:
            fail(parser, "--out", str(error))
    rows = []
    for paper in args.papers:
        written = dataset_write.write_paper_dataset(paper, root, size=args.size, seed=args.seed,
                                                    force=args.force, progress=True,
                                                    use_cache=not args.no_cache)
        rows.append(dataset_write.written_summary(written))
        print(f"{written.dataset_id}: {written.n_samples} samples, "
              f"{written.size_bytes / 1e6:.2f} MB, collected in {written.collect_s:.1f} s, "
              f"written in {written.write_s:.2f} s", flush=True)
    print(markdown_table(rows))
    print(f"output directory: {root}")


# ------------------------------------------------------------------------------------- dispatch
class Command(NamedTuple):
    """One subcommand: ``add_parser(subparsers)`` adds and returns its parser; ``run(parser,
    args)`` checks what the parser cannot and does the work (``parser.error`` for one-line
    errors)."""

    add_parser: Callable[[Any], argparse.ArgumentParser]
    run: Callable[[argparse.ArgumentParser, argparse.Namespace], None]


COMMANDS: dict[str, Command] = {
    "benchmark": Command(_benchmark_parser, _run_benchmark),
    "estimation": Command(_estimation_parser, _run_estimation),
    "track": Command(_track_parser, _run_track),
    "ho2018": Command(_ho2018_parser, _run_ho2018),
    "zhao2021": Command(_zhao2021_parser, _run_zhao2021),
    "zou2022": Command(_zou2022_parser, _run_zou2022),
    "compare": Command(_compare_parser, _run_compare),
    "claims": Command(_claims_parser, _run_claims),
    "suite": Command(_suite_parser, _run_suite),
    "datasets": Command(_datasets_parser, _run_datasets),
    "results": Command(results_page.add_parser, results_page.run),
}
"""Subcommand name -> its parser and its work, in the order ``--help`` lists them."""

DISTINCT_OPTIONS = ("policies", "kp", "seeds", "paths", "conditions", "experiments", "baselines",
                    "papers", "claims")
"""List options whose values must not repeat (each run once)."""


def _check_distinct(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse (one line, exit 2) a list option that names a value twice."""
    for option in DISTINCT_OPTIONS:
        values = getattr(args, option, None)
        if isinstance(values, list) and len(set(values)) != len(values):
            parser.error(f"--{option} must be distinct (each run once), got {values}")


def main(argv: list[str] | None = None) -> None:
    """``python -m eval``: parse and check every option (one-line errors, exit 2), then run."""
    parser = argparse.ArgumentParser(prog="python -m eval", description=__doc__,
                                     formatter_class=HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    parsers = {name: command.add_parser(sub) for name, command in COMMANDS.items()}
    args = parser.parse_args(argv)
    command_parser = parsers[args.command]
    check_environment(command_parser)
    _check_distinct(command_parser, args)
    if args.out is not None:  # suite's default output directory is checked once the spec is read
        check_output_dir(command_parser, "--out", args.out)
    COMMANDS[args.command].run(command_parser, args)


if __name__ == "__main__":
    main()
