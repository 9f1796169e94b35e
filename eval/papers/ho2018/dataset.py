"""ho2018's dataset: Section 3.2's pre-training walk of ``lwpr_rwr``, EM-tracked, as the Minari
dataset ``soft-arm/ho2018/pretraining-v0`` (``python -m eval datasets ho2018``)."""

from __future__ import annotations

import gymnasium as gym

from soft_gym.datasets.episodes import EpisodeRecorder
from eval.datasets.papers import Collection, PaperDataset, sample_count
from soft_gym._validation import require_seed

HO2018_ENV = ("SoftArmTrackHo2018-v0", {"feedback": "em"})


def collect_ho2018(size: dict[str, int], seed: int = 0, progress: bool = True,
                   use_cache: bool = True) -> Collection:
    """ho2018 Section 3.2's pre-training walk of ``lwpr_rwr``: straight lines between random
    actuator-space waypoints on an unloaded copy of the env, EM-tracked.

    :param size: ``pretrain_waypoints`` (paper: 80; 320 for the varying-load experiment).
    :param seed: ``lwpr_rwr``'s seed: the waypoints and the copy's reset (default: 0).
    :param progress: show the walk's progress bar.
    :param use_cache: unused (the pre-training caches its model, not its walk).
    """
    from agents.policies import make_policy

    import soft_gym  # noqa: F401 - registers the env ids

    seed = require_seed("seed", seed)
    waypoints = sample_count(size, "pretrain_waypoints", 2)
    env_id, env_kwargs = HO2018_ENV
    env = gym.make(env_id, **env_kwargs)
    sink: list[EpisodeRecorder] = []
    try:
        controller = make_policy("lwpr_rwr", env=env, pretrain_waypoints=waypoints, seed=seed,
                                 cache=False, progress=progress)
        transitions = controller._collect_pretraining_data(
            wrap_env=lambda walk_env: sink.append(EpisodeRecorder(walk_env)) or sink[-1])
        match = controller.walk_key()
    finally:
        env.close()
    recorder = sink[0]
    walk_spec = recorder.env.spec
    episode = recorder.episode_arrays(0)
    return Collection([episode], walk_spec.id, dict(walk_spec.kwargs),
                      recorder.observation_space, recorder.action_space,
                      "agents.controllers.lwpr_rwr.LWPRRWRController._collect_pretraining_data",
                      {"pretrain_waypoints": waypoints, "seed": seed,
                       "leg_decisions": controller.leg_decisions,
                       "hold_steps": controller.hold_steps,
                       "waypoint_range": controller.waypoint_range,
                       "rest_actuation": controller.rest_actuation,
                       "transitions": int(len(transitions[0]))},
                      raw=transitions, match=match)


CARD: dict[str, str] = {
    "title": "ho2018 pre-training walk (Section 3.2)",
    "how": "`lwpr_rwr`'s pre-training: on an unloaded, fault-free copy of the env "
           "(EM-tracker feedback), 20 control steps at the rest actuation, then straight "
           "lines of 30 decisions (2 control steps each) between random actuator-space "
           "waypoints (uniform in [0, 0.6] of every chamber's range). The LWPR forward "
           "model learns the transitions (p, u, du, dp) every `hold_steps` steps of this "
           "episode. Recorded as the env ran it.",
    "observations": "the env's flat observation: `pose` (7,), the EM tracker's tip "
                    "position (m) and quaternion; `target` (6,) m (the reach task's, not "
                    "used by the walk).",
    "infos": "`tip_position_m` (3,) m, `tip_quaternion` (4,), `backbone_m` (n, 3) m, "
             "`chamber_lengths_m` (6,) m, `pressures_pa` (6,) Pa, `target_m` (3,) m, "
             "`error_mm` mm, `time_s` s: the ground truth of every step (row 0: the reset).",
    "biases": "EM noise 0.8 mm / 0.7 deg; the arm is unloaded; waypoints cover only "
              "[0, 0.6] of each chamber's range.",
    "layout": "One Gymnasium episode as the env ran it: `observations` (steps + 1), "
              "`actions`, `rewards`, `terminations`, `truncations` (steps) and `infos` "
              "(steps + 1, row 0 from the reset). `recover_environment()` makes that env; "
              "`reset(seed=episode's seed)` and the actions give the observations back bit "
              "for bit.",
}
"""The data card's text (:func:`eval.datasets.cards.paper_card`)."""


DATASET = PaperDataset(
    "ho2018", "soft-arm/ho2018/pretraining-v0", collect_ho2018,
    {"pretrain_waypoints": 80}, {"pretrain_waypoints": 2},
    "pre-training walk: env actions, EM-feedback observations, true tip and backbone",
    card=CARD)
