"""zhao2021's shape reconstruction: the exploration data, the SFE-PD networks and the
``strain_sr`` feedback source with the ``shape`` observation part.

References: the exploration's own rules (Section VI-A: two chambers by +-0.05 bar per step
within [0, 0.8 bar], a 75 g tip after the free samples); key points of a straight arm at sixths
of its length; an LSTM written out step by step (eq. 2) against the batched one; a trained small
model against the mean predictor; save/load identity; gymnasium's env checker.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

import soft_gym  # noqa: F401
from soft_gym.robots.presets import get_preset
from soft_gym.papers.zhao2021.sfe_pd import KeyPointNetworks, sequences
from soft_gym.papers.zhao2021.exploration import (cached_reconstruction, collect_exploration,
                                                      exploration_of)
from soft_gym.sensing.key_points import key_point_arcs, key_points_from_backbone
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig
from soft_gym.sensors.strain_gauge import StrainGauges

ZHAO = get_preset("zhao2021")
SMALL = {"n_free": 240, "n_loaded": 120, "max_iterations": 80, "batch_size": 64,
         "learning_rate": 1e-2}
"""A quick model: 360 exploration samples, 80 iterations (the paper's takes 6000 and 1000)."""


@pytest.fixture(scope="module")
def small_model():
    """The small model and the exploration it learnt from."""
    config = ReconstructionConfig(**SMALL)
    reconstructor, _ = cached_reconstruction(ZHAO, StrainGauges(), config, progress=False)
    return reconstructor, exploration_of(ZHAO, StrainGauges(), config, progress=False)


def test_key_points_lie_at_sixths_of_a_straight_arm():
    arcs = key_point_arcs(ZHAO)
    assert np.allclose(arcs, ZHAO.length_m * np.arange(1, 7) / 6)
    n = len(np.r_[0.0, np.cumsum([s.link_length_m for s in ZHAO.segments for _ in
                                  range(s.n_links)])])
    straight = np.zeros((n, 3))
    straight[:, 2] = np.linspace(0.0, ZHAO.length_m, n)
    points = key_points_from_backbone(ZHAO, straight)
    assert np.allclose(points[:, 2], arcs) and np.allclose(points[:, :2], 0.0)
    with pytest.raises(ValueError, match="backbone_m"):
        key_points_from_backbone(ZHAO, straight[:-1])


def test_exploration_follows_the_papers_rules(small_model):
    _, data = small_model
    p_max = ZHAO.p_max_pa
    assert len(data) == 360 and data.readings.shape == (360, 6)
    assert np.all(data.pressures_pa >= 0.0) and np.all(data.pressures_pa <= p_max + 1e-9)
    changes = np.diff(data.pressures_pa, axis=0)
    changed = np.abs(changes) > 1.0
    assert np.all(changed.sum(axis=1) == 2)                      # two chambers per step
    assert np.allclose(np.abs(changes[changed]), p_max[0] / 16)  # by 0.05 bar each
    assert np.all(data.tip_load_kg[:240] == 0.0) and np.all(data.tip_load_kg[240:] == 0.075)
    tips = data.key_points_m[:, -1]
    assert np.ptp(tips[:, 0]) > 0.01 and np.ptp(tips[:, 1]) > 0.01  # the walk moves the tip
    again = collect_exploration(ZHAO, StrainGauges(), n_free=20, n_loaded=0, progress=False)
    assert np.array_equal(again.pressures_pa, data.pressures_pa[:20])
    assert np.allclose(again.readings, data.readings[:20])       # same seed, same noise


def test_batched_lstm_equals_the_equations_written_out():
    torch.manual_seed(3)
    nets = KeyPointNetworks(n_nets=2, n_inputs=4, dropout=0.0).eval()
    x = torch.randn(5, 6, 4)
    with torch.no_grad():
        batched = nets(x).numpy()
    W = nets.input_weights.detach().numpy()
    U = nets.recurrent_weights.detach().numpy()
    b = nets.gate_bias.detach().numpy()
    sigmoid = lambda v: 1.0 / (1.0 + np.exp(-v))  # noqa: E731
    for net in range(2):
        for sample in range(5):
            h, c = np.zeros(6), np.zeros(6)
            for t in range(6):
                gates = x[sample, t].numpy() @ W[net] + h @ U[net] + b[net, 0]
                f, i, cand, o = np.split(gates, 4)                     # eq. (2)
                c = sigmoid(f) * c + sigmoid(i) * np.tanh(cand)
                h = sigmoid(o) * np.tanh(c)
            hidden = sigmoid(h @ nets.hidden_weights[net].detach().numpy()
                             + nets.hidden_bias[net, 0].detach().numpy())        # eq. (3)
            out = hidden @ nets.output_weights[net].detach().numpy() \
                + nets.output_bias[net, 0].detach().numpy()                       # eq. (4)
            assert np.allclose(out, batched[sample, net], atol=1e-5)


def test_sequences_hold_the_last_six_steps():
    a = np.arange(10.0)[:, None] * np.ones((1, 2))
    s = -a[:, :1]
    x = sequences(a, s, window=5)
    assert x.shape == (10, 6, 3)
    assert np.array_equal(x[7, :, 0], np.arange(2.0, 8.0))
    assert np.array_equal(x[2, :, 0], [0, 0, 0, 0, 1, 2])  # padded with the first step


def test_small_model_beats_the_mean_and_reloads_identically(small_model, tmp_path):
    reconstructor, data = small_model
    x = sequences(data.pressures_pa, data.readings)
    predicted = reconstructor.key_points(x[..., :6], x[..., 6:])
    errors_mm = np.linalg.norm(predicted - data.key_points_m, axis=-1).mean(axis=0) * 1000
    spread_mm = np.linalg.norm(data.key_points_m - data.key_points_m.mean(axis=0),
                               axis=-1).mean(axis=0) * 1000
    assert np.all(errors_mm < 0.5 * spread_mm), (errors_mm, spread_mm)
    path = tmp_path / "sr.sfepd"
    reconstructor.save(path)
    loaded = type(reconstructor).load(path)
    again = loaded.key_points(x[:20, :, :6], x[:20, :, 6:])
    assert np.array_equal(again, reconstructor.key_points(x[:20, :, :6], x[:20, :, 6:]))
    raw = bytearray(path.read_bytes())
    raw[-20] ^= 0xFF
    path.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match="sr.sfepd"):
        type(reconstructor).load(path)


