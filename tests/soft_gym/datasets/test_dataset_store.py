"""soft_gym.datasets.store and episodes: a round trip of a recorded episode (write, load, recover
the env, replay the actions, the observations back bit for bit), and every bad input as one
ValueError naming it."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401 - registers the ids
from eval.__main__ import main
from soft_gym.datasets.episodes import EpisodeRecorder
from soft_gym.datasets.store import list_datasets, load_dataset, write_dataset
from tests.cli_errors import assert_one_line_error

ENV_ID = "SoftArmReachWang2023-v0"
ENV_KWARGS = {"feedback": "ground_truth", "episode_steps": 15}
DATASET_ID = "soft-arm/test/round-trip-v0"


def _write_random_episodes(root: Path, dataset_id: str = DATASET_ID, force: bool = False,
                           seeds=(3, 4)) -> EpisodeRecorder:
    """Two episodes of random actions on ground-truth feedback, written under ``root``."""
    recorder = EpisodeRecorder(gym.make(ENV_ID, **ENV_KWARGS))
    rng = np.random.default_rng(0)
    for seed in seeds:
        recorder.reset(seed=seed)
        done = False
        while not done:
            action = rng.uniform(-1, 1, recorder.action_space.shape).astype(np.float32)
            _, _, terminated, truncated, _ = recorder.step(action)
            done = terminated or truncated
    recorder.close()
    write_dataset(dataset_id, recorder.buffers(), env_id=ENV_ID, env_kwargs=ENV_KWARGS,
                  observation_space=recorder.observation_space,
                  action_space=recorder.action_space, description="random actions",
                  algorithm_name="random", card="# test\n", root=root, force=force,
                  episode_metadata=[{"policy": "random"} for _ in seeds])
    return recorder


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, EpisodeRecorder]:
    root = tmp_path_factory.mktemp("datasets")
    return root, _write_random_episodes(root)


def test_round_trip_replays_bit_for_bit(written):
    root, recorder = written
    start = time.perf_counter()
    dataset = load_dataset(DATASET_ID, root=root)
    env = dataset.recover_environment()
    elapsed = time.perf_counter() - start
    assert elapsed < 2.0, f"load + recover took {elapsed:.2f} s"
    assert env.spec.id == ENV_ID and env.spec.kwargs["feedback"] == "ground_truth"
    assert dataset.total_episodes == 2 and dataset.total_steps == 30
    for index, episode in enumerate(dataset.iterate_episodes()):
        seed = dataset.storage.get_episode_metadata([index]).__next__()["seed"]
        reference = recorder.episode_arrays(index)
        assert np.array_equal(episode.observations, reference["observations"])
        observation, _ = env.reset(seed=seed)
        replayed = [observation]
        for action in episode.actions:
            observation, *_ = env.step(action)
            replayed.append(observation)
        assert np.array_equal(np.array(replayed), episode.observations)  # bit for bit
        assert episode.infos["tip_position_m"].shape == (16, 3)
        assert np.array_equal(episode.rewards, reference["rewards"])
    env.close()


def test_episode_metadata_and_listing(written):
    root, _ = written
    dataset = load_dataset(DATASET_ID, root=root)
    assert [m["policy"] for m in dataset.storage.get_episode_metadata([0, 1])] == ["random"] * 2
    assert list_datasets(root) == [DATASET_ID]


def test_the_recorder_changes_nothing():
    plain, wrapped = gym.make(ENV_ID, **ENV_KWARGS), EpisodeRecorder(gym.make(ENV_ID, **ENV_KWARGS))
    a, _ = plain.reset(seed=1)
    b, _ = wrapped.reset(seed=1)
    assert np.array_equal(a, b)
    for action in np.random.default_rng(1).uniform(-1, 1, (5, 3)).astype(np.float32):
        ra, rb = plain.step(action), wrapped.step(action)
        assert np.array_equal(ra[0], rb[0]) and ra[1] == rb[1]
    plain.close()
    wrapped.close()


def test_an_existing_dataset_is_not_replaced_without_force(tmp_path):
    _write_random_episodes(tmp_path, seeds=(3,))
    before = sorted(p.name for p in (tmp_path / DATASET_ID / "data").iterdir())
    with pytest.raises(ValueError, match="already exists.*force"):
        _write_random_episodes(tmp_path, seeds=(5,))
    assert sorted(p.name for p in (tmp_path / DATASET_ID / "data").iterdir()) == before
    _write_random_episodes(tmp_path, seeds=(5, 6), force=True)
    assert load_dataset(DATASET_ID, root=tmp_path).total_episodes == 2


@pytest.mark.parametrize("dataset_id", ["soft-arm/test/absent-v0", "not an id", None])
def test_an_unknown_id_is_one_value_error(written, dataset_id):
    root, _ = written
    with pytest.raises(ValueError, match="dataset_id") as error:
        load_dataset(dataset_id, root=root)
    assert repr(dataset_id) in str(error.value)


def _copy(root: Path, tmp_path: Path) -> Path:
    shutil.copytree(root / DATASET_ID, tmp_path / DATASET_ID)
    return tmp_path / DATASET_ID / "data"


def test_a_corrupt_dataset_is_one_value_error(written, tmp_path):
    data = _copy(written[0], tmp_path)
    (data / "metadata.json").write_text("{not json")
    with pytest.raises(ValueError, match="corrupt") as error:
        load_dataset(DATASET_ID, root=tmp_path)
    assert DATASET_ID in str(error.value)


def test_a_damaged_episode_file_is_one_value_error(written, tmp_path):
    data = _copy(written[0], tmp_path)
    episode_file = next((data / "1").glob("*.arrow"))
    episode_file.write_bytes(episode_file.read_bytes()[:100])
    with pytest.raises(ValueError, match="corrupt|truncated") as error:
        load_dataset(DATASET_ID, root=tmp_path)
    assert DATASET_ID in str(error.value)


def test_a_truncated_dataset_is_one_value_error(written, tmp_path):
    data = _copy(written[0], tmp_path)
    shutil.rmtree(data / "1")
    with pytest.raises(ValueError, match="truncated") as error:
        load_dataset(DATASET_ID, root=tmp_path)
    assert DATASET_ID in str(error.value) and "'1'" in str(error.value)


def test_a_dataset_of_another_env_version_is_one_value_error(written, tmp_path):
    data = _copy(written[0], tmp_path)
    metadata = json.loads((data / "metadata.json").read_text())
    metadata["env_spec"] = metadata["env_spec"].replace(ENV_ID, "SoftArmReachWang2023-v7")
    (data / "metadata.json").write_text(json.dumps(metadata))
    with pytest.raises(ValueError, match="SoftArmReachWang2023-v7") as error:
        load_dataset(DATASET_ID, root=tmp_path)
    assert "another env version" in str(error.value) and ENV_ID in str(error.value)


def test_the_command_line_refuses_an_existing_dataset(tmp_path, capsys):
    target = tmp_path / "soft-arm" / "zhao2021" / "exploration-v0"
    target.mkdir(parents=True)
    marker = target / "keep"
    marker.write_text("old")
    assert_one_line_error(main, ["datasets", "--papers", "zhao2021", "--size", "quick",
                                 "--out", str(tmp_path)], "--out", capsys, also="--force")
    assert marker.read_text() == "old"


@pytest.mark.parametrize("argv, option", [
    (["datasets", "--papers", "zhao2022"], "--papers"),
    (["datasets", "--size", "huge"], "--size"),
    (["datasets", "--seed", "-1"], "--seed"),
    (["datasets", "--papers", "ho2018", "ho2018"], "--papers"),
])
def test_the_command_line_refuses_bad_options(argv, option, capsys):
    assert_one_line_error(main, argv, option, capsys)
