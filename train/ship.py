"""Copy a trained run into the repository as a shipped agent (``agents/trained/<name>/``).

    python -m train.ship results/train/sac_wang2023_track sac_wang2023_track --model best

Only what loading and provenance need is kept: the model, its VecNormalize statistics, the
resolved config, versions, the training summary and the learning curve (no replay buffer or
checkpoints, so the repository stays small).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from agents.policies import SHIPPED_DIR, mark_model_file, model_normalization_mark
from soft_gym._cli import HelpFormatter
from train.trainer import (BEST_MODEL_FILE, BEST_NORMALIZATION_FILE, MODEL_FILE,
                           NORMALIZATION_FILE)


def ship(run_dir: str | Path, name: str, model: str = "final",
         destination: str | Path = SHIPPED_DIR) -> Path:
    """Copy ``run_dir``'s final or best model with its provenance to ``destination/name``."""
    run_dir = Path(run_dir)
    if model not in ("final", "best"):
        raise ValueError(f"model must be 'final' or 'best', got {model!r}")
    model_file, normalization_file = ((MODEL_FILE, NORMALIZATION_FILE) if model == "final" else
                                      (BEST_MODEL_FILE, BEST_NORMALIZATION_FILE))
    if not (run_dir / model_file).is_file() or not (run_dir / "config.yaml").is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} holds no {model_file} with a config.yaml")
    target = Path(destination) / name
    target.mkdir(parents=True, exist_ok=True)
    shutil.copy(run_dir / model_file, target / MODEL_FILE)
    normalized = (run_dir / normalization_file).is_file()
    if normalized:
        shutil.copy(run_dir / normalization_file, target / NORMALIZATION_FILE)
    if model_normalization_mark(target / MODEL_FILE) is None:  # a model saved before the mark
        mark_model_file(target / MODEL_FILE, normalized)
    for extra in ("config.yaml", "versions.yaml", "training.yaml", "learning_curve.png"):
        if (run_dir / extra).is_file():
            shutil.copy(run_dir / extra, target / extra)
    (target / "source.txt").write_text(f"{model} model of run {run_dir.name}\n")
    return target


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m train.ship", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.add_argument("run_dir", help="a run directory of python -m train")
    parser.add_argument("name", help="the shipped agent's name (sb3:<name> loads it)")
    parser.add_argument("--model", choices=("final", "best"), default="final",
                        help="the final model or the best evaluated one")
    args = parser.parse_args(argv)
    try:
        print(ship(args.run_dir, args.name, args.model))
    except ValueError as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