def test_bad_readings_are_refused(small_model):
    reconstructor, _ = small_model
    good_a, good_s = np.zeros((6, 6)), np.zeros((6, 6))
    with pytest.raises(ValueError, match="readings"):
        reconstructor.key_points(good_a, np.zeros((6, 5)))
    with pytest.raises(ValueError, match="pressures_pa"):
        reconstructor.key_points(np.zeros((5, 6)), good_s)
    bad = good_s.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="finite"):
        reconstructor.key_points(good_a, bad)
    with pytest.raises(ValueError, match="n_free"):
        ReconstructionConfig(n_free=-1)
    with pytest.raises(ValueError, match="shape-reconstruction options"):
        ReconstructionConfig.from_options({"epochs": 3})


def test_strain_sr_env_passes_the_checker_and_fills_the_shape_part(small_model):
    from gymnasium.utils.env_checker import check_env

    env = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="strain_sr",
                   obs=("pose", "target", "strain", "pressure", "shape"), sensing=dict(SMALL))
    try:
        check_env(env.unwrapped, skip_render_check=True)
        observation, _ = env.reset(seed=0)
        unwrapped = env.unwrapped
        shape = unwrapped.observation_part(observation, "shape").reshape(7, 3)
        pose = unwrapped.observation_part(observation, "pose")
        assert np.array_equal(shape[0], np.zeros(3))        # P_0: the base
        assert np.allclose(shape[-1], pose[:3], atol=1e-6)  # the tip is the last key point
        for _ in range(30):
            observation, *_, info = env.step(env.action_space.sample())
        truth = key_points_from_backbone(ZHAO, info["backbone_m"])
        shape = unwrapped.observation_part(observation, "shape").reshape(7, 3)[1:]
        assert np.all(np.isfinite(shape))
        assert np.linalg.norm(shape - truth, axis=1).max() < 0.05  # a small model, 5 cm
    finally:
        env.close()


def test_shape_part_needs_a_source_that_estimates_the_backbone():
    with pytest.raises(ValueError, match="shape"):
        gym.make("SoftArmReach-v0", preset="zhao2021", feedback="em", obs=("pose", "shape"))
    env = gym.make("SoftArmReach-v0", preset="zhao2021", feedback="ground_truth",
                   obs=("pose", "shape"))
    try:
        observation, info = env.reset(seed=0)
        shape = env.unwrapped.observation_part(observation, "shape").reshape(7, 3)
        assert np.allclose(shape[1:], key_points_from_backbone(ZHAO, info["backbone_m"]),
                           atol=1e-6)
        assert np.allclose(shape[0], 0.0)
    finally:
        env.close()
    with pytest.raises(ValueError, match="shape-reconstruction options"):
        gym.make("SoftArmReach-v0", preset="zhao2021", feedback="strain_sr",
                 sensing={"iterations": 5})
