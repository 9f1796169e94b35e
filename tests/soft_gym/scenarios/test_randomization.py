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


@pytest.mark.smoke
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

    path = Path(__file__).resolve().parents[3] / "train" / "configs" / "randomization.yaml"
    assert RandomizationConfig.from_any(path) == RandomizationConfig()


@pytest.mark.parametrize("bad, message", [
    ({"tip_mass_kg": (0.02, 0.01)}, r"tip_mass_kg must be a finite range"),
    ({"tip_mass_kg": (-0.01, 0.01)}, r"tip_mass_kg must be a finite range"),
    ({"stiffness_scale": (0.0, 1.0)}, r"stiffness_scale must be a finite range"),
    ({"fault_strength": (0.5, 1.5)}, r"fault_strength must lie within \[0, 1\]"),
    ({"load_weights": {"anvil": 1.0}}, r"load_weights keys must be among .*anvil"),
    ({"load_weights": {"none": 0.0}}, r"load_weights must be finite odds >= 0 with a positive sum"),
    ({"unknown_key": 1}, r"randomization keys must be among .*unknown_key"),
])
def test_bad_ranges_raise(bad, message):
    with pytest.raises(ValueError, match=message):
        RandomizationConfig.from_any(bad)


# --------------------------------------------------------------------------- effect tests
# The pneumatic lag against its first-order step response, and the sensor-noise factor against
# the spread of the EM tracker's readings (docs/architecture.md, "Pneumatic actuation", and
# soft_gym/sensors/em_tracker.py: 0.8 mm per-axis position noise, ho2018).

STEP_TIMES_S = (0.05, 0.1, 0.2, 0.4, 0.8)
"""Times after a commanded step at which the first-order response is checked (s)."""


def _first_order_step(p_cmd: np.ndarray, t_s: float, tau_s: float) -> np.ndarray:
    """Step response of ``tau dp/dt = p_cmd - p`` from ``p(0) = 0``: ``p_cmd (1 - exp(-t/tau))``."""
    return p_cmd * (1.0 - np.exp(-t_s / tau_s))


@pytest.mark.parametrize("scale", [None, 1.5])
@pytest.mark.parametrize("dt_s", [0.01, 0.0025])
def test_pneumatic_step_response_is_first_order(scale: float | None, dt_s: float) -> None:
    """``PneumaticSupply`` from rest under a commanded step follows ``p_cmd (1 - exp(-t / tau))``
    within 1 % at several times, with ``tau`` the preset's ``pneumatic_time_constant_s`` or 1.5
    times it after ``set_time_constant_scale(1.5)``; whatever the update interval."""
    from soft_gym.robots.pneumatics import PneumaticSupply

    spec = get_preset("wang2023")
    tau = spec.pneumatic_time_constant_s * (1.0 if scale is None else scale)
    supply = PneumaticSupply(spec)
    if scale is not None:
        supply.set_time_constant_scale(scale)
    supply.reset(np.zeros(spec.n_chambers))
    p_cmd = spec.p_max_pa * np.array([0.8, 0.3, 0.55])
    supply.command(p_cmd)
    elapsed_steps = 0
    for t_s in STEP_TIMES_S:
        target_steps = int(round(t_s / dt_s))
        for _ in range(target_steps - elapsed_steps):
            pressure = supply.advance(dt_s)
        elapsed_steps = target_steps
        np.testing.assert_allclose(pressure, _first_order_step(p_cmd, t_s, tau), rtol=0.01,
                                   err_msg=f"t = {t_s} s, tau = {tau} s")


