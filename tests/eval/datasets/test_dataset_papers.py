"""eval.datasets.papers and write: each paper's dataset holds what the procedure's own
collection returns for the same seed, and its env is recovered."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401 - registers the ids
from eval.datasets import PAPER_DATASETS, load_dataset, write_paper_dataset
from eval.datasets.papers import env_calibration_context as _private_context
from eval.papers.wang2023.dataset import WANG2023_ENV
from eval.papers.zhao2021.dataset import ZHAO2021_ENV
from eval.papers.zou2022.dataset import ZOU2022_ENV
from soft_gym.robots.actuation import Actuation


def _written(paper: str, root, **size):
    written = write_paper_dataset(paper, root=root, size=size or "quick", progress=False,
                                  use_cache=False)
    start = time.perf_counter()
    dataset = load_dataset(written.dataset_id, root=root)
    env = dataset.recover_environment()
    assert time.perf_counter() - start < 2.0
    assert (written.path / "card.md").read_text().startswith(f"# {written.dataset_id}")
    return written, dataset, env


def _commands(env, actions: np.ndarray) -> np.ndarray:
    actuation = Actuation(env.unwrapped.arm, "absolute")
    return np.array([actuation.pressure(a) for a in actions])


def test_every_paper_has_a_dataset_id():
    assert sorted(PAPER_DATASETS) == ["ho2018", "wang2023", "zhao2021", "zou2022"]
    ids = [recipe.dataset_id for recipe in PAPER_DATASETS.values()]
    assert len(set(ids)) == 4 and all(i.startswith("soft-arm/") for i in ids)


def test_zhao2021_equals_the_exploration(tmp_path):
    from soft_gym.papers.zhao2021.exploration import collect_exploration

    written, dataset, env = _written("zhao2021", tmp_path, n_free=16, n_loaded=8)
    context = _private_context(*ZHAO2021_ENV)
    reference = collect_exploration(context.spec, context.make_sensor("strain"), n_free=16,
                                    n_loaded=8, seed=0, progress=False)
    episode = dataset[0]
    assert written.n_samples == 24 and np.isnan(episode.observations["strain"][0]).all()
    assert np.array_equal(episode.observations["strain"][1:], reference.readings)
    assert np.array_equal(episode.infos["backbone_m"][1:], reference.backbone_m)
    assert np.array_equal(episode.infos["command_pa"][1:], reference.pressures_pa)
    assert np.array_equal(np.asarray(episode.infos["tip_load_kg"][1:]), reference.tip_load_kg)
    np.testing.assert_allclose(_commands(env, episode.actions), reference.pressures_pa,
                               rtol=1e-6)
    assert env.spec.id == ZHAO2021_ENV[0] and "strain" in env.unwrapped.obs_parts
    env.close()


def test_zou2022_equals_the_data_set(tmp_path):
    from soft_gym.papers.zou2022.dataset import collect_dataset
    from soft_gym.sensing import make_feedback_source
    from soft_gym.sensors.stereo import StereoCamera

    _, dataset, env = _written("zou2022", tmp_path, n_samples=20)
    context = _private_context(*ZOU2022_ENV)
    source = make_feedback_source("encoder_dnn", {"n_samples": 20})
    reference = collect_dataset(context.spec, context.make_sensor("encoder"),
                                StereoCamera(**source.labelling_stereo_options()), source.config,
                                progress=False)
    episode = dataset[0]
    assert np.array_equal(episode.observations["encoder"][1:], reference.lengths_m)
    assert np.array_equal(episode.infos["stereo_labels_m"][1:], reference.labels_m,
                          equal_nan=True)
    assert np.array_equal(episode.infos["true_points_m"][1:], reference.truth_m)
    split = np.asarray(episode.infos["split"][1:])
    assert np.array_equal(np.flatnonzero(split == 2), reference.test)
    env.close()


def test_wang2023_equals_the_calibration(tmp_path):
    from soft_gym.procedures.calibration import private_simulator
    from soft_gym.papers.wang2023.calibration import calibrate_pipeline
    from soft_gym.sensing import make_feedback_source
    from soft_gym.papers.wang2023.pipeline import SensingPipeline

    _, dataset, env = _written("wang2023", tmp_path, n_init=15)
    context = _private_context(*WANG2023_ENV)
    pipeline = SensingPipeline(context.make_sensor("image"), context.make_sensor("fbg"),
                               **make_feedback_source("fused", {"n_init": 15}).options)
    sim = private_simulator(context)
    try:
        sim.reset(settle_s=context.settle_s)
        labelled = calibrate_pipeline(pipeline, sim, np.random.default_rng(0), progress=False)
        final_tip = sim.tip_pose()[0]
    finally:
        sim.close()
    episode = dataset[0]
    assert len(episode) == 15
    assert int(np.nansum(episode.infos["labelled"])) == labelled
    assert np.array_equal(episode.infos["tip_position_m"][-1], final_tip)
    assert np.isnan(episode.infos["camera_label_position_m"][
        np.asarray(episode.infos["labelled"]) == 0][1:]).all()
    env.close()


def test_ho2018_replays_bit_for_bit_and_equals_the_walk(tmp_path):
    from agents.policies import make_policy

    _, dataset, env = _written("ho2018", tmp_path, pretrain_waypoints=2)
    episode = dataset[0]
    seed = next(dataset.storage.get_episode_metadata([0]))["seed"]
    observation, _ = env.reset(seed=seed)
    replayed = [observation]
    for action in episode.actions:
        observation, *_ = env.step(action)
        replayed.append(observation)
    assert np.array_equal(np.array(replayed), episode.observations)
    # the transitions lwpr_rwr learns from, taken afresh without recording
    source = gym.make("SoftArmTrackHo2018-v0", feedback="em")
    controller = make_policy("lwpr_rwr", env=source, pretrain_waypoints=2, seed=0,
                             cache=False, progress=False)
    p, u, du, dp = controller._collect_pretraining_data()
    source.close()
    decisions = 20 + controller.hold_steps * np.arange(len(p))
    poses_mm = (episode.observations[decisions, :3] * 1000.0).astype(float)
    assert np.array_equal(poses_mm, p)
    env.close()


@pytest.mark.slow
def test_zhao2021_at_the_papers_size(tmp_path):
    written, dataset, env = _written("zhao2021", tmp_path, n_free=4000, n_loaded=2000)
    assert written.n_samples == 6000 and dataset.total_steps == 6000
    env.close()
