"""The MuJoCo engine as the env uses it: what it refuses (before any work, naming the feature and
the engine), seeds, episodes that leave nothing behind, the divergence guard, stability without
a substep split, and domain randomisation.

Its physics against analytic references runs in ``test_physics.py`` (every test there runs on
both engines) and against the PyBullet arm in ``test_engine_agreement.py``.
"""

from __future__ import annotations

import copy
import pickle
from concurrent.futures import ThreadPoolExecutor

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import soft_gym  # noqa: F401  (registers the ids)
from soft_gym.engines import ENGINES, make_simulator
from soft_gym.engines.chain_readout import PhysicsDivergedError
from soft_gym.engines.mujoco import MujocoWorld, stepping
from soft_gym.engines.mujoco.simulator import MujocoArmSimulator
from soft_gym.engines.mujoco.stepping import step_arms
from soft_gym.robots import get_preset
from soft_gym.scenarios.loads import TipMass
from soft_gym.sensing import FEEDBACK_SOURCES

NO_SWAYING = {"load_weights": {"none": 0.3, "tip_mass": 0.35, "filling_load": 0.2,
                               "push": 0.15}}


def _make(env_id: str = "SoftArmReach-v0", **kwargs):
    return gym.make(env_id, **{"feedback": "ground_truth", "engine": "mujoco", **kwargs})


def _rollout(env, seed: int, steps: int = 40) -> np.ndarray:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = [obs]
    for _ in range(steps):
        obs, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        out.append(obs)
    return np.array(out)


@pytest.mark.smoke
@pytest.mark.parametrize("kwargs, named", [
    ({"feedback": "fused"}, "sensor 'image'"),
    ({"feedback": "camera"}, "sensor 'image'"),
    ({"feedback": "fbg"}, "sensor 'image'"),
    ({"preset": "zou2022", "feedback": "stereo"}, "sensor 'stereo'"),
    ({"sensors": ("stereo",)}, "sensor 'stereo'"),
    ({"scenario": ["swaying_mass"]}, "SwayingMass"),
    ({"scenario": ["obstacle_rod"]}, "ObstacleRod"),
    ({"render_mode": "rgb_array"}, "render_mode='rgb_array'"),
    ({"randomization": True}, "load_weights['swaying_mass']"),
])
def test_what_mujoco_lacks_is_refused_naming_the_feature_and_the_engine(kwargs, named):
    with pytest.raises(ValueError) as error:
        _make(**kwargs)
    message = str(error.value)
    assert named in message and "mujoco engine" in message and "pybullet" in message


def _feedback_mujoco_runs() -> list[str]:
    """The feedback sources an env on the MuJoCo engine accepts, found by making it."""
    from soft_gym.envs.uncalibrated import make_uncalibrated_env

    accepted = []
    for name in FEEDBACK_SOURCES:
        try:
            make_uncalibrated_env("SoftArmReach-v0", {"engine": "mujoco", "feedback": name}).close()
        except ValueError:
            continue
        accepted.append(name)
    return sorted(accepted)


GT = {"feedback": "ground_truth"}


@pytest.mark.parametrize("kwargs, remedy", [
    ({}, "feedback"),  # the default feedback, fused, needs the eye-in-hand camera
    ({"feedback": "camera", "obs": ("pose", "target", "image"), "obs_format": "dict"},
     "feedback and obs"),
    ({**GT, "obs": ("pose", "target", "image"), "obs_format": "dict"},
     " or leave 'image' out of obs="),
    ({**GT, "sensors": ("stereo",)}, " or leave 'stereo' out of sensors="),
    ({**GT, "scenario": ["swaying_mass"]}, ""),
    ({**GT, "render_mode": "rgb_array"}, " or pass render_mode=None"),
    ({**GT, "randomization": True},
     " or set RandomizationConfig.load_weights['swaying_mass'] (randomization=) to 0 to draw "
     "none"),
])
def test_what_mujoco_lacks_is_refused_naming_the_argument_that_makes_it_run(kwargs, remedy):
    """Beside the engines that have it, the refusal names what would run on the engine asked
    for, on the same line: the feedback sources it runs (those the env accepts on it), the
    part or sensor to leave out, render_mode=None, no swaying masses drawn; a scenario element
    needs another engine."""
    with pytest.raises(ValueError) as error:
        gym.make("SoftArmReach-v0", engine="mujoco", **kwargs)
    message = str(error.value)
    assert "\n" not in message
    engines = "use engine= one of ['pybullet']"
    feedback = f" or pass feedback= one of {_feedback_mujoco_runs()}"
    expected = {"feedback": feedback,
                "feedback and obs": f"{feedback} and leave 'image' out of obs="}.get(remedy,
                                                                                   remedy)
    assert message.endswith(engines + expected), message


