"""The physics stays physical across episodes and under every load the env accepts.

References: the joint-space mass matrix from its definition (finite-difference Jacobians of every
link's centre of mass and orientation, ``M = sum m Jv^T Jv + Jw^T R I R^T Jw``); a fresh env for
what a seed must reproduce; the arm's largest possible reach (every link at its longest) for a
runaway.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from soft_gym._quaternion import quaternion_to_matrix
from soft_gym.robots import get_preset
from soft_gym.robots.spec import GRAVITY_M_S2
from soft_gym.robots.stops import EndStops
from soft_gym.scenarios import Push, SwayingMass, TipMass
from soft_gym.scenarios.randomization import RandomizationConfig
from soft_gym.engines.pybullet.simulator import ArmSimulator, PhysicsDivergedError

PRESETS = ("wang2023", "zhao2021", "zou2022", "ho2018")


def _mass_matrix_by_definition(client, body: int, q: np.ndarray, eps: float = 1e-7) -> np.ndarray:
    """``sum_i m_i Jv_i^T Jv_i + Jw_i^T R_i I_i R_i^T Jw_i`` with finite-difference Jacobians."""
    n = len(q)

    def frames(positions):
        for joint, value in enumerate(positions):
            client.resetJointState(body, joint, float(value), 0.0)
        states = client.getLinkStates(body, list(range(n)), computeForwardKinematics=1)
        return (np.array([s[0] for s in states]),
                quaternion_to_matrix(np.array([s[1] for s in states])))

    centres, rotations = frames(q)
    jv, jw = np.zeros((n, 3, n)), np.zeros((n, 3, n))
    for j in range(n):
        up, down = q.copy(), q.copy()
        up[j] += eps
        down[j] -= eps
        (c_up, r_up), (c_down, r_down) = frames(up), frames(down)
        jv[:, :, j] = (c_up - c_down) / (2 * eps)
        spin = np.einsum("nij,nkj->nik", (r_up - r_down) / (2 * eps), rotations)
        jw[:, :, j] = np.stack([spin[:, 2, 1], spin[:, 0, 2], spin[:, 1, 0]], axis=1)
    frames(q)
    mass = np.zeros((n, n))
    for link in range(n):
        info = client.getDynamicsInfo(body, link)
        inertia = (rotations[link] * np.array(info[2])) @ rotations[link].T
        mass += info[0] * jv[link].T @ jv[link] + jw[link].T @ inertia @ jw[link]
    return mass


@pytest.mark.parametrize("preset", ["ho2018", "wang2023"])
def test_mass_matrix_follows_a_tip_payload(preset):
    """PyBullet's calculateMassMatrix keeps the masses of its first call; the simulator's mass
    matrix must follow a payload put on and taken off (the cause of the runaway after a loaded
    episode)."""
    sim = ArmSimulator(get_preset(preset))
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.3, 0.3, sim.arm.n_joints)
    q[sim.arm.station_axial_joint] *= 0.02
    for payload_kg in (0.024, 0.0):
        sim.set_tip_payload("test", payload_kg)
        sim.set_joint_positions(q)
        reference = _mass_matrix_by_definition(sim.client, sim.arm.body_id, q)
        assert np.abs(sim.mass_matrix(q) - reference).max() < 1e-9 * np.abs(reference).max() + 1e-12
    sim.close()


def test_clearing_loads_restores_the_arm_as_built():
    spec = get_preset("wang2023")
    fresh, loaded = ArmSimulator(spec), ArmSimulator(spec)
    loaded.add_load(TipMass(mass_kg=0.03))
    loaded.add_load(SwayingMass(mass_kg=0.01))
    loaded.reset(settle_s=0.2)
    loaded.step_physics(0.5)
    loaded.clear_loads()
    for link in range(fresh.arm.n_joints):
        assert (loaded.client.getDynamicsInfo(loaded.arm.body_id, link)
                == fresh.client.getDynamicsInfo(fresh.arm.body_id, link))
    assert loaded.tip_payload_kg == 0.0 and not loaded._held.forces
    q = np.linspace(-0.2, 0.2, fresh.arm.n_joints)
    assert np.array_equal(loaded.mass_matrix(q), fresh.mass_matrix(q))


def _heavy(spec) -> RandomizationConfig:
    """Every load kind, each up to what the arm bears."""
    g, limit = GRAVITY_M_S2, spec.max_load_n
    return RandomizationConfig(
        load_weights={"none": 0.1, "tip_mass": 0.3, "filling_load": 0.2, "swaying_mass": 0.2,
                      "push": 0.2},
        tip_mass_kg=(0.0, limit / g), filling_added_kg=(0.0, limit / g - 0.014),
        filling_rate_kg_s=(0.001, 0.02), swaying_mass_kg=(0.001, limit / g),
        push_force_n=(0.0, limit), time_constant_scale=(0.7, 1.5))


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("ranges", ["default", "heavy"])
def test_random_episodes_keep_the_tip_within_reach(preset, ranges):
    """The issue's reproduction: random actions over randomised episodes in one env (loads of
    every kind one after another); every tip stays within the arm's largest reach."""
    spec = get_preset(preset)
    env = gym.make("SoftArmTrack-v0", preset=preset, feedback="em", path=["circle", "pentagram"],
                   randomization=True if ranges == "default" else _heavy(spec)).unwrapped
    rng = np.random.default_rng(0)
    farthest, loads = 0.0, set()
    for episode in range(16):
        _, info = env.reset(seed=episode)
        loads.update(info["randomization"]["loads"])
        for _ in range(100):
            _, _, _, truncated, info = env.step(rng.uniform(-1, 1, spec.n_chambers))
            farthest = max(farthest, float(np.linalg.norm(info["tip_position_m"])))
            if truncated:
                break
    env.close()
    assert len(loads) >= 3, loads
    assert farthest <= spec.max_reach_m, (
        f"tip {farthest * 1e3:.0f} mm from the base, reach {spec.max_reach_m * 1e3:.0f} mm")


