"""wang2023's dataset: Section IV-B's spiral calibration (FBG shifts, camera labels), as the Minari
dataset ``soft-arm/wang2023/calibration-v0`` (``python -m eval datasets wang2023``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from soft_gym.datasets.episodes import box_dict_space, procedure_episode
from eval.datasets.papers import (Collection, PaperDataset, absolute_actions, env_calibration_context,
                                 pressure_action_space, sample_count)
from soft_gym._validation import require_seed

WANG2023_ENV = ("SoftArmReachWang2023-v0",
                {"feedback": "ground_truth", "obs": ["pose", "target", "fbg", "pressure"]})


class _CommandLog:
    """A simulator that remembers the last pressures commanded (Pa); otherwise the simulator."""

    def __init__(self, sim) -> None:
        self._sim = sim
        self.last_command_pa = np.asarray(sim.pressures_pa, dtype=float).copy()

    def set_pressures(self, pressures_pa) -> None:
        self.last_command_pa = np.array(pressures_pa, dtype=float)
        self._sim.set_pressures(pressures_pa)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sim, name)


class _SampleLog:
    """A sensing pipeline that keeps every calibration step's readings, its camera label and
    the arm's ground truth; otherwise the pipeline."""

    def __init__(self, pipeline, sim: _CommandLog) -> None:
        self._pipeline, self._sim = pipeline, sim
        self.rows: list[dict[str, np.ndarray]] = []

    def calibration_sample(self, step: int, measurement):
        sample = self._pipeline.calibration_sample(step, measurement)
        position, quaternion = self._sim.tip_pose()
        label_p, label_q = ((np.full(3, np.nan), np.full(4, np.nan)) if sample is None
                            else (np.asarray(sample[1], float), np.asarray(sample[2], float)))
        self.rows.append({
            "fbg": np.array(measurement["fbg"], dtype=float),
            "command_pa": self._sim.last_command_pa.copy(),
            "pressures_pa": np.array(self._sim.pressures_pa, dtype=float),
            "tip_position_m": np.array(position, dtype=float),
            "tip_quaternion": np.array(quaternion, dtype=float),
            "backbone_m": np.array(self._sim.backbone(), dtype=float),
            "camera_label_position_m": label_p, "camera_label_quaternion": label_q,
            "labelled": np.array(float(sample is not None))})
        return sample

    def __getattr__(self, name: str) -> Any:
        return getattr(self._pipeline, name)


def collect_wang2023(size: dict[str, int], seed: int = 0, progress: bool = True,
                     use_cache: bool = True) -> Collection:
    """wang2023 Section IV-B's sensing calibration: the spiral exploration whose camera-labelled
    FBG shifts initialise F-emp, as ``fused`` feedback calibrates.

    :param size: ``n_init`` exploration steps (paper: 450).
    :param seed: seeds the sensors' noise (the calibration's own: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: unused (the calibration caches its model, not its steps).
    """
    from soft_gym.procedures.calibration import private_simulator
    from soft_gym.papers.wang2023.calibration import calibrate_pipeline
    from soft_gym.sensing import make_feedback_source
    from soft_gym.papers.wang2023.pipeline import SensingPipeline

    seed = require_seed("seed", seed)
    n_init = sample_count(size, "n_init", 10)
    env_id, env_kwargs = WANG2023_ENV
    context = env_calibration_context(env_id, env_kwargs)
    source = make_feedback_source("fused", {"n_init": n_init})
    pipeline = SensingPipeline(context.make_sensor("image"), context.make_sensor("fbg"),
                               **source.options)
    sim = private_simulator(context)
    try:
        sim.reset(settle_s=context.settle_s)
        logged_sim = _CommandLog(sim)
        log = _SampleLog(pipeline, logged_sim)
        labelled = calibrate_pipeline(log, logged_sim, np.random.default_rng(seed),
                                      progress=progress)
    finally:
        sim.close()
    columns = {key: np.stack([row[key] for row in log.rows]) for key in log.rows[0]}
    observations = {"fbg": columns.pop("fbg")}
    command = columns["command_pa"]
    episode = procedure_episode(absolute_actions(context.spec, command), observations, columns,
                                seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      pressure_action_space(context.spec),
                      "soft_gym.papers.wang2023.calibration.calibrate_pipeline",
                      {"n_init": n_init, "map_steps": pipeline.map_steps, "seed": seed,
                       "labelled_samples": int(labelled),
                       "control_period_s": context.spec.control_period_s},
                      raw=pipeline)


CARD: dict[str, str] = {
    "title": "wang2023 sensing calibration (Section IV-B)",
    "how": "The predefined spiral actuation, one command per control period, on a private "
           "simulator of the wang2023 arm at rest after the env's settle time; every step "
           "reads the helical FBG fiber and the eye-in-hand camera, whose ORB + PnP pose "
           "labels the FBG shifts when it trusts the frame. These labelled samples "
           "initialise F-emp (`fused`, `camera`, `fbg` feedback). The procedure is "
           "`soft_gym.papers.wang2023.calibration.calibrate_pipeline`.",
    "observations": "`fbg` (17,): Bragg wavelength shifts (nm).",
    "infos": "`command_pa` (3,) Pa; `pressures_pa` (3,) Pa, the chambers' pressures "
             "(lagging the command); `tip_position_m` (3,) m and `tip_quaternion` (4,) "
             "(x, y, z, w), true; `backbone_m` (n_links + 1, 3) m; "
             "`camera_label_position_m` (3,) m and `camera_label_quaternion` (4,), the "
             "camera's pose (NaN where it gave none); `labelled` (1 = used by F-emp).",
    "biases": "The camera labels are the vision tracker's, with its errors; frames it "
              "did not trust are unlabelled. The exploration covers the spiral only.",
}
"""The data card's text (:func:`eval.datasets.cards.paper_card`)."""


DATASET = PaperDataset(
    "wang2023", "soft-arm/wang2023/calibration-v0", collect_wang2023,
    {"n_init": 450}, {"n_init": 20},
    "spiral calibration: commands, FBG shifts, camera labels, true tip pose and backbone",
    card=CARD)
