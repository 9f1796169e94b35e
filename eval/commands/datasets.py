"""``python -m eval datasets``: each paper's exploration or calibration data written as a Minari
dataset (:mod:`eval.datasets`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from eval import datasets as datasets_module
from eval.datasets import write as dataset_write
from eval.report import markdown_table
from soft_gym._cli import HelpFormatter, check_output_dir, fail, seed_int


DATASETS_DESCRIPTION = (
    "Write each paper's exploration or calibration data as a Minari dataset "
    "(soft-arm/<paper>/<name>-v0): the commands, the raw readings the method learns from and "
    "the ground truth, with the env that produced them recoverable "
    "(dataset.recover_environment()). Ids: " + ", ".join(
        f"{paper} {recipe.dataset_id}" for paper, recipe in datasets_module.PAPER_DATASETS.items())
    + ". Load one with minari.load_dataset(ID) (with MINARI_DATASETS_PATH=OUT when --out is "
    "given) or eval.datasets.load_dataset(ID, root=OUT). Fields, units and data cards: "
    "README.md (Datasets) and docs/datasets.md; each dataset's card.md sits beside its data/.")


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``datasets`` subcommand's parser."""
    datasets = sub.add_parser(
        "datasets", help="the papers' exploration and calibration data as Minari datasets",
        description=DATASETS_DESCRIPTION, formatter_class=HelpFormatter)
    papers = list(datasets_module.PAPER_DATASETS)
    datasets.add_argument("--papers", nargs="+", choices=papers, default=papers,
                          help="papers whose datasets to write")
    datasets.add_argument("--size", choices=list(dataset_write.SIZES), default="paper",
                          help="the papers' sample counts ("
                               + "; ".join(f"{paper} " + ", ".join(
                                   f"{key}={value}" for key, value in recipe.paper_size.items())
                                   for paper, recipe in datasets_module.PAPER_DATASETS.items())
                               + "; minutes to an hour), or quick ones (seconds)")
    datasets.add_argument("--seed", type=seed_int, default=0,
                          help="the procedures' seed (0: the one the baselines calibrate with)")
    datasets.add_argument("--out", default=None,
                          help="datasets root (made; must be writable); default: Minari's "
                               "(MINARI_DATASETS_PATH, else ~/.minari/datasets)")
    datasets.add_argument("--force", action="store_true",
                          help="replace datasets that exist (otherwise refused before any work)")
    datasets.add_argument("--no-cache", action="store_true",
                          help="collect afresh even where the calibration cache holds the "
                               "collection")
    return datasets


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
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
