"""Domain randomisation: seeded draws, each randomised quantity acts on the arm as stated."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from soft_gym.robots.presets import get_preset
from soft_gym.scenarios.randomization import DomainRandomizer, RandomizationConfig


def _env(**kwargs):
    return gym.make("SoftArmTrackWang2023-v0", feedback="em", **kwargs).unwrapped


def test_off_by_default():
    env = _env()
    _, info = env.reset(seed=0)
    assert "randomization" not in info and env.randomizer is None
    env.close()


def test_same_seed_same_episode_and_seeds_differ():
    env = _env(randomization=True)
    draws, tips = [], []
    for seed in (4, 4, 5):
        _, info = env.reset(seed=seed)
        for _ in range(20):
            _, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
        draws.append(info["randomization"])
        tips.append(info["tip_position_m"])
    env.close()
    assert draws[0] == draws[1] and np.array_equal(tips[0], tips[1])
    assert draws[0] != draws[2]


def test_loads_do_not_pile_up_across_episodes():
    config = RandomizationConfig(load_weights={"tip_mass": 1.0})
    env = _env(randomization=config, scenario={"name": "tip_mass", "mass_kg": 0.001})
    for seed in range(4):
        env.reset(seed=seed)
        assert len(env.sim.loads) == 2  # the env's own load and this episode's
    env.close()


@pytest.mark.parametrize("scale", [0.8, 1.25])
def test_stiffness_scale_scales_pressure_bending_inversely(make_sim, scale):
    """Without gravity a chamber's moment bends the arm by M L / (scale EI): the tip's lateral
    deflection angle scales as 1 / scale (small bends)."""
    spec = get_preset("wang2023")
    pressure = spec.p_pre_pa.copy()
    pressure[0] += 0.2 * (spec.p_max_pa[0] - spec.p_pre_pa[0])
    bends = []
    for factor in (1.0, scale):
        sim = make_sim(spec, gravity=False)
        sim.set_stiffness_scale(factor)
        sim.reset(pressure, settle_s=3.0)
        _, quaternion = sim.tip_pose()
        axis_z = 1.0 - 2.0 * (quaternion[0] ** 2 + quaternion[1] ** 2)
        bends.append(np.arccos(np.clip(axis_z, -1.0, 1.0)))
    assert bends[1] / bends[0] == pytest.approx(1.0 / scale, rel=0.03)


def test_time_constant_and_sensor_noise_follow_the_draw():
    config = RandomizationConfig(load_weights={"none": 1.0}, sensor_noise_scale=(2.0, 2.0),
                                 time_constant_scale=(1.5, 1.5))
    env = _env(randomization=config)
    nominal_tau = get_preset("wang2023").pneumatic_time_constant_s
    env.reset(seed=0)
    assert env.sim.supply.time_constant_s == pytest.approx(1.5 * nominal_tau)
    assert env.sensors["em"].position_noise_m == pytest.approx(2 * 0.8e-3)
    env.close()


def test_faults_drawn_only_with_a_camera():
    config = RandomizationConfig(fault_weights={"low_light": 1.0})
    randomizer = DomainRandomizer(config, n_links=4, with_camera=True)
    draw = randomizer.sample(np.random.default_rng(0))
    assert [type(f).__name__ for f in draw.faults] == ["LowLight"]
    assert DomainRandomizer(config, 4, with_camera=False).sample(np.random.default_rng(0)).faults == []


def test_yaml_config_matches_defaults():
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "train" / "configs" / "randomization.yaml"
    assert RandomizationConfig.from_any(path) == RandomizationConfig()


@pytest.mark.parametrize("bad", [
    {"tip_mass_kg": (0.02, 0.01)},
    {"tip_mass_kg": (-0.01, 0.01)},
    {"stiffness_scale": (0.0, 1.0)},
    {"fault_strength": (0.5, 1.5)},
    {"load_weights": {"anvil": 1.0}},
    {"load_weights": {"none": 0.0}},
    {"unknown_key": 1},
])
def test_bad_ranges_raise(bad):
    with pytest.raises(ValueError):
        RandomizationConfig.from_any(bad)