@pytest.mark.parametrize("preset", PRESETS)
def test_loads_at_the_limit_hold_every_joint_on_its_stops(preset):
    """The heaviest tip mass and the strongest push (tip and base link, along and against gravity,
    sideways) under random pressures: the tip stays within reach and no joint goes more than
    10 % past its limit."""
    spec = get_preset(preset)
    limit = spec.max_load_n
    loads = [TipMass(mass_kg=limit / GRAVITY_M_S2)]
    for direction in ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.6, 0.6, -0.5)):
        force = limit * np.array(direction) / np.linalg.norm(direction)
        loads += [Push(force_n=tuple(force), link=link, start_s=0.0, end_s=None, ramp_s=0.5)
                  for link in (0, -1)]
    for load in loads:
        sim = ArmSimulator(spec)
        sim.add_load(load)
        sim.reset()
        rng = np.random.default_rng(1)
        farthest, overshoot = 0.0, 0.0
        for _ in range(120):
            sim.set_pressures(rng.uniform(0.0, 1.0, spec.n_chambers) * spec.p_max_pa)
            sim.step_physics(spec.control_period_s)
            q = sim.joint_positions()
            farthest = max(farthest, float(np.linalg.norm(sim.tip_pose()[0])))
            overshoot = max(overshoot, float(np.max(np.maximum(q / sim.arm.upper_limit,
                                                               q / sim.arm.lower_limit))))
        sim.close()
        assert farthest <= spec.max_reach_m and overshoot <= 1.1, (load, farthest, overshoot)


def _bang_bang(env, seed: int, steps: int, hold: int = 10):
    """Every chamber switched between its pre-pressure and p_max, drawn anew every ``hold``
    control steps (whole segments fold as far as they go and swing the load); yields each step's
    info after checking the joints are finite."""
    sim = env.unwrapped.sim
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for step in range(steps):
        if step % hold == 0:
            action = rng.choice([-1.0, 1.0], env.action_space.shape[0]).astype(np.float32)
        _, _, _, _, info = env.step(action)
        assert np.all(np.isfinite(sim.joint_positions())), (seed, step)
        yield info