@pytest.mark.parametrize("engine", ["bullet", "MuJoCo", 3, None])
def test_an_unknown_engine_is_refused_listing_the_engines(engine):
    with pytest.raises(ValueError, match="engine must be one of") as error:
        _make(engine=engine)
    assert all(name in str(error.value) for name in ENGINES)


def test_the_world_refuses_every_call_by_name():
    world = MujocoWorld()
    with pytest.raises(ValueError, match="a body beside the arm.*mujoco engine"):
        world.add_body("sphere", position_m=(0, 0, 0), radius_m=0.01)
    with pytest.raises(ValueError, match="rendering.*mujoco engine"):
        world.render(32, 32, [0.0] * 16, [0.0] * 16, (0, 0, 1))


@pytest.mark.parametrize("env_id, preset", [("SoftArmReach-v0", "wang2023"),
                                            ("SoftArmTrack-v0", "zhao2021"),
                                            ("SoftArmTrack-v0", "ho2018")])
def test_mujoco_envs_pass_gymnasiums_checker(env_id, preset):
    env = _make(env_id, preset=preset)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_a_seed_fixes_an_episode_and_no_episode_leaks_into_the_next():
    """Same seed, same trajectory bit for bit, in one env after other episodes (with loads,
    stiffness and lag drawn by randomisation) and in a fresh env."""
    kwargs = {"preset": "zhao2021", "randomization": NO_SWAYING,
              "scenario": [{"name": "push", "start_s": 0.5}]}
    env = _make(**kwargs)
    first = _rollout(env, seed=3)
    _rollout(env, seed=4)
    again = _rollout(env, seed=3)
    fresh = _rollout(_make(**kwargs), seed=3)
    assert np.array_equal(first, again) and np.array_equal(first, fresh)
    assert not np.array_equal(first, _rollout(env, seed=5))


def test_a_rebuilt_env_continues_identically():
    env = _make(preset="wang2023", scenario=[{"name": "tip_mass", "mass_kg": 0.01}])
    for clone in (copy.deepcopy(env.unwrapped), pickle.loads(pickle.dumps(env.unwrapped))):
        assert clone.sim.spec == env.unwrapped.sim.spec and clone.engine == "mujoco"
        assert np.array_equal(_rollout(clone, seed=1), _rollout(env.unwrapped, seed=1))


def test_randomised_stiffness_and_lag_move_both_engines_alike():
    """The same draws (stiffness x1.4, lag x1.5) shift both engines' tips alike: the MuJoCo arm
    stays within 0.5 mm of the PyBullet arm after a step of one chamber."""
    spec = get_preset("wang2023")
    tips = []
    for engine in ("pybullet", "mujoco"):
        sim = make_simulator(spec, engine, physics_dt_s=spec.physics_dt_s / 2)
        sim.set_stiffness_scale(1.4)
        sim.set_time_constant_scale(1.5)
        sim.reset(settle_s=0.5)
        sim.set_pressures(np.array([1.0, 0.0, 0.0]) * spec.p_max_pa)
        sim.step_physics(0.3)
        tips.append(sim.tip_pose()[0])
        sim.close()
    nominal = make_simulator(spec, "mujoco")
    nominal.reset(settle_s=0.5)
    nominal.set_pressures(np.array([1.0, 0.0, 0.0]) * spec.p_max_pa)
    nominal.step_physics(0.3)
    assert np.linalg.norm(tips[0] - tips[1]) < 0.5e-3
    assert np.linalg.norm(nominal.tip_pose()[0] - tips[1]) > 3e-3  # the draws do change it


