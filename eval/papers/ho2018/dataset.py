"""ho2018's dataset: Section 3.2's pre-training walk of ``lwpr_rwr``, EM-tracked, as the Minari
dataset ``soft-arm/ho2018/pretraining-v0`` (``python -m eval datasets ho2018``)."""

from __future__ import annotations

import gymnasium as gym

from eval.datasets.episodes import EpisodeRecorder
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


DATASET = PaperDataset(
    "ho2018", "soft-arm/ho2018/pretraining-v0", collect_ho2018,
    {"pretrain_waypoints": 80}, {"pretrain_waypoints": 2},
    "pre-training walk: env actions, EM-feedback observations, true tip and backbone")