@pytest.mark.parametrize("preset, mass_kg", [(p, None) for p in PRESETS] + [("ho2018", 0.0142)])
def test_bang_bang_switching_under_a_swung_tip_mass_stays_physical(preset, mass_kg):
    """Bang-bang actions under the heaviest tip mass the arm accepts (and ho2018's own 14.2 g
    tip): no joint goes more than 10 % past its limit and the tip stays within reach (a taut
    thread may reach into its band). Before substeps were split while the arm whips, ho2018
    diverged on every one of five such draws at its heaviest tip (within 6-35 control steps)
    and on four of five with 14.2 g (55-255)."""
    spec = get_preset(preset)
    mass_kg = spec.max_load_n / GRAVITY_M_S2 if mass_kg is None else mass_kg
    env = gym.make("SoftArmReach-v0", preset=preset, feedback="ground_truth", episode_steps=1000,
                   scenario={"name": "tip_mass", "mass_kg": mass_kg})
    sim = env.unwrapped.sim
    reach_m = spec.max_reach_m + float(np.sum(sim.arm.thread_band))
    for seed in (0, 1):
        farthest, overshoot = 0.0, 0.0
        for info in _bang_bang(env, seed, 150):
            q = sim.joint_positions()
            farthest = max(farthest, float(np.linalg.norm(info["tip_position_m"])))
            overshoot = max(overshoot, float(np.max(np.maximum(q / sim.arm.upper_limit,
                                                               q / sim.arm.lower_limit))))
        assert overshoot <= 1.1 and farthest <= reach_m, (seed, overshoot, farthest, reach_m)
    env.close()


def test_a_whipping_arm_splits_its_substeps_and_the_next_episode_starts_on_the_preset_step():
    """The split engages while ho2018 whips (joint speeds of several rad/s) and never while it
    tracks slowly; a reset restores PyBullet's step and the preset's, so an episode after a
    whipping one matches the same seed in a fresh env bit for bit."""
    spec = get_preset("ho2018")
    kwargs = dict(preset="ho2018", feedback="ground_truth",
                  scenario={"name": "tip_mass", "mass_kg": 0.0142})
    env = gym.make("SoftArmTrack-v0", **kwargs)
    sim = env.unwrapped.sim
    pieces = [sim._refinement for _ in _bang_bang(env, 0, 60)]
    assert max(pieces) > 1 and min(pieces) == 1, pieces

    def calm_episode(env) -> np.ndarray:
        observation, _ = env.reset(seed=3)
        record = [observation]
        for step in range(60):  # a slow ramp of one chamber
            action = np.full(spec.n_chambers, -1.0, dtype=np.float32)
            action[0] = -1.0 + step / 60.0
            observation, _, _, _, info = env.step(action)
            assert env.unwrapped.sim._refinement == 1, step
            record += [observation, info["tip_position_m"]]
        return np.concatenate([np.ravel(x) for x in record])

    after_whipping = calm_episode(env)
    step_s = sim.client.getPhysicsEngineParameters()["fixedTimeStep"]
    assert step_s == pytest.approx(spec.physics_dt_s)
    fresh = gym.make("SoftArmTrack-v0", **kwargs)
    assert np.array_equal(after_whipping, calm_episode(fresh))
    fresh.close()
    env.close()


@pytest.mark.parametrize("preset", PRESETS)
def test_a_seed_fixes_an_episode_after_any_history(preset):
    """Every seeded episode, after a history of loaded episodes of every kind, matches the same
    seed in a fresh env bit for bit (observations and ground-truth tip)."""
    spec = get_preset(preset)
    kwargs = dict(preset=preset, feedback="em", path=["circle", "pentagram"],
                  randomization=_heavy(spec))

    def episode(env, seed: int) -> tuple[np.ndarray, list]:
        observation, info = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        record = [observation]
        for _ in range(40):
            observation, _, _, _, info = env.step(rng.uniform(-1, 1, spec.n_chambers))
            record += [observation, info["tip_position_m"]]
        return np.concatenate([np.ravel(x) for x in record]), info["randomization"]["loads"]

    used = gym.make("SoftArmTrack-v0", **kwargs)
    kinds = set()
    for seed in range(8):
        seen, loads = episode(used, seed)
        kinds.update(loads)
        fresh = gym.make("SoftArmTrack-v0", **kwargs)
        expected, _ = episode(fresh, seed)
        fresh.close()
        assert np.array_equal(seen, expected), f"seed {seed} ({loads}) differs after history"
    used.close()
    assert len(kinds) >= 3, kinds


@pytest.mark.parametrize("load", [TipMass(mass_kg=1e6), Push(force_n=(1e9, 0.0, 0.0)),
                                  SwayingMass(mass_kg=10.0)])
