"""zhao2021's dataset: Section VI-A's random exploration with the env's strain gauges, as the
Minari dataset ``soft-arm/zhao2021/exploration-v0`` (``python -m eval datasets zhao2021``)."""

from __future__ import annotations

from soft_gym.datasets.episodes import box_dict_space, procedure_episode
from eval.datasets.papers import (Collection, PaperDataset, absolute_actions, env_calibration_context,
                                 pressure_action_space, sample_count)
from soft_gym._validation import require_seed

ZHAO2021_ENV = ("SoftArmReachZhao2021-v0",
                {"feedback": "ground_truth", "obs": ["pose", "target", "strain", "pressure"]})


def collect_zhao2021(size: dict[str, int], seed: int = 0, progress: bool = True,
                     use_cache: bool = True) -> Collection:
    """zhao2021 Section VI-A's random exploration with the env's strain gauges.

    :param size: ``n_free`` and ``n_loaded`` samples (paper: 4000 and 2000).
    :param seed: seeds the walk and the gauges' noise (``strain_sr``'s default: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: take the exploration from the calibration cache where ``strain_sr`` or
        ``local_ik_asdm`` already ran it (the same record), and keep it there.
    """
    from soft_gym.papers.zhao2021.exploration import exploration_key, exploration_of
    from soft_gym.sensing import make_feedback_source

    seed = require_seed("seed", seed)
    n_free, n_loaded = sample_count(size, "n_free", 0), sample_count(size, "n_loaded", 0)
    env_id, env_kwargs = ZHAO2021_ENV
    context = env_calibration_context(env_id, env_kwargs)
    config = make_feedback_source("strain_sr", {"n_free": n_free, "n_loaded": n_loaded,
                                                "seed": seed}).config
    gauges = context.make_sensor("strain")
    data = exploration_of(context.spec, gauges, config, use_cache=use_cache, progress=progress)
    observations = {"strain": data.readings}
    episode = procedure_episode(
        absolute_actions(context.spec, data.pressures_pa), observations,
        {"command_pa": data.pressures_pa, "tip_position_m": data.backbone_m[:, -1],
         "key_points_m": data.key_points_m, "backbone_m": data.backbone_m,
         "tip_load_kg": data.tip_load_kg}, seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      pressure_action_space(context.spec),
                      "soft_gym.papers.zhao2021.exploration.collect_exploration",
                      {"n_free": n_free, "n_loaded": n_loaded, "load_kg": config.load_kg,
                       "seed": seed, "settle_s": 1.0}, raw=data,
                      match=exploration_key(context.spec, gauges, config.n_free, config.n_loaded,
                                            config.load_kg, config.seed))


CARD: dict[str, str] = {
    "title": "zhao2021 random exploration (Section VI-A)",
    "how": "A random walk in pressure space on a private simulator of the zhao2021 arm: "
           "each sample adjusts two random chambers by +-1/16 of p_max (0.05 bar), holds "
           "the command 1 s and reads the strain gauges and the backbone. The first "
           "`n_free` samples are taken with the arm free, the next `n_loaded` with a 75 g "
           "tip mass (the same walk continues). This is the record `strain_sr` and "
           "`local_ik_asdm` learn from, taken by the procedure that builds them "
           "(`soft_gym.papers.zhao2021.exploration`), so the calibration cache shares it.",
    "observations": "`strain` (6,): the strain gauges' readings (3 per segment, the sensor's "
                    "units: bending strain with the gauges' noise).",
    "infos": "`command_pa` (6,) Pa; `tip_position_m` (3,) m; `key_points_m` (6, 3) m, "
             "zhao2021's P_1..P_6; `backbone_m` (n_links + 1, 3) m; `tip_load_kg` kg.",
    "biases": "The arm is simulated (2 x 4 rigid links, thread-limited bores); gauges "
              "read the simulated curvature with Gaussian noise, no drift or hysteresis. "
              "The walk never leaves [p_pre, p_max]; the loaded half follows the free half "
              "without a reset.",
}
"""The data card's text (:func:`eval.datasets.cards.paper_card`)."""


DATASET = PaperDataset(
    "zhao2021", "soft-arm/zhao2021/exploration-v0", collect_zhao2021,
    {"n_free": 4000, "n_loaded": 2000}, {"n_free": 40, "n_loaded": 20},
    "random exploration: commands, strain-gauge readings, key points, backbone, tip load",
    card=CARD)
