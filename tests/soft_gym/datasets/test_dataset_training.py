"""soft_gym.datasets.training: each method trained from its paper's dataset equals the method
trained on a fresh collection with the same seed (bit for bit), and a dataset that does not fit
the method is refused by one ValueError naming it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

import soft_gym  # noqa: F401 - registers the ids
from agents.policies import make_policy
from eval.datasets import write_paper_dataset
from eval.datasets.papers import env_calibration_context as _private_context
from eval.papers.zhao2021.dataset import ZHAO2021_ENV
from soft_gym.papers.zhao2021.exploration import collect_exploration, exploration_of
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig

ZHAO_SIZE = {"n_free": 16, "n_loaded": 8}
ZOU_SIZE = {"n_samples": 20}
HO_SIZE = {"pretrain_waypoints": 2}
ZHAO_ID = "soft-arm/zhao2021/exploration-v0"
ZOU_ID = "soft-arm/zou2022/stereo-labels-v0"
HO_ID = "soft-arm/ho2018/pretraining-v0"
ZHAO_OBS = ["pose", "target", "strain", "pressure"]


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    """zhao2021's, zou2022's and ho2018's datasets at small sizes, written once."""
    directory = tmp_path_factory.mktemp("datasets")
    for paper, size in (("zhao2021", ZHAO_SIZE), ("zou2022", ZOU_SIZE), ("ho2018", HO_SIZE)):
        write_paper_dataset(paper, root=directory, size=size, progress=False, use_cache=False)
    return directory


@pytest.fixture(autouse=True)
def _no_disk_cache(monkeypatch):
    monkeypatch.setenv("SOFT_GYM_CACHE", "off")