def test_loads_beyond_what_the_arm_bears_are_refused(load):
    sim = ArmSimulator(get_preset("wang2023"))
    with pytest.raises(ValueError, match=r"at most 1.24 N on the wang2023 arm"):
        sim.add_load(load)
    sim.close()


def test_env_refuses_a_randomization_heavier_than_the_arm_bears():
    with pytest.raises(ValueError, match="randomization tip_mass_kg can draw a load of 9.81 N"):
        gym.make("SoftArmTrackWang2023-v0", feedback="em",
                 randomization={"tip_mass_kg": (0.0, 1.0)})
    with pytest.raises(ValueError, match="max_load_n"):
        gym.make("SoftArmTrackWang2023-v0", feedback="em",
                 scenario={"name": "tip_mass", "mass_kg": 1e6})


def test_end_stops_lock_smoothly():
    """Zero force inside the free range, force continuous with slope rising linearly over the
    band to the full stiffness, and the tangent matches the force's derivative."""
    stops = EndStops(np.array([-1.0, -0.4]), np.array([1.0, 0.6]), np.array([100.0, 10.0]))
    q = np.array([0.7, 0.4])
    assert np.array_equal(stops.force(q), [0.0, 0.0])
    for position in np.linspace(-1.5, 1.5, 61):
        q = np.array([position, position * 0.5])
        step = 1e-6
        slope = (stops.force(q + step) - stops.force(q - step)) / (2 * step)
        assert np.allclose(slope, stops.stiffness_at(q), rtol=1e-4, atol=1e-3)
    assert stops.stiffness_at(np.array([1.2, 0.8]))[0] == 100.0
    assert stops.force(np.array([-1.2, 0.0]))[0] < 0


def test_a_diverged_simulation_raises_instead_of_reporting_states():
    sim = ArmSimulator(get_preset("wang2023"))
    sim.set_joint_positions(3.0 * sim.arm.upper_limit)
    with pytest.raises(PhysicsDivergedError, match="times its limit"):
        sim.step_physics(sim.physics_dt_s)
    sim.close()


def test_loads_count_together_only_while_they_act():
    """Twenty 0.15 N flicks, one every 10 s, never add up; two held pushes at once do."""
    from soft_gym.scenarios import Flick

    sim = ArmSimulator(get_preset("wang2023"))
    for k in range(20):
        sim.add_load(Flick(impulse_ns=(0.003, 0.0, 0.0), start_s=10.0 * k + 1.0))
    sim.add_load(Push(force_n=(1.0, 0.0, 0.0), start_s=0.0, end_s=None))
    with pytest.raises(ValueError, match="at most 1.24 N"):
        sim.add_load(Push(force_n=(0.0, 0.2, 0.0), start_s=50.0, end_s=60.0))
    sim.close()


@pytest.mark.parametrize("preset", ["zou2022", "wang2023", "zhao2021", "ho2018"])
def test_a_reset_with_pressures_settles_where_the_lag_takes_the_arm(preset):
    """``ArmSimulator.reset(pressure_pa, settle_s)`` starts the arm where those pressures hold it
    (a straight zou2022 arm stepped to 3 bar in every chamber used to diverge): full pressure and
    random draws stay physical and settles within 0.5 mm of the tip that the same pressures reach
    through the supply's lag from rest."""
    spec = get_preset(preset)
    rng = np.random.default_rng(3)
    stepped, lagged = ArmSimulator(spec), ArmSimulator(spec)
    try:
        draws = [spec.p_max_pa] + [spec.p_pre_pa + rng.uniform(0, 1, spec.n_chambers) * (
            spec.p_max_pa - spec.p_pre_pa) for _ in range(3)]
        for pressure in draws:  # p_max everywhere diverged on zou2022 from a straight start
            # zhao2021's heavy arm takes ~8 s to settle within 0.1 mm
            stepped.reset(pressure, settle_s=8.0)
            lagged.reset(settle_s=0.2)
            lagged.set_pressures(pressure)
            lagged.step_physics(8.0 + 12 * spec.pneumatic_time_constant_s)
            gap_mm = np.linalg.norm(stepped.tip_pose()[0] - lagged.tip_pose()[0]) * 1e3
            assert gap_mm < 0.5, (pressure, gap_mm)
    finally:
        stepped.close()
        lagged.close()
