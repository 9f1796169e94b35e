"""zou2022's dataset: Section 5.1 (1)'s pressure sweep labelled by ASES on the stereo pair, as the
Minari dataset ``soft-arm/zou2022/stereo-labels-v0`` (``python -m eval datasets zou2022``)."""

from __future__ import annotations

import numpy as np

from soft_gym.datasets.episodes import box_dict_space, procedure_episode
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


CARD: dict[str, str] = {
    "title": "zou2022 ASES-labelled pressure sweep (Section 5.1 (1))",
    "how": "Distinct commands of the 0.1 bar grid (0-3 bar per muscle, 31^3 = 29791 "
           "commands) in random order on a private simulator, each held 2 s; the cable "
           "encoders' chamber lengths are read and the stereo pair's ASES (SOM centreline) "
           "labels seven backbone points. A sample where ASES lost the arm is replaced by "
           "a copy of a good one turned about the axis (the paper's supplement; "
           "`augmented`). Train / validation / test sets are dealt out by command "
           "(`split`). The procedure is `soft_gym.papers.zou2022.dataset`.",
    "observations": "`encoder` (3,): chamber lengths from the cable encoders (m).",
    "infos": "`command_pa` (3,) Pa; `stereo_labels_m` (7, 3) m, ASES's P_0..P_6 (the "
             "DNN's labels); `true_points_m` (7, 3) m, the simulator's P_0..P_6; "
             "`tip_position_m` (3,) m, true; `augmented` (1 = rotated copy); `split` "
             "(0 train, 1 validation, 2 test).",
    "biases": "The labels are ASES's, not the truth: they carry the stereo pair's "
              "triangulation and SOM errors (compare `true_points_m`). The simulated arm "
              "twists as its muscles fill (an assumed unbalanced braid). Augmented samples "
              "are copies, not measurements.",
}
"""The data card's text (:func:`eval.datasets.cards.paper_card`)."""


DATASET = PaperDataset(
    "zou2022", "soft-arm/zou2022/stereo-labels-v0", collect_zou2022,
    {"n_samples": 29791}, {"n_samples": 30},
    "pressure sweep: commands, encoder lengths, ASES stereo labels, true points, split",
    card=CARD)
