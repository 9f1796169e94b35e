"""ho2018's reward-weighted-regression inverse and the ``lwpr_rwr`` baseline.

References: a slow, loop-by-loop implementation of ho2018 eqs. (6)-(13) (one field and one
sample at a time); the analytic inverse of a redundant linear map; the paper's qualitative
finding on the simulated upright arm (online error falls cycle by cycle under an unknown tip
load while the offline model's does not).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.learners.rwr_inverse import RewardWeightedInverse
from agents.policies import make_policy


def _reference_betas(model: RewardWeightedInverse, p, u, du, dp) -> np.ndarray:
    """Eqs. (6)-(13) written out field by field and sample by sample."""
    t, a = model.task_dim, model.actuator_dim
    scale = np.concatenate([np.full(2 * t, model.task_scale), np.full(a, model.actuation_scale)])
    betas = []
    for i, (centre, metric) in enumerate(zip(model.centres, model.metrics)):
        weights, costs, rows = [], [], []
        for k in range(len(p)):
            z = np.concatenate([p[k], u[k]])
            weights.append(np.exp(-0.5 * (z - centre) @ metric @ (z - centre)))
            attractor = model.attractor_gain * (model.rest_actuation - u[k])
            costs.append(np.sum(model.cost_weights * (du[k] - attractor) ** 2))
            x = np.concatenate([dp[k], z - centre]) / scale
            rows.append(np.append(x, 1.0))
        weights, costs, X = np.array(weights), np.array(costs), np.array(rows)
        mean_cost = np.sum(weights * costs) / np.sum(weights)
        W = np.diag(np.exp(-0.5 * costs / mean_cost) * weights)
        ridge = model.ridge * np.eye(X.shape[1])
        betas.append(np.linalg.solve(X.T @ W @ X + ridge,
                                     X.T @ W @ du + ridge @ model.prior_betas[i]))
    return np.array(betas)


def _linear_data(n=400, seed=0):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 6)) * 10.0
    u = rng.uniform(0, 1, (n, 6))
    du = rng.normal(0, 0.03, (n, 6))
    return A, u @ A.T, u, du, du @ A.T


def _fields(p, u, n, seed=1):
    rng = np.random.default_rng(seed)
    centres = np.concatenate([p[:n], u[:n]], axis=1) + rng.normal(0, 0.1, (n, 9))
    metrics = np.array([np.diag(rng.uniform(1e-3, 1e-2, 9)) for _ in range(n)])
    return centres, metrics


@pytest.mark.smoke
def test_fit_and_online_refit_match_the_paper_equations_written_out():
    _, p, u, du, dp = _linear_data(60)
    model = RewardWeightedInverse(3, 6, attractor_gain=0.1, ridge=0.5, window=30,
                                  refit_weight=1e-12)
    model.set_fields(*_fields(p, u, 4))
    expected = _reference_betas(model, p, u, du, dp)  # prior: zero
    model.fit(p, u, du, dp)
    np.testing.assert_allclose(model.betas, expected, rtol=1e-8, atol=1e-12)
    # online: the window keeps the newest 30 samples and the fields are pulled to the prior
    for k in range(45):
        model.add(p[k], u[k], du[k], dp[k])
    assert model.window_size == 30
    expected = _reference_betas(model, p[15:45], u[15:45], du[15:45], dp[15:45])
    np.testing.assert_allclose(model.betas, expected, rtol=1e-8, atol=1e-12)


def test_inverse_of_a_redundant_linear_map_reaches_the_task_and_pulls_to_rest():
    """For ``dp = A du`` (3 x 6), the blended inverse gives ``A du = dp_ref`` within 2 %, and
    its motion beyond the pseudo-inverse lies along the null-space part of ``u_0 - u`` (the
    attractor, eq. (8)): cosine 0.67 on average over 50 configurations, positive in 44 (by
    chance it would average 0)."""
    A, p, u, du, dp = _linear_data(2000)
    model = RewardWeightedInverse(3, 6, attractor_gain=0.05, rest_actuation=0.2)
    model.set_fields(np.zeros((1, 9)), np.zeros((1, 9, 9)))
    model.fit(p, u, du, dp)
    rng = np.random.default_rng(3)
    null_projector = np.eye(6) - np.linalg.pinv(A) @ A
    cosines = []
    for _ in range(50):
        config = rng.uniform(0, 1, 6)
        wanted = rng.normal(0, 0.3, 3)
        step = model.predict(wanted, config @ A.T, config)
        assert np.linalg.norm(A @ step - wanted) < 0.02 * np.linalg.norm(wanted)
        null_motion = step - np.linalg.pinv(A) @ wanted
        towards_rest = null_projector @ (0.2 - config)
        cosines.append(null_motion @ towards_rest
                       / (np.linalg.norm(null_motion) * np.linalg.norm(towards_rest)))
    assert np.mean(cosines) > 0.5
    assert np.sum(np.array(cosines) > 0) >= 40


def test_inverse_save_load_and_refusals(tmp_path):
    _, p, u, du, dp = _linear_data(100)
    model = RewardWeightedInverse(3, 6)
    model.set_fields(*_fields(p, u, 3))
    model.fit(p, u, du, dp)
    model.add(p[0], u[0], du[0], dp[0])
    model.save(tmp_path / "inverse.npz")
    loaded = RewardWeightedInverse.load(tmp_path / "inverse.npz")
    for k in range(5):
        assert np.array_equal(model.predict(dp[k], p[k], u[k]), loaded.predict(dp[k], p[k], u[k]))
    (tmp_path / "bad.npz").write_bytes(b"not a model")
    with pytest.raises(ValueError, match="bad.npz"):
        RewardWeightedInverse.load(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="window"):
        RewardWeightedInverse(window=-5)
    with pytest.raises(ValueError, match="position"):
        model.predict(np.zeros(3), np.array([np.nan, 0, 0]), np.zeros(6))
    with pytest.raises(ValueError, match="actuations"):
        model.fit(p, u[:, :5], du, dp)


def _env(**kwargs):
    return gym.make("SoftArmReach-v0", preset="ho2018", feedback="em", obs=("pose", "target"),
                    **kwargs)


def test_controller_refuses_bad_settings_and_envs():
    env = _env()
    with pytest.raises(ValueError, match="window"):
        make_policy("lwpr_rwr", env, window=-1)
    with pytest.raises(ValueError, match="online"):
        make_policy("lwpr_rwr", env, online="yes")
    with pytest.raises(ValueError, match="no_such_option"):
        make_policy("lwpr_rwr", env, no_such_option=1)
    controller = make_policy("lwpr_rwr", env)
    with pytest.raises(ValueError, match="position_m"):
        controller.action_for(np.array([np.inf, 0.0, 0.1]), np.zeros(3))
    with pytest.raises(ValueError, match="'target'"):
        make_policy("lwpr_rwr", gym.make("SoftArmReach-v0", preset="ho2018", feedback="em",
                                         obs=("pose",)))
    env.close()


PRESSURE_QUICK = {"protocol": "quick", "env_options": {"actuation": "pressure"}}
"""The shorter protocol with the chambers driven by pressure, where these numbers were measured."""
SHORT = {"pretrain_waypoints": 80, "max_epochs": 6, "cycle_s": 40.0, "lead_in_s": 10.0,
         **PRESSURE_QUICK}
SHORT_VARYING = {"pretrain_waypoints": 80, "max_epochs": 6, "cycle_s": 20.0, "lead_in_s": 10.0,
                 **PRESSURE_QUICK}


@pytest.fixture(scope="module")
def short_static():
    from eval.papers.ho2018.experiments import run_experiment

    return run_experiment("static", seed=0, progress=False, **SHORT)


@pytest.mark.slow
def test_short_static_load_online_improves_offline_does_not(short_static):
    """ho2018 Table 1's pattern on a shorter version (LWPR epochs at most 6, 10 s lead-in):
    under the unknown 14.2 g tip the online error falls from cycle 1 to cycle 3, while the
    offline error without load stays where it started. Measured (seed 0): online 4.05, 2.71,
    2.46 mm; offline 2.38, 2.35, 2.35 mm."""
    online = short_static["online, 14.2 g tip"]["cycle_mean_mm"]
    offline = short_static["offline, no load"]["cycle_mean_mm"]
    assert online[2] < 0.75 * online[0]
    assert offline[2] > 0.8 * offline[0]


def test_controller_save_load_predicts_identically(tmp_path):
    env = _env()
    controller = make_policy("lwpr_rwr", env, cache=False, pretrain_waypoints=10,
                             max_epochs=2, leg_decisions=5)
    controller.pretrain()
    controller.save(tmp_path / "controller.npz")
    loaded = type(controller).load(tmp_path / "controller.npz", env=env)
    position, target = np.array([0.0, 0.0, 0.16]), np.array([0.01, 0.0, 0.155])
    for _ in range(6):
        assert np.array_equal(controller.action_for(position, target),
                              loaded.action_for(position, target))
    (tmp_path / "bad.npz").write_bytes(b"\x00garbage")
    with pytest.raises(ValueError, match="bad.npz"):
        type(controller).load(tmp_path / "bad.npz", env=env)
    env.close()


@pytest.fixture(scope="module")
def short_varying():
    from eval.papers.ho2018.experiments import run_experiment

    return run_experiment("varying", seed=0, progress=False, **SHORT_VARYING)


@pytest.mark.slow
def test_short_filling_load_offline_degrades_online_holds(short_varying):
    """ho2018 Table 2's pattern on a shorter version (20 s cycles): with the fluid tip filling in
    cycles 3 and 4 the offline error grows well beyond its first cycles while the online
    learner's stays far below it. Measured (seed 0): offline 8.10, 7.59, 12.84, 24.20 mm; online
    4.05, 3.76, 3.88, 3.77 mm.

    Slow (three tracking runs, 270 simulated seconds: 25-65 s on one core), like the static
    one (two runs, 50 s): in the default run tests/eval/claims/test_quick_claims.py runs the
    same controller adapting online to an unknown load through the same experiment runner,
    test_fit_and_online_refit_match_the_paper_equations_written_out its online refit, and
    tests/soft_gym/scenarios/test_scenarios.py::
    test_filling_load_mass_rises_at_its_rate_to_its_maximum the filling load."""
    offline = short_varying["offline, filling"]["cycle_mean_mm"]
    online = short_varying["online, filling"]["cycle_mean_mm"]
    assert offline[3] > 2.0 * offline[0]
    assert online[3] < 0.5 * offline[3]


TINY = {"pretrain_waypoints": 6, "max_epochs": 2, "leg_decisions": 5}


def test_pretraining_is_cached_on_disk_and_a_corrupt_file_is_rebuilt(tmp_path, monkeypatch):
    """A second controller (another process would do the same) reads the pre-training from the
    user cache; a corrupted file is refused with a warning and pre-trained again, giving the
    same model."""
    from soft_gym.sensing import calibration_cache

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("SOFT_GYM_CACHE", "on")
    calibration_cache.clear_memory()
    env = _env()
    before = set(tmp_path.rglob("*.pkl"))  # the arm's reachable tips
    first = make_policy("lwpr_rwr", env, **TINY)
    first.pretrain()
    files = list(set(tmp_path.rglob("*.pkl")) - before)
    assert len(files) == 1
    calibration_cache.clear_memory()
    second = make_policy("lwpr_rwr", env, **TINY)
    with monkeypatch.context() as patch:  # the second one reads the file, it does not pre-train
        patch.setattr(type(second), "_collect_pretraining_data",
                      lambda self: pytest.fail("pre-trained again instead of reading the cache"))
        second.pretrain()
    files[0].write_bytes(files[0].read_bytes()[:-100] + b"\x00" * 100)
    calibration_cache.clear_memory()
    third = make_policy("lwpr_rwr", env, **TINY)
    with pytest.warns(RuntimeWarning, match="ignoring calibration cache file"):
        third.pretrain()
    position, target = np.array([0.0, 0.0, 0.16]), np.array([0.01, 0.0, 0.155])
    for controller in (second, third):
        assert np.array_equal(controller.inverse.betas, first.inverse.betas)
        assert np.array_equal(controller.action_for(position, target),
                              first.action_for(position, target))
    calibration_cache.clear_memory()
    env.close()




def test_pretraining_shows_progress_of_its_waypoints_and_epochs(capsys):
    """Pre-training shows tqdm bars on stderr (the waypoints driven, the LWPR epochs); with
    ``progress=False`` it is silent, and the setting does not change the model."""
    env = _env()
    shown = make_policy("lwpr_rwr", env, cache=False, **TINY)
    shown.pretrain()
    err = capsys.readouterr().err
    assert "lwpr_rwr pre-training waypoints" in err and "/6" in err
    assert "lwpr_rwr LWPR epochs" in err
    quiet = make_policy("lwpr_rwr", env, cache=False, progress=False, **TINY)
    quiet.pretrain()
    assert capsys.readouterr().err == ""
    assert np.array_equal(quiet.inverse.betas, shown.inverse.betas)
    with pytest.raises(ValueError, match="progress must be True or False, got 1"):
        make_policy("lwpr_rwr", env, progress=1)
    env.close()
