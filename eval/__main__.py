"""Command line of the benchmark runner.

    python -m eval estimation --experiments clean occlusion lighting --steps 4000 --out results/estimation
    python -m eval track --policies cc_model hybrid_gpr --kp 0.04 0.1 --path circle --out results/track

``benchmark`` (the README's main job): ``cc_model``, ``hybrid_gpr`` and the shipped SB3 agents on
the wang2023 circle, 3 cycles, with a 10 g tip load, fused camera/FBG feedback and a partly
occluding hand moving in front of the camera during the third cycle; prints the table, writes CSV,
JSON and plots (under 3 minutes on 2 cores, the runs spread over two processes).

``compare``: the SB3 agents against the baselines, nominal and out of distribution (see
``eval/compare.py``).

``estimation``: the wang2023 estimation experiments (camera, F-emp and fusion vs ground truth;
Figs. 6-7, Tables III, IV, VI). ``track``: baselines tracking a path on an arm preset, with loads,
visual faults and a feedback source, several gains and seeds; a Markdown table with mean +- std,
max, per cycle and the improvement over ``cc_model``, per-step CSVs and plots.

Every command ends by printing the output directory it wrote to (``--out``); its JSON summary
records the soft-arm-gym version that made it (``soft_arm_gym_version``). ``--video`` (``track``,
``benchmark``, ``compare``, ``estimation``) also writes an MP4 of each run next to its CSV (a GIF
where ffmpeg is absent): the scene with the target, path, loads, true tip and estimate, and the
camera sensors' frames beside it, one frame per control step (see ``eval/video.py``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
from pathlib import Path

from eval import compare as compare_module
from eval import estimation as estimation_module
from eval.estimation import EXPERIMENTS, run_experiments
from soft_gym._cli import HelpFormatter


DEFAULT_WORKERS = max(1, min(2, os.cpu_count() or 1))


def _track(args: argparse.Namespace) -> None:
    from eval.metrics import add_improvement, summarize, summary_table
    from eval.report import markdown_table, plot_error_time, plot_trajectory, \
        write_records_csv, write_results_json
    from eval.runner import RunConfig, run_many

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scenario = json.loads(args.scenario) if args.scenario else None
    faults = json.loads(args.faults) if args.faults else None
    rows, records = [], {}
    # an SB3 agent has no K_p: it runs once per seed
    runs = [(kp, seed, policy) for kp, seed, policy in itertools.product(args.kp, args.seeds,
                                                                          args.policies)
            if not (policy.startswith("sb3:") and kp != args.kp[0])]
    video = getattr(args, "video", False)
    configs = [RunConfig(
        policy=policy, policy_params={} if policy.startswith("sb3:") else {"kp": kp}, seed=seed,
        env_kwargs={"preset": args.preset, "path": args.path, "cycles": args.cycles,
                    "scenario": scenario, "faults": faults, "feedback": args.feedback},
        video_path=str(out / f"{_track_label(policy, kp, seed)}.mp4") if video else None)
        for kp, seed, policy in runs]
    print(f"{len(configs)} runs on {args.workers} worker(s)", flush=True)
    records_in_order = run_many(configs, workers=args.workers, progress=True)
    for (kp, seed, policy), config, record in zip(runs, configs, records_in_order):
        label = _track_label(policy, kp, seed)
        records[label] = record
        write_records_csv(out / f"{label}.csv", record)
        plot_trajectory(out / f"{label}_trajectory.png", record, label)
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
    plot_error_time(out / "error_time.png", records, f"{args.preset} {args.path}")
    write_results_json(out / "track.json", table)
    columns = ["policy", "kp", "seed", "track_mean_mm", "track_max_mm", "dev_mean_mm",
               "improvement_%", "track_last_cycle_mm", "dev_last_cycle_mm", "improvement_last_%",
               "dev_improvement_last_%"]
    text = markdown_table(table, columns=[c for c in columns if c in table[0]])
    (out / "track.md").write_text(text + "\n")
    print(text)


def _track_label(policy: str, kp: float, seed: int) -> str:
    """File stem of one track run's CSV, plots and video."""
    gain = "" if policy.startswith("sb3:") else f"_kp{kp}"
    return f"{compare_module.policy_label(policy)}{gain}_seed{seed}"