@pytest.mark.parametrize("preset", ["ho2018", "zou2022"])
def test_bang_bang_under_the_heaviest_tip_mass_stays_within_the_stops(preset):
    """The load that made the PyBullet arm whip (bang-bang, ho2018 with its 14.2 g tip) stays
    bounded with no substep split: the implicit damping holds the fast link modes."""
    spec = get_preset(preset)
    sim = make_simulator(spec, "mujoco")
    sim.add_load(TipMass(mass_kg=min(0.0142, 0.9 * spec.max_load_n / 9.81)))
    sim.reset(settle_s=0.5)
    rng = np.random.default_rng(0)
    reach = spec.max_reach_m
    for _ in range(200):
        sim.set_pressures(np.where(rng.random(spec.n_chambers) < 0.5, spec.p_pre_pa,
                                   spec.p_max_pa))
        sim.step_physics(spec.control_period_s)  # raises PhysicsDivergedError if it ran away
        assert np.linalg.norm(sim.tip_pose()[0]) <= reach
    assert np.all(np.isfinite(sim.joint_positions()))


def test_a_joint_far_past_its_stop_raises_diverged():
    spec = get_preset("wang2023")
    sim = make_simulator(spec, "mujoco")
    q = np.zeros(sim.chain.n_joints)
    q[0] = 5.0 * sim.chain.upper_limit[0]
    sim.set_joint_positions(q)
    with pytest.raises(PhysicsDivergedError, match="of the wang2023 arm is at .* times its limit"):
        sim.step_physics(sim.physics_dt_s)


def test_tip_payload_and_clear_loads_restore_the_arm_as_built():
    spec = get_preset("zou2022")
    sim = make_simulator(spec, "mujoco")
    masses, inertias = sim.model.body_mass.copy(), sim.model.body_inertia.copy()
    sim.add_load(TipMass(mass_kg=0.02))
    sim.reset(settle_s=0.2)
    assert sim.tip_payload_kg == pytest.approx(0.02)
    assert sim.model.body_mass.sum() == pytest.approx(masses.sum() + 0.02)
    sim.clear_loads()
    assert sim.tip_payload_kg == 0.0
    assert np.array_equal(sim.model.body_mass, masses)
    assert np.array_equal(sim.model.body_inertia, inertias)


@pytest.mark.parametrize("tip_mass_kg", [0.08, 0.12])
def test_leaving_the_stop_tendons_out_far_from_the_stops_changes_no_motion(tip_mass_kg,
                                                                          monkeypatch):
    """The arm rides a model without the stops' tendons while every joint is far from its
    stops; bang-bang under a heavy tip (80 g, and 120 g, the upright arm's bound of twice its
    weight) drives ho2018's joints into the stops and out again (no preset's pressures alone,
    nor the papers' tip loads, reach a stop), and the tip moves bit for bit as on an arm that
    keeps the full model all along."""
    spec = get_preset("ho2018")
    rng = np.random.default_rng(3)
    commands = [np.where(rng.random(spec.n_chambers) < 0.5, spec.p_pre_pa, spec.p_max_pa)
                for _ in range(60)]

    def tips(switching: bool) -> tuple[np.ndarray, int]:
        sim = make_simulator(spec, "mujoco")
        if tip_mass_kg:
            sim.add_load(TipMass(mass_kg=tip_mass_kg))
        if not switching:
            monkeypatch.setattr(sim, "stop_proximity", lambda: (True, True))
        sim.reset(settle_s=0.3)
        out, free = [], 0
        for pressure in commands:
            sim.set_pressures(pressure)
            sim.step_physics(spec.control_period_s)
            out.append(sim.tip_pose()[0])
            free += not sim.with_stops
        monkeypatch.undo()
        return np.array(out), free

    switched, free_steps = tips(True)
    full, _ = tips(False)
    assert 0 < free_steps < len(commands)  # both models carried the arm
    assert np.array_equal(switched, full)


def _ordinary_stepping(monkeypatch) -> None:
    """Step every MuJoCo arm update by update in Python (never open loop)."""
    monkeypatch.setattr(MujocoArmSimulator, "forces_known_ahead", property(lambda self: False))


