"""Evaluation curves that decide when training stops: the agent's mean last-cycle tracking error
on a fixed set of paths and loads, every ``curve_freq`` env steps, and the plateau rule.

A run trained with ``--curve-freq N`` (``TrainRequest.curve_freq``) evaluates the live model
every ``N`` env steps on :func:`evaluation_cases` (each of the recipe's paths, nominal and with
a tip mass at the middle of the recipe's randomised range; two cycles each, deterministic
actions, the training engine, reset seed :data:`CURVE_SEED`) and writes one row per evaluation
to ``eval/tracking_curve.csv``: env steps, wall time (s), the mean of the cases' last-cycle mean
errors (mm) and each case's. The model with the lowest mean is kept as
``best_tracking_model.zip`` (with its normalisation statistics,
:func:`agents.policies.run_dir.normalization_file`). With ``until_plateau``
training stops once :func:`has_plateaued`: the last ``fraction`` (20 %) of the steps so far
lowered the best error by under ``min_improvement`` (5 %) of it, so the budget comes from the
curve, not from a time limit; ``--timesteps`` is then the most it may take.
``train.curves.plot_tracking_curve`` draws ``tracking_curve.png`` from the CSV.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from agents.policies.run_dir import BEST_TRACKING_MODEL_FILE, normalization_file
from agents.policies.sb3 import SB3Policy
from agents.rollout import run_episode
from agents.tracking_error import last_cycle_error_mm
from soft_gym.scenarios.randomization import RandomizationConfig

CURVE_FILE = "eval/tracking_curve.csv"
CURVE_SEED = 777
"""Reset seed of every evaluation episode (apart from the training and SB3 evaluation seeds)."""
CURVE_CYCLES = 2
"""Cycles of the path per evaluation episode; the last one is scored, as in the suites."""
PLATEAU_FRACTION = 0.2
PLATEAU_IMPROVEMENT = 0.05
MIN_EVALUATIONS = 5
"""Evaluations before the plateau rule may stop a run."""


@dataclass(frozen=True)
class EvaluationCase:
    """One episode of the evaluation set: a label and env keyword arguments over the
    recipe's (the randomisation removed)."""

    label: str
    env_kwargs: dict = field(default_factory=dict)


def _paths(env_kwargs: dict) -> list[str | None]:
    path = env_kwargs.get("path")
    if path is None:
        return [None]
    return [path] if isinstance(path, str) else list(path)


def _middle_tip_mass_kg(randomization: Any) -> float | None:
    """The middle of the recipe's randomised tip-mass range (kg), ``None`` without
    randomisation or where it draws no tip masses."""
    config = RandomizationConfig.from_any(randomization)
    if config is None or not config.load_weights.get("tip_mass", 0.0):
        return None
    middle = 0.5 * (config.tip_mass_kg[0] + config.tip_mass_kg[1])
    return middle if middle > 0 else None


def evaluation_cases(env_kwargs: dict, arm_variants: list[dict] | None = None
                     ) -> list[EvaluationCase]:
    """The fixed evaluation set of a recipe's env keyword arguments: each of its paths (one
    drawn per training episode), nominal and, where training randomises loads, with a tip mass
    at the middle of the randomised range (a load seen in training, not a held-out one).

    Args:
        env_kwargs: the recipe's env keyword arguments.
        arm_variants: where the arms of the batch differ (the recipe's ``arm_env_kwargs``,
            :meth:`train.config.TrainSettings.arm_variants`), the set for each distinct arm's
            keyword arguments over ``env_kwargs``, its labels led by the arm's
            (``feedback=...``).

    Returns:
        The evaluation cases, each with its label and env keyword arguments.
    """
    variants = arm_variants or [{}]
    cases = []
    for variant in variants:
        merged = {**env_kwargs, **variant}
        mass = _middle_tip_mass_kg(merged.get("randomization"))
        prefix = f"{variant_label(variant)} " if len(variants) > 1 else ""
        arm = {key: value for key, value in variant.items() if key != "randomization"}
        for path in _paths(merged):
            base = arm if path is None else {**arm, "path": path}
            name = prefix + (path or "default")
            cases.append(EvaluationCase(f"{name} nominal", base))
            if mass is not None:
                cases.append(EvaluationCase(
                    f"{name} {mass * 1000:g} g",
                    {**base, "scenario": {"name": "tip_mass", "mass_kg": mass}}))
    return cases


def variant_label(variant: dict) -> str:
    """A short label of an arm's keyword arguments: its plain values as ``key=value`` (e.g.
    ``feedback=encoder_dnn``), the keys of the others."""
    parts = [f"{key}={value}" if isinstance(value, (str, int, float)) else key
             for key, value in variant.items()]
    return " ".join(parts) or "base"


def has_plateaued(timesteps: np.ndarray, errors_mm: np.ndarray,
                  fraction: float = PLATEAU_FRACTION,
                  min_improvement: float = PLATEAU_IMPROVEMENT,
                  min_evaluations: int = MIN_EVALUATIONS) -> bool:
    """Whether the curve has flattened: the best error over all evaluations is less than
    ``min_improvement`` (relative) below the best over those in the first ``1 - fraction`` of
    the steps so far.

    Args:
        timesteps: env steps of each evaluation, increasing.
        errors_mm: the evaluations' errors (mm), lower is better.
        fraction: the share of the latest steps whose improvement is judged (0.2: the last
            20 %).
        min_improvement: the relative improvement under which the curve is flat (0.05).
        min_evaluations: no plateau before this many evaluations.

    Returns:
        Whether the curve has flattened.
    """
    timesteps, errors_mm = np.asarray(timesteps, float), np.asarray(errors_mm, float)
    if len(errors_mm) < min_evaluations:
        return False
    earlier = errors_mm[timesteps <= (1.0 - fraction) * timesteps[-1]]
    if len(earlier) == 0:
        return False
    best_before, best_now = float(earlier.min()), float(errors_mm.min())
    return best_before - best_now < min_improvement * best_before