def test_env_pressure_follows_the_randomised_time_constant() -> None:
    """In an env whose draw fixes ``time_constant_scale`` at 1.5, the chamber pressures in
    ``info["pressures_pa"]`` after an action step follow ``p_cmd (1 - exp(-t / (1.5 tau)))``
    within 1 % (``p_cmd`` from the documented absolute action map
    ``p_pre + (a + 1) / 2 (p_max - p_pre)``, with wang2023's zero pre-pressure), and not the
    preset's own ``tau``, which is off by far more than 1 % at the first steps."""
    spec = get_preset("wang2023")
    assert np.all(spec.p_pre_pa == 0.0)  # the formula's p(0) = 0
    env = gym.make("SoftArmTrackWang2023-v0", feedback="ground_truth",
                   randomization={"load_weights": {"none": 1.0},
                                  "time_constant_scale": (1.5, 1.5)}).unwrapped
    try:
        _, info = env.reset(seed=0)
        assert info["randomization"]["time_constant_scale"] == pytest.approx(1.5)
        np.testing.assert_allclose(info["pressures_pa"], 0.0, atol=1e-9)
        action = np.array([0.6, -0.2, -1.0])
        p_cmd = spec.p_pre_pa + (action + 1.0) / 2.0 * (spec.p_max_pa - spec.p_pre_pa)
        tau = 1.5 * spec.pneumatic_time_constant_s
        nominal = spec.pneumatic_time_constant_s
        moving = p_cmd > 0
        for k in range(1, 17):
            _, _, _, _, info = env.step(action)
            t_s = k * spec.control_period_s
            assert info["time_s"] == pytest.approx(t_s, abs=1e-9)
            pressure = np.asarray(info["pressures_pa"], dtype=float)
            np.testing.assert_allclose(pressure, _first_order_step(p_cmd, t_s, tau),
                                       rtol=0.01, atol=1e-6, err_msg=f"step {k}")
            if k <= 4:  # the preset's tau would be visibly wrong here
                wrong = _first_order_step(p_cmd, t_s, nominal)
                assert np.all(np.abs(pressure[moving] - wrong[moving]) > 0.05 * wrong[moving])
    finally:
        env.close()


def _em_position_spread(noise_scale: float, seed: int, steps: int = 200) -> tuple[float, float]:
    """Per-axis std (m) of the EM tracker's position readings with the arm held at rest, over
    ``steps`` control steps; also the largest motion of the true tip over the same steps (m)."""
    env = gym.make("SoftArmReach-v0", preset="wang2023", feedback="em", episode_steps=steps,
                   randomization={"load_weights": {"none": 1.0},
                                  "sensor_noise_scale": (noise_scale, noise_scale),
                                  "stiffness_scale": (1.0, 1.0),
                                  "time_constant_scale": (1.0, 1.0)}).unwrapped
    try:
        _, info = env.reset(seed=seed)
        assert info["randomization"]["sensor_noise_scale"] == pytest.approx(noise_scale)
        rest = -np.ones(env.action_space.shape[0])  # absolute mode: the pre-pressure, as at reset
        readings, tips = [], []
        for _ in range(steps):
            _, _, _, _, info = env.step(rest)
            readings.append(np.asarray(info["sensors"]["em"][:3], dtype=float))
            tips.append(np.asarray(info["tip_position_m"], dtype=float))
    finally:
        env.close()
    readings, tips = np.array(readings), np.array(tips)
    spread = float(np.sqrt(np.mean((readings - readings.mean(axis=0)) ** 2)))
    motion = float(np.max(np.linalg.norm(tips - tips.mean(axis=0), axis=1)))
    return spread, motion


def test_em_noise_spread_scales_with_the_drawn_sensor_noise_scale() -> None:
    """Held at rest, the EM readings' spread is the tracker's noise: about 0.8 mm per axis
    (ho2018) times the drawn ``sensor_noise_scale``. Measured over 200 steps (600 samples, std
    known to ~3 %), the spread at scale 2.0 is twice the one at 1.0 within 15 %, and each is
    0.8 mm times its scale within 15 %. Different seeds, so the two spreads are independent."""
    spread_1, motion_1 = _em_position_spread(1.0, seed=11)
    spread_2, motion_2 = _em_position_spread(2.0, seed=12)
    assert max(motion_1, motion_2) < 0.05e-3  # the arm is at rest: the spread is sensor noise
    assert spread_1 == pytest.approx(0.8e-3, rel=0.15)
    assert spread_2 == pytest.approx(2.0 * 0.8e-3, rel=0.15)
    assert spread_2 / spread_1 == pytest.approx(2.0, rel=0.15)