def _open_loop_spy(monkeypatch) -> list[tuple[int, int]]:
    """Record (arms given, arms handed back) of every open-loop call."""
    calls: list[tuple[int, int]] = []
    original = stepping._step_open_loop

    def spy(sims, total, n_threads):
        back = original(sims, total, n_threads)
        calls.append((len(sims), len(back)))
        return back

    monkeypatch.setattr(stepping, "_step_open_loop", spy)
    return calls


@pytest.mark.parametrize("preset", ["wang2023", "zhao2021", "zou2022", "ho2018"])
def test_open_loop_stepping_moves_arms_bit_for_bit_as_update_by_update(preset, monkeypatch):
    """One arm, and a batch of three on two threads, under random and bang-bang pressures, whole
    and half control periods and one update's interval and a substep (a call may start and end
    between updates, or on the first substep after one), and a tip payload put on and taken off
    one arm of the batch (that arm is then stepped update by update): the same states and
    applied forces bit for bit as stepping every arm update by update."""
    spec = get_preset(preset)

    def run() -> np.ndarray:
        rng = np.random.default_rng(5)
        sims = [MujocoArmSimulator(spec) for _ in range(4)]
        states = []
        with ThreadPoolExecutor(2) as executor:
            for k in range(24):
                for sim in sims:
                    fraction = (rng.uniform(0, 1, spec.n_chambers) if k % 8 < 5
                                else rng.integers(0, 2, spec.n_chambers).astype(float))
                    sim.set_pressures(spec.p_pre_pa + fraction * (spec.p_max_pa - spec.p_pre_pa))
                # whole and half control periods, and a call ending on the first substep after
                # an update (one substep more than an update's interval)
                seconds = {2: 0.5 * spec.control_period_s,
                           4: (sims[0].per_actuation + 1) * sims[0].physics_dt_s}.get(
                    k % 5, spec.control_period_s)
                sims[0].step_physics(seconds)
                step_arms(sims[1:], seconds, executor, 2)
                sims[3].set_tip_payload("cup", 0.01 if 8 <= k < 14 else 0.0)
                states.append([np.r_[sim.data.time, sim.data.qpos, sim.data.qvel,
                                     sim.data.qfrc_applied] for sim in sims])
        return np.array(states)

    calls = _open_loop_spy(monkeypatch)
    open_loop = run()
    assert calls and {arms for arms, _ in calls} >= {1, 2, 3}  # alone, and batches with and
    monkeypatch.undo()                                       # without the payload arm
    _ordinary_stepping(monkeypatch)
    assert np.array_equal(open_loop, run())


def test_an_arm_entering_a_stop_band_open_loop_is_stepped_again_update_by_update(monkeypatch):
    """A joint thrown towards its stop enters the band where the stop acts within the control
    period: the open-loop run is dropped, the arm put back and stepped update by update (on the
    model with the stops), and it ends exactly where that stepping alone takes it."""
    spec = get_preset("wang2023")

    def run() -> np.ndarray:
        sim = MujocoArmSimulator(spec)
        stops = sim.chain.end_stops()
        start = stops.free_centre.copy()
        start[0] += 0.9 * stops.free_half_width[0]
        sim.set_joint_positions(start)
        sim.data.qvel[0] = 3.0 * stops.free_half_width[0] / spec.control_period_s
        sim.set_pressures(spec.p_max_pa)
        sim.step_physics(spec.control_period_s)
        return np.r_[sim.data.time, sim.data.qpos, sim.data.qvel]

    calls = _open_loop_spy(monkeypatch)
    open_loop = run()
    assert calls == [(1, 1)]
    monkeypatch.undo()
    _ordinary_stepping(monkeypatch)
    ordinary = run()
    assert np.array_equal(open_loop, ordinary)
    # the stop acted: on the model without the stops all along the arm ends elsewhere
    monkeypatch.undo()
    monkeypatch.setattr(MujocoArmSimulator, "in_stop_band", lambda self, positions: False)
    monkeypatch.setattr(MujocoArmSimulator, "stop_proximity", lambda self: (False, False))
    assert not np.array_equal(run(), ordinary)
