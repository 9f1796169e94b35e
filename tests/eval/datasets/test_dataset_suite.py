"""eval.datasets.suite and ``suite --record minari``: records identical with and without
recording, one dataset per arm and condition with the policy in each episode's metadata, and
the episodes replayed bit for bit in their env."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import eval.suite as suite
import soft_gym  # noqa: F401 - registers the ids
from soft_gym.datasets.store import load_dataset
from eval.datasets.suite import write_suite_datasets
from eval.suite.store import read_steps, record_path
from tests.suite_specs import assert_suite_cli_error, tiny_suite


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("suite")
    spec_file = base / "tiny.yaml"
    spec_file.write_text(tiny_suite())
    spec = suite.load_suite(spec_file)
    plain, recorded = base / "plain", base / "recorded"
    suite.run_suite(spec, plain, backend="serial", progress=False)
    suite.run_suite(spec, recorded, backend="serial", progress=False, record=True)
    return spec, plain, recorded


def _record(out, key) -> dict:
    record = json.loads(record_path(out, key).read_text())
    record.pop("wall_s")
    return record


def test_records_are_the_same_with_and_without_recording(runs):
    spec, plain, recorded = runs
    for cell in suite.expand(spec):
        assert _record(plain, cell.key) == _record(recorded, cell.key)
        a, b = read_steps(plain, cell.key), read_steps(recorded, cell.key)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.keys() == b.keys()
            assert all(np.array_equal(a[k], b[k]) for k in a)


def test_one_dataset_per_arm_and_condition_replays_bit_for_bit(runs):
    spec, _, recorded = runs
    cells = suite.expand(spec)
    result = write_suite_datasets(spec.name, recorded, cells)
    assert result["datasets"] == {"soft-arm/suite-tiny/wang2023-nominal-v0": 1,
                                  "soft-arm/suite-tiny/wang2023-load_10g-v0": 1}
    assert len(result["missing"]) == 1  # the n/a run of the agent on ho2018
    dataset = load_dataset("soft-arm/suite-tiny/wang2023-load_10g-v0", root=result["root"])
    metadata = next(dataset.storage.get_episode_metadata([0]))
    assert metadata["policy"] == "cc_model" and metadata["seed"] == 0
    episode = dataset[0]
    steps = read_steps(recorded, metadata["key"])
    assert np.array_equal(episode.infos["tip_position_m"][1:], steps["tip_m"])
    assert np.array_equal(episode.actions, steps["action"].astype(np.float32))
    env = gym.make(metadata["env_id"], **metadata["env_kwargs"])
    observation, _ = env.reset(seed=metadata["seed"])
    replayed = [observation]
    for action in episode.actions:
        observation, *_ = env.step(action)
        replayed.append(observation)
    env.close()
    assert np.array_equal(np.array(replayed), episode.observations)
    recovered = dataset.recover_environment()
    assert recovered.spec.kwargs["scenario"] == metadata["env_kwargs"]["scenario"]
    recovered.close()


def test_record_with_report_only_is_one_line(tmp_path, capsys):
    assert_suite_cli_error(["--record", "minari", "--report-only"], "--record", tmp_path,
                           capsys)


def test_record_takes_only_minari(tmp_path, capsys):
    assert_suite_cli_error(["--record", "hdf5"], "--record", tmp_path, capsys)
