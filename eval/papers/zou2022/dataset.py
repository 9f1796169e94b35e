"""zou2022's dataset: Section 5.1 (1)'s pressure sweep labelled by ASES on the stereo pair, as the
Minari dataset ``soft-arm/zou2022/stereo-labels-v0`` (``python -m eval datasets zou2022``)."""

from __future__ import annotations

import numpy as np

from eval.datasets.episodes import box_dict_space, procedure_episode
from eval.datasets.papers import (Collection, PaperDataset, absolute_actions, env_calibration_context,
                                 pressure_action_space, sample_count)
from soft_gym._validation import require_seed

ZOU2022_ENV = ("SoftArmReachZou2022-v0",
               {"feedback": "ground_truth", "obs": ["pose", "target", "encoder", "pressure"]})
SPLITS = ("train", "validation", "test")
"""``infos["split"]``: 0, 1, 2 for the DNN's training, validation and test sets."""


def collect_zou2022(size: dict[str, int], seed: int = 0, progress: bool = True,
                    use_cache: bool = True) -> Collection:
    """zou2022 Section 5.1 (1)'s pressure sweep, labelled by ASES on the stereo pair.

    :param size: ``n_samples`` commands of the 0.1 bar grid (paper: 29791, each once).
    :param seed: seeds the sweep's order, the sensors' noise and the split (``encoder_dnn``'s
        default: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: take the data set from the calibration cache where ``encoder_dnn``
        already built it, and keep it there.
    """
    from soft_gym.papers.zou2022.dataset import cached_dataset, dataset_key
    from soft_gym.sensing import make_feedback_source
    from soft_gym.sensors.stereo import StereoCamera

    seed = require_seed("seed", seed)
    n_samples = sample_count(size, "n_samples", 10)
    env_id, env_kwargs = ZOU2022_ENV
    context = env_calibration_context(env_id, env_kwargs)
    source = make_feedback_source("encoder_dnn", {"n_samples": n_samples, "seed": seed})
    stereo = StereoCamera(**source.labelling_stereo_options())
    encoders = context.make_sensor("encoder")
    data = cached_dataset(context.spec, encoders, stereo, source.config, use_cache=use_cache,
                          progress=progress)
    split = np.full(len(data), -1.0)
    for index, name in enumerate(SPLITS):
        split[getattr(data, name)] = index
    observations = {"encoder": data.lengths_m}
    episode = procedure_episode(
        absolute_actions(context.spec, data.pressures_pa), observations,
        {"command_pa": data.pressures_pa, "stereo_labels_m": data.labels_m,
         "true_points_m": data.truth_m, "tip_position_m": data.truth_m[:, -1],
         "augmented": data.augmented.astype(float), "split": split}, seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      pressure_action_space(context.spec),
                      "soft_gym.papers.zou2022.dataset.collect_dataset",
                      {"n_samples": n_samples, "seed": seed, "n_lost": int(data.n_lost),
                       "settle_s": source.config.settle_s,
                       "pressure_step_pa": source.config.pressure_step_pa}, raw=data,
                      match=dataset_key(context.spec, encoders, stereo, source.config))


DATASET = PaperDataset(
    "zou2022", "soft-arm/zou2022/stereo-labels-v0", collect_zou2022,
    {"n_samples": 29791}, {"n_samples": 30},
    "pressure sweep: commands, encoder lengths, ASES stereo labels, true points, split")