def _assert_identical(a, b, where: str = "state") -> None:
    """Two model states equal bit for bit (dicts, lists, arrays, tensors, numbers)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), where
        for key in a:
            _assert_identical(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _assert_identical(x, y, f"{where}[{i}]")
    elif isinstance(a, torch.Tensor):
        assert torch.equal(a, b), where
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and np.array_equal(
            a, b, equal_nan=a.dtype.kind in "fc"), where
    else:
        assert a == b or (a != a and b != b), where


def _zhao_env(**kwargs):
    return gym.make("SoftArmReachZhao2021-v0", obs=ZHAO_OBS, **kwargs)


def test_the_exploration_read_back_equals_the_collection(root):
    context = _private_context(*ZHAO2021_ENV)
    spec, gauges = context.spec, context.make_sensor("strain")
    config = ReconstructionConfig.from_options(ZHAO_SIZE)
    read = exploration_of(spec, gauges, config, dataset=ZHAO_ID, dataset_root=root)
    collected = collect_exploration(spec, gauges, seed=0, progress=False, **ZHAO_SIZE)
    for name in ("pressures_pa", "readings", "key_points_m", "backbone_m", "tip_load_kg"):
        _assert_identical(getattr(read, name), getattr(collected, name), name)


def test_local_ik_asdm_from_the_dataset_equals_the_collection(root):
    env = _zhao_env(feedback="ground_truth")
    options = dict(exploration=ZHAO_SIZE, max_iterations=3, cache=False, progress=False)
    collected = make_policy("local_ik_asdm", env=env, **options)
    read = make_policy("local_ik_asdm", env=env, dataset=ZHAO_ID, dataset_root=root, **options)
    collected.pretrain(), read.pretrain()
    _assert_identical(collected.network.state(), read.network.state())
    _assert_identical(collected.training, read.training)
    env.close()


def test_strain_sr_from_the_dataset_equals_the_collection(root):
    sensing = {**ZHAO_SIZE, "max_iterations": 2}
    collected = _zhao_env(feedback="strain_sr", sensing=sensing)
    read = _zhao_env(feedback="strain_sr",
                     sensing={**sensing, "dataset": ZHAO_ID, "dataset_root": str(root)})
    _assert_identical(collected.unwrapped.feedback_source.reconstructor.state(),
                      read.unwrapped.feedback_source.reconstructor.state())
    first, _ = collected.reset(seed=3)
    second, _ = read.reset(seed=3)
    assert np.array_equal(first, second)
    collected.close(), read.close()


def test_encoder_dnn_from_the_dataset_equals_the_collection(root):
    sensing = {**ZOU_SIZE, "epochs": 2}
    kwargs = dict(feedback="encoder_dnn", obs=["pose", "target", "encoder", "pressure"])
    collected = gym.make("SoftArmReachZou2022-v0", sensing=sensing, **kwargs)
    read = gym.make("SoftArmReachZou2022-v0", **kwargs,
                    sensing={**sensing, "dataset": ZOU_ID, "dataset_root": root})
    source, other = collected.unwrapped.feedback_source, read.unwrapped.feedback_source
    _assert_identical(source.dnn.state(), other.dnn.state())
    for name in ("pressures_pa", "lengths_m", "labels_m", "truth_m", "augmented", "n_lost",
                 "train", "validation", "test"):
        _assert_identical(getattr(source.report["data"], name),
                          getattr(other.report["data"], name), name)
    collected.close(), read.close()


def test_lwpr_rwr_from_the_dataset_equals_the_walk(root):
    env = gym.make("SoftArmTrackHo2018-v0", feedback="em")
    options = dict(max_epochs=2, cache=False, progress=False, **HO_SIZE)
    walked = make_policy("lwpr_rwr", env=env, **options)
    read = make_policy("lwpr_rwr", env=env, dataset=HO_ID, dataset_root=root, **options)
    for ours, theirs in zip(walked._collect_pretraining_data(), read._read_pretraining_data()):
        _assert_identical(ours, theirs)
    _assert_identical(walked.pretrain(), read.pretrain())
    _assert_identical(walked.inverse.state(), read.inverse.state())
    _assert_identical(walked.pretraining_tips_mm(), read.pretraining_tips_mm())
    observation, _ = env.reset(seed=1)
    assert np.array_equal(walked.predict(observation)[0], read.predict(observation)[0])
    env.close()


def test_the_walk_seam_records_what_the_walk_drove():
    from soft_gym.datasets.episodes import EpisodeRecorder

    env = gym.make("SoftArmTrackHo2018-v0", feedback="em")
    controller = make_policy("lwpr_rwr", env=env, cache=False, progress=False, **HO_SIZE)
    recorders = []
    data = controller._collect_pretraining_data(
        wrap_env=lambda walk: recorders.append(EpisodeRecorder(walk)) or recorders[-1])
    env.close()
    assert len(recorders) == 1 and len(recorders[0].episodes[0]["actions"]) == 20 + 2 * 60
    for ours, theirs in zip(data, controller._collect_pretraining_data()):
        _assert_identical(ours, theirs)


# ------------------------------------------------------------------------------ bad input
def test_an_unknown_id_is_one_value_error_naming_it(root):
    env = _zhao_env(feedback="ground_truth")
    controller = make_policy("local_ik_asdm", env=env, exploration=ZHAO_SIZE, cache=False,
                             progress=False, dataset="soft-arm/zhao2021/nothing-v0",
                             dataset_root=root)
    with pytest.raises(ValueError, match="soft-arm/zhao2021/nothing-v0"):
        controller.pretrain()
    env.close()


@pytest.mark.parametrize("options, setting", [
    ({"exploration": {"n_free": 20, "n_loaded": 8}}, "n_free"),
    ({"exploration": {**ZHAO_SIZE, "seed": 1}}, "seed"),
])
def test_local_ik_asdm_refuses_other_sizes_and_seeds(root, options, setting):
    env = _zhao_env(feedback="ground_truth")
    controller = make_policy("local_ik_asdm", env=env, cache=False, progress=False,
                             dataset=ZHAO_ID, dataset_root=root, **options)
    with pytest.raises(ValueError, match=rf"{ZHAO_ID}.* {setting} = "):
        controller.pretrain()
    env.close()


def test_another_arm_or_gauge_model_is_refused(root):
    env = gym.make("SoftArmReach-v0", preset="ho2018", obs=ZHAO_OBS, feedback="ground_truth")
    controller = make_policy("local_ik_asdm", env=env, exploration=ZHAO_SIZE, cache=False,
                             progress=False, dataset=ZHAO_ID, dataset_root=root)
    with pytest.raises(ValueError, match=rf"{ZHAO_ID}.* preset = 'zhao2021'.*'ho2018'"):
        controller.pretrain()
    env.close()
    with pytest.raises(ValueError, match=rf"{ZHAO_ID}.* gauges = "):
        _zhao_env(feedback="strain_sr", sensor_config={"strain": {"noise_std": 0.5}},
                  sensing={**ZHAO_SIZE, "dataset": ZHAO_ID, "dataset_root": str(root)})


def test_encoder_dnn_refuses_another_recipe(root):
    with pytest.raises(ValueError, match=rf"{ZOU_ID}.* recipe.seed = 0.* 1"):
        gym.make("SoftArmReachZou2022-v0", feedback="encoder_dnn",
                 sensing={**ZOU_SIZE, "seed": 1, "dataset": ZOU_ID, "dataset_root": root})


def test_lwpr_rwr_refuses_another_walk_or_paper(root):
    env = gym.make("SoftArmTrackHo2018-v0", feedback="em")
    for options, pattern in (
            ({"pretrain_waypoints": 3}, rf"{HO_ID}.* pretrain_waypoints = 2.* 3"),
            ({"pretrain_waypoints": 2, "seed": 5}, rf"{HO_ID}.* seed = 0.* 5"),
            ({"pretrain_waypoints": 2, "dataset": ZHAO_ID},
             rf"{ZHAO_ID}.* holds zhao2021's data, not ho2018's")):
        controller = make_policy("lwpr_rwr", env=env, cache=False, progress=False,
                                 **{"dataset": HO_ID, "dataset_root": root, **options})
        with pytest.raises(ValueError, match=pattern):
            controller.pretrain()
    env.close()


def test_bad_dataset_options_are_refused():
    env = gym.make("SoftArmTrackHo2018-v0", feedback="em")
    with pytest.raises(ValueError, match="dataset must be a dataset id"):
        make_policy("lwpr_rwr", env=env, dataset=3)
    env.close()
    with pytest.raises(ValueError, match="dataset_root is given without a dataset"):
        _zhao_env(feedback="strain_sr", sensing={**ZHAO_SIZE, "dataset_root": "/tmp"})