def _add_video_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--video", action="store_true",
                        help="also write an MP4 of each run next to its CSV (a GIF without "
                             "ffmpeg)")


def _agents_against_first_gain(table: list[dict], kp: float) -> None:
    """SB3 agents have no K_p: their improvement is over ``cc_model`` at the first gain."""
    from eval.metrics import improvement

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


def _check_seeds_and_baselines(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``--seeds`` >= 0 and ``--baselines`` known names or ``sb3:PATH``, before any work."""
    if any(seed < 0 for seed in args.seeds):
        parser.error(f"--seeds must be >= 0, got {args.seeds}")
    from agents.policies import BASELINES

    unknown = [name for name in args.baselines
               if name not in BASELINES and not name.startswith("sb3:")]
    if unknown:
        parser.error(f"--baselines must be names from {sorted(BASELINES)} or sb3:PATH, "
                     f"got {unknown}")


def _paper_parser(sub, name: str, module, help_text: str,
                  seeds_help: str) -> argparse.ArgumentParser:
    """The subcommand of one paper's experiments: ``--experiments`` among the module's
    ``EXPERIMENTS`` (default all) and ``--seeds``; its description is the module's docstring."""
    paper = sub.add_parser(name, help=help_text, description=module.__doc__,
                           formatter_class=HelpFormatter)
    paper.add_argument("--experiments", nargs="+", default=list(module.EXPERIMENTS),
                       choices=list(module.EXPERIMENTS), help="which experiments")
    paper.add_argument("--seeds", type=int, nargs="+", default=[0], help=seeds_help)
    return paper


def _suite(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``suite``: check every option and the spec before any run, run, report."""
    import sys

    from eval import suite as suite_module
    from eval import suite_report

    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    backend = args.backend
    if args.address is not None and args.backend != "ray":
        parser.error(f"--address is the Ray cluster of --backend ray, got --backend "
                     f"{args.backend}")
    if args.address is not None and not args.address.strip():
        parser.error("--address must be a Ray address (auto, ray://host:10001, host:6379), "
                     "got ''")
    if args.backend == "ray":
        from eval import suite_ray

        try:
            suite_ray.require_ray()
        except ImportError as error:
            parser.error(f"--backend ray: {error}")
        backend = suite_ray.make_ray_map(args.address)
    if args.seeds is not None and (any(seed < 0 for seed in args.seeds)
                                   or len(set(args.seeds)) != len(args.seeds)):
        parser.error(f"--seeds must be distinct integers >= 0, got {args.seeds}")
    if args.report_only and args.resume:
        parser.error("--resume runs the missing runs; --report-only runs none: give one")
    try:
        suite_report.require_rliable()
    except ImportError as error:
        parser.error(str(error))
    try:
        spec = suite_module.load_suite(args.spec)
        if args.seeds is not None:
            spec = spec.with_seeds(args.seeds)
        cells = (suite_module.expand(spec) if args.report_only
                 else suite_module.check_suite(spec, progress=True))
    except ValueError as error:
        parser.error(f"spec: {error}")
    out = Path(args.out or f"results/suite_{spec.name}")
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
                                   progress=True, check=False, backend=backend)
        except suite_module.SuiteRunError as error:
            failure = error
    print(suite_report.write_report(spec, out, cells=cells))
    if failure is not None:
        print(f"error: {failure}", file=sys.stderr)
    print(f"output directory: {out}")
    if failure is not None:
        raise SystemExit(1)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m eval", description=__doc__,
                                     formatter_class=HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    benchmark = sub.add_parser("benchmark", help="the small embedded default comparison",
                               formatter_class=HelpFormatter)
    benchmark.add_argument("--out", default="results/benchmark", help="output directory")
    benchmark.add_argument("--workers", type=int, default=DEFAULT_WORKERS,
                           help="runs in parallel processes (up to 2, one per core)")
    _add_video_flag(benchmark)
    estimation = sub.add_parser("estimation", help="wang2023 estimation experiments",
                                description=estimation_module.__doc__,
                                formatter_class=HelpFormatter)
    estimation.add_argument("--experiments", nargs="+", default=["clean"],
                            choices=list(EXPERIMENTS) + ["all"],
                            help="which runs ('all' for every one)")
    estimation.add_argument("--steps", type=int, default=4000,
                            help="control steps of 0.05 s per run (paper: ~4000)")
    estimation.add_argument("--seed", type=int, default=0, help="episode seed")
    estimation.add_argument("--out", default="results/estimation", help="output directory")
    _add_video_flag(estimation)
    track = sub.add_parser("track", help="baselines tracking a path",
                           formatter_class=HelpFormatter)
    track.add_argument("--policies", nargs="+", default=["cc_model", "hybrid_gpr"],
                       help="baseline names or sb3:PATH")
    track.add_argument("--kp", type=float, nargs="+", default=[0.06],
                       help="K_p gains of eq. (26) (paper: 0.04 0.06 0.08 0.10)")
    track.add_argument("--preset", default="wang2023", help="arm preset")
    track.add_argument("--path", default="circle", help="circle, pentagram, rectangle, spiral, star")
    track.add_argument("--cycles", type=int, default=3, help="path cycles per run")
    track.add_argument("--feedback", default="ground_truth",
                       help="pose feedback: fused, camera, fbg, em or ground_truth")
    track.add_argument("--scenario", default=None,
                       help='loads as JSON, e.g. \'{"name": "tip_mass", "mass_kg": 0.01}\'')
    track.add_argument("--faults", default=None,
                       help='visual faults as JSON, e.g. \'"wang2023_occlusion"\'')
    track.add_argument("--seeds", type=int, nargs="+", default=[0], help="episode seeds")
    track.add_argument("--out", default="results/track", help="output directory")
    track.add_argument("--workers", type=int, default=DEFAULT_WORKERS,
                       help="runs in parallel processes (up to 2, one per core)")
    _add_video_flag(track)
    from eval import ho2018 as ho2018_module

    ho2018 = _paper_parser(sub, "ho2018", ho2018_module,
                           "ho2018 static and varying tip-load experiments",
                           "seeds (pre-training waypoints and episode)")
    ho2018.add_argument("--cycle-s", type=float, default=None,
                        help="seconds per rectangle cycle (s); default: the experiment's own "
                             "(40 s static, 30 s varying)")
    ho2018.add_argument("--baselines", nargs="*", default=[],
                        help="further policies on the online run's load, e.g. cc_model "
                             "hybrid_gpr")
    ho2018.add_argument("--lead-in-s", type=float, default=15.0,
                        help="seconds tracking the first corner before recording (s)")
    ho2018.add_argument("--out", default="results/ho2018", help="output directory")
    from eval import zhao2021 as zhao2021_module

    zhao2021 = _paper_parser(sub, "zhao2021", zhao2021_module,
                             "zhao2021 shape reconstruction and local-IK control experiments",
                             "seeds (exploration, training and episodes)")
    zhao2021.add_argument("--samples", type=int, nargs=2, default=[4000, 2000],
                          metavar=("FREE", "LOADED"),
                          help="exploration samples free and with the 75 g tip (paper: 4000 "
                               "2000)")
    zhao2021.add_argument("--iterations", type=int, default=1000,
                          help="most training iterations of the networks (paper: 1000)")
    zhao2021.add_argument("--baselines", nargs="*", default=[],
                          help="further policies on the free point-to-point run and circle, "
                               "e.g. lwpr_rwr cc_model sb3:PATH")
    zhao2021.add_argument("--out", default="results/zhao2021", help="output directory")
    from eval import zou2022 as zou2022_module

    zou2022 = _paper_parser(sub, "zou2022", zou2022_module,
                            "zou2022 shape estimation (RSES, ASES, DNN) and control with each "
                            "shape source", "seeds (exploration, training, sensor noise, poses)")
    zou2022.add_argument("--samples", type=int, default=29791,
                         help="exploration samples of the DNN's data set (paper: 31^3 = 29791, "
                              "~25 min on one core, cached)")
    zou2022.add_argument("--epochs", type=int, default=500, help="DNN training epochs (paper: 500)")
    zou2022.add_argument("--poses", type=int, default=20,
                         help="random poses of the ASES fault experiment")
    zou2022.add_argument("--out", default="results/zou2022", help="output directory")
    compare = sub.add_parser(
        "compare", help="SB3 agents against the baselines, nominal and out of distribution",
        description=compare_module.__doc__, formatter_class=HelpFormatter)
    compare.add_argument("--policies", nargs="+", default=None,
                         help="baselines, sb3:PATH or shipped agent names as sb3:<name> "
                              "(default: cc_model, hybrid_gpr and every shipped agent)")
    compare.add_argument("--paths", nargs="+", default=["circle", "pentagram"],
                         help="paths to track")
    compare.add_argument("--conditions", nargs="+", default=list(compare_module.CONDITIONS),
                         choices=list(compare_module.CONDITIONS), help="test conditions")
    compare.add_argument("--seeds", type=int, nargs="+", default=[0, 1], help="episode seeds")
    compare.add_argument("--cycles", type=int, default=2, help="path cycles per run")
    compare.add_argument("--feedback", default="fused",
                         help="pose feedback of every policy: fused, camera, fbg, em, ground_truth")
    compare.add_argument("--kp", type=float, default=0.06, help="K_p of the CC baselines")
    compare.add_argument("--out", default="results/compare", help="output directory")
    compare.add_argument("--workers", type=int, default=DEFAULT_WORKERS,
                         help="runs in parallel processes (up to 2, one per core)")
    _add_video_flag(compare)
    from eval import suite as suite_module

    suite = sub.add_parser(
        "suite", help="the four-arm benchmark suite of a YAML spec: leaderboard, IQM with "
        "bootstrap CIs, performance profiles", description=suite_module.__doc__,
        formatter_class=HelpFormatter)
    suite.add_argument("spec", help="suite YAML file, or a bundled suite: "
                       f"{', '.join(suite_module.bundled_suites())}")
    suite.add_argument("--out", default=None,
                       help="output directory; default: results/suite_<suite name>")
    suite.add_argument("--workers", type=int, default=DEFAULT_WORKERS,
                       help="runs in parallel processes (up to 2, one per core)")
    suite.add_argument("--resume", action="store_true",
                       help="skip the runs whose record is already in the output directory")
    suite.add_argument("--seeds", type=int, nargs="+", default=None,
                       help="episode seeds replacing the suite's own")
    suite.add_argument("--report-only", action="store_true",
                       help="run nothing: write the report from the records there")
    suite.add_argument("--backend", default="process", choices=["process", "serial", "ray"],
                       help="where the runs go: --workers spawned processes, this process, or "
                            "Ray tasks (a local Ray of --workers CPUs, or the cluster at "
                            "--address; optional extra: pip install \"soft-arm-gym[ray]\")")
    suite.add_argument("--address", default=None, metavar="ADDR",
                       help="with --backend ray: an existing Ray cluster (auto, "
                            "ray://host:10001, host:6379); the package must be importable on "
                            "every node. Default: a local Ray")
    args = parser.parse_args(argv)
    if args.command == "suite":
        _suite(suite, args)
        return
    if args.command == "ho2018":
        for option, value, low in (("--cycle-s", args.cycle_s, 5.0),
                                   ("--lead-in-s", args.lead_in_s, 0.0)):
            if value is not None and (not value >= low or value > 3600):
                parser.error(f"{option} must be within [{low:g}, 3600] s, got {value!r}")
        _check_seeds_and_baselines(parser, args)
        try:
            ho2018_module.check_baselines(tuple(args.baselines))
        except ValueError as error:
            parser.error(f"--baselines: {error}")
        ho2018_module.run_and_report(args.experiments, args.seeds, args.out,
                                     cycle_s=args.cycle_s, lead_in_s=args.lead_in_s,
                                     baselines=tuple(args.baselines))
        print(f"output directory: {args.out}")
        return
    if args.command == "zhao2021":
        free, loaded = args.samples
        if free < 0 or loaded < 0 or free + loaded < 24:
            parser.error(f"--samples must be two counts >= 0 adding up to >= 24, got "
                         f"{args.samples}")
        if args.iterations < 1:
            parser.error(f"--iterations must be >= 1, got {args.iterations}")
        _check_seeds_and_baselines(parser, args)
        from soft_gym.sensing.shape_reconstruction import ReconstructionConfig

        config = ReconstructionConfig(n_free=free, n_loaded=loaded,
                                      max_iterations=args.iterations)
        zhao2021_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                       baselines=tuple(args.baselines))
        print(f"output directory: {args.out}")
        return
    if args.command == "zou2022":
        for option, value, low in (("--samples", args.samples, 20), ("--epochs", args.epochs, 1),
                                   ("--poses", args.poses, 1)):
            if value < low:
                parser.error(f"{option} must be >= {low}, got {value}")
        if any(seed < 0 for seed in args.seeds):
            parser.error(f"--seeds must be >= 0, got {args.seeds}")
        from soft_gym.sensing.shape_dnn import ShapeDNNConfig

        config = ShapeDNNConfig(n_samples=args.samples, epochs=args.epochs)
        zou2022_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                      n_poses=args.poses)
        print(f"output directory: {args.out}")
        return
    if args.command == "compare":
        from agents.policies import shipped_agents

        policies = args.policies or (["cc_model", "hybrid_gpr"]
                                     + [f"sb3:{name}" for name in shipped_agents()])
        if args.feedback not in ("fused", "camera") and "occlusion" in args.conditions:
            parser.error("the occlusion condition needs camera feedback: --feedback fused or "
                         f"camera, got {args.feedback!r}")
        rows = compare_module.run_comparison(
            policies, args.paths, args.conditions, args.seeds, args.out, cycles=args.cycles,
            feedback=args.feedback, kp=args.kp, workers=args.workers,
            **({"video": True} if args.video else {}))
        from eval.report import markdown_table

        print(markdown_table(rows, float_format="{:.2f}"))
        print(f"output directory: {args.out}")
        return
    if args.command == "benchmark":
        from agents.policies import shipped_agents

        occluder = {"name": "moving_occluder", "mode": "partial", "strength": 0.8,
                    "start_s": 40.0}
        args = argparse.Namespace(
            policies=["cc_model", "hybrid_gpr"] + [f"sb3:{name}" for name in shipped_agents()],
            kp=[0.06], preset="wang2023", path="circle",
            cycles=3, feedback="fused", scenario=json.dumps({"name": "tip_mass", "mass_kg": 0.01}),
            faults=json.dumps(occluder), seeds=[0], out=args.out, workers=args.workers,
            video=args.video)
        _track(args)
    elif args.command == "estimation":
        if args.steps < 600:
            parser.error(f"--steps must be >= 600 (the F-emp calibration alone takes 450), "
                         f"got {args.steps}")
        experiments = list(EXPERIMENTS) if "all" in args.experiments else args.experiments
        rows = run_experiments(experiments, args.out, steps=args.steps, seed=args.seed,
                               **({"video": True} if args.video else {}))
        from eval.report import markdown_table

        print(markdown_table(rows, float_format="{:.2f}"))
    else:
        _track(args)
    print(f"output directory: {args.out}")


if __name__ == "__main__":
    main()