class TrackingCurveCallback(BaseCallback):
    """Evaluate the live model on ``cases`` every ``curve_freq`` env steps (see the module).

    Args:
        env_id: the training env's id.
        env_kwargs: the training env's keyword arguments (the randomisation is removed).
        cases: the evaluation set (:func:`evaluation_cases`).
        curve_freq: env steps between evaluations, >= 1.
        run_dir: the run directory (the CSV and the best model go there).
        until_plateau: stop training once :func:`has_plateaued`.
        fraction: the plateau rule's share of the latest steps.
        min_improvement: the plateau rule's relative improvement.
        min_timesteps: env steps before the plateau rule may stop training (a curve flat at
            the start, before learning takes hold, is not a plateau).
        evaluate_at_start: also evaluate before the first step (a run started from a trained
            agent: the curve then shows where it began, and the starting model is the best
            until training beats it).
    """

    def __init__(self, env_id: str, env_kwargs: dict, cases: list[EvaluationCase],
                 curve_freq: int, run_dir: str | Path, until_plateau: bool = False,
                 fraction: float = PLATEAU_FRACTION,
                 min_improvement: float = PLATEAU_IMPROVEMENT, min_timesteps: int = 0,
                 evaluate_at_start: bool = False) -> None:
        super().__init__()
        self.env_id, self.cases = env_id, list(cases)
        self.env_kwargs = {key: value for key, value in env_kwargs.items()
                           if key != "randomization"}
        self.curve_freq, self.run_dir = int(curve_freq), Path(run_dir)
        self.until_plateau, self.fraction = until_plateau, fraction
        self.min_improvement, self.min_timesteps = min_improvement, int(min_timesteps)
        self.evaluate_at_start = evaluate_at_start
        self.timesteps: list[int] = []
        self.errors_mm: list[float] = []
        self.plateaued = False
        self.evaluation_s = 0.0  # wall time spent evaluating (not training)
        self._next = 0
        self._started = time.perf_counter()

    def _on_training_start(self) -> None:
        self._next = self.num_timesteps + self.curve_freq
        self.timesteps, self.errors_mm = read_curve(self.run_dir)  # a resumed run continues
        if self.evaluate_at_start and not self.timesteps:
            self._record()

    def _on_step(self) -> bool:
        if self.num_timesteps < self._next:
            return True
        self._next = self.num_timesteps + self.curve_freq
        self._record()
        if (self.until_plateau and self.num_timesteps >= self.min_timesteps
                and has_plateaued(np.array(self.timesteps),
                                  np.array(self.errors_mm), self.fraction,
                                  self.min_improvement)):
            self.plateaued = True
            return False
        return True

    def _record(self) -> None:
        """Evaluate now, write the row and keep the model if it is the best so far."""
        started = time.perf_counter()
        errors = self.evaluate()
        self.evaluation_s += time.perf_counter() - started
        mean = float(np.mean(list(errors.values())))
        self._write_row(mean, errors)
        if not self.errors_mm or mean < min(self.errors_mm):
            self._save_best()
        self.timesteps.append(self.num_timesteps)
        self.errors_mm.append(mean)

    def evaluate(self) -> dict[str, float]:
        """Each case's last-cycle mean tracking error (mm) with the live model."""
        policy = SB3Policy(self.model, self.model.get_vec_normalize_env())
        errors = {}
        for case in self.cases:
            env = gym.make(self.env_id, **{**self.env_kwargs, **case.env_kwargs,
                                           "cycles": CURVE_CYCLES})
            try:
                errors[case.label] = last_cycle_error_mm(
                    run_episode(env, policy, seed=CURVE_SEED, learn=False))
            finally:
                env.close()
        return errors

    def _write_row(self, mean: float, errors: dict[str, float]) -> None:
        path = self.run_dir / CURVE_FILE
        path.parent.mkdir(parents=True, exist_ok=True)
        new = not path.exists()
        with open(path, "a", newline="") as handle:
            writer = csv.writer(handle)
            if new:
                writer.writerow(["timesteps", "wall_s", "mean_last_cycle_mm",
                                 *[f"{label} (mm)" for label in errors]])
            writer.writerow([self.num_timesteps,
                             round(time.perf_counter() - self._started, 1), f"{mean:.4f}",
                             *[f"{value:.4f}" for value in errors.values()]])

    def _save_best(self) -> None:
        path = self.run_dir / BEST_TRACKING_MODEL_FILE
        self.model.save(str(path))
        normalization = self.model.get_vec_normalize_env()
        if normalization is not None:  # where sb3:PATH looks for the model's statistics
            normalization.save(str(normalization_file(path)))


def read_curve(run_dir: str | Path) -> tuple[list[int], list[float]]:
    """The env steps and mean last-cycle errors (mm) of ``run_dir``'s tracking curve (empty
    lists when it has none)."""
    path = Path(run_dir) / CURVE_FILE
    if not path.exists():
        return [], []
    with open(path) as handle:
        rows = list(csv.DictReader(handle))
    return ([int(row["timesteps"]) for row in rows],
            [float(row["mean_last_cycle_mm"]) for row in rows])
