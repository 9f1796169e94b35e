"""Sliding-window GP with an incremental Cholesky factor against a GP rebuilt from scratch."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from agents.learners import SlidingWindowGP, cholesky_rank1_update

LENGTH_SCALES = np.array([0.7, 1.1, 0.9])


def _kernel(a: np.ndarray, b: np.ndarray, length_scales, signal_variance: float) -> np.ndarray:
    diff = (a[:, None, :] - b[None, :, :]) / np.asarray(length_scales)
    return signal_variance * np.exp(-0.5 * np.sum(diff**2, axis=2))


def _window_matrix(X, length_scales, signal_variance, noise_variance):
    return (_kernel(X, X, length_scales, signal_variance)
            + noise_variance * np.eye(len(X)))


def _scratch_gp(X, Y, x_query, length_scales, signal_variance=1.0, noise_variance=1e-4,
                mean="window_mean"):
    """Reference GP built on exactly (X, Y): predictive mean (k, m) and latent std (k,)."""
    K = _window_matrix(X, length_scales, signal_variance, noise_variance)
    lower = np.linalg.cholesky(K)
    mu = Y.mean(axis=0) if mean == "window_mean" else np.zeros(Y.shape[1])
    alpha = scipy.linalg.cho_solve((lower, True), Y - mu)
    cross = _kernel(x_query, X, length_scales, signal_variance)
    v = scipy.linalg.solve_triangular(lower, cross.T, lower=True)
    var = signal_variance - np.sum(v**2, axis=0)
    return cross @ alpha + mu, np.sqrt(np.maximum(var, 0.0))


def _stream(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.0, 1.0, (n, 3))
    Y = np.stack([np.sin(X @ np.array([1.0, 2.0, 0.5])), X[:, 0] * X[:, 1] - 0.3 * X[:, 2]],
                 axis=1) + 0.01 * rng.standard_normal((n, 2))
    return X, Y


def _assert_matches_scratch(gp, X, Y, x_query, atol=1e-8, **kwargs):
    mean, std = gp.predict(x_query, return_std=True)
    ref_mean, ref_std = _scratch_gp(X, Y, x_query, gp.length_scales, gp.signal_variance,
                                    gp.noise_variance, gp.mean, **kwargs)
    np.testing.assert_allclose(mean, ref_mean, rtol=0, atol=atol)
    np.testing.assert_allclose(std, np.repeat(ref_std[:, None], Y.shape[1], axis=1),
                               rtol=0, atol=atol)


# --------------------------------------------------------------------------- against scratch
@pytest.mark.parametrize("mean", ["window_mean", "zero"])
def test_matches_scratch_gp_through_add_drop_cycles_and_refactorisations(mean):
    window, refactor_every = 50, 37
    X, Y = _stream(400)
    x_query = np.random.default_rng(7).uniform(-1.2, 1.2, (12, 3))
    gp = SlidingWindowGP(window=window, length_scales=LENGTH_SCALES, noise_variance=1e-4,
                         mean=mean, refactor_every=refactor_every)
    checked_before = checked_after = 0
    for i in range(len(X)):
        gp.add(X[i], Y[i])
        start = max(0, i + 1 - window)
        assert len(gp) == i + 1 - start
        if gp.adds_since_refactor in (refactor_every - 1, 0) or i % 7 == 0:
            checked_before += gp.adds_since_refactor == refactor_every - 1
            checked_after += gp.adds_since_refactor == 0
            _assert_matches_scratch(gp, X[start:i + 1], Y[start:i + 1], x_query)
    assert checked_before >= 10 and checked_after >= 10
    assert gp.samples_seen == len(X)


def test_pure_incremental_factor_over_1000_steps_has_no_drift():
    window = 50
    X, Y = _stream(1000, seed=3)
    x_query = np.random.default_rng(8).uniform(-1.0, 1.0, (10, 3))
    gp = SlidingWindowGP(window=window, length_scales=LENGTH_SCALES, noise_variance=1e-4,
                         refactor_every=10**9)
    for i in range(len(X)):
        gp.add(X[i], Y[i])
        if i % 97 == 0 or i == len(X) - 1:
            start = max(0, i + 1 - window)
            Xw = X[start:i + 1]
            expected = np.linalg.cholesky(_window_matrix(Xw, LENGTH_SCALES, 1.0, 1e-4))
            np.testing.assert_allclose(gp.cholesky_factor, expected, rtol=0, atol=1e-9)
            _assert_matches_scratch(gp, Xw, Y[start:i + 1], x_query)
    assert gp.adds_since_refactor == 1000        # never refactorised


@pytest.mark.smoke
def test_factor_equals_numpy_cholesky_of_window_matrix():
    X, Y = _stream(130, seed=5)
    gp = SlidingWindowGP(window=40, length_scales=0.8, signal_variance=2.0, noise_variance=1e-3,
                         refactor_every=1000)
    for i in range(len(X)):
        gp.add(X[i], Y[i])
    factor = gp.cholesky_factor
    expected = np.linalg.cholesky(_window_matrix(X[-40:], 0.8, 2.0, 1e-3))
    np.testing.assert_allclose(factor, expected, rtol=0, atol=1e-9)
    assert np.allclose(factor, np.tril(factor))


def test_rank1_update_function_matches_cholesky():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((30, 30))
    K = A @ A.T + 30 * np.eye(30)
    x = rng.standard_normal(30)
    updated = cholesky_rank1_update(np.linalg.cholesky(K), x)
    np.testing.assert_allclose(updated, np.linalg.cholesky(K + np.outer(x, x)), rtol=0,
                               atol=1e-10)


# --------------------------------------------------------------------------- window semantics
def test_window_keeps_exactly_the_last_samples():
    X, Y = _stream(57, seed=11)
    gp = SlidingWindowGP(window=20, length_scales=LENGTH_SCALES, refactor_every=1000)
    for x, y in zip(X, Y):
        gp.add(x, y)
    assert len(gp) == 20
    np.testing.assert_array_equal(gp.window_inputs, X[-20:])
    np.testing.assert_array_equal(gp.window_targets, Y[-20:])
    fresh = SlidingWindowGP(window=20, length_scales=LENGTH_SCALES)
    for x, y in zip(X[-20:], Y[-20:]):
        fresh.add(x, y)
    x_query = np.random.default_rng(1).uniform(-1, 1, (9, 3))
    mean, std = gp.predict(x_query, return_std=True)
    fresh_mean, fresh_std = fresh.predict(x_query, return_std=True)
    np.testing.assert_allclose(mean, fresh_mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(std, fresh_std, rtol=0, atol=1e-10)
    _assert_matches_scratch(gp, X[-20:], Y[-20:], x_query)


def test_window_of_one_and_clear():
    gp = SlidingWindowGP(window=1, length_scales=0.5, mean="zero")
    for value in (0.0, 1.0, 2.0):
        gp.add([value], [value])
    np.testing.assert_array_equal(gp.window_inputs, [[2.0]])
    mean, ref = gp.predict([2.3]), _scratch_gp(np.array([[2.0]]), np.array([[2.0]]),
                                               np.array([[2.3]]), 0.5, mean="zero")[0][0]
    np.testing.assert_allclose(mean, ref, atol=1e-12)
    gp.clear()
    assert len(gp) == 0 and gp.input_dim == 1 and gp.output_dim == 1
    mean, std = gp.predict([0.3], return_std=True)
    np.testing.assert_array_equal(mean, [0.0])
    np.testing.assert_array_equal(std, [1.0])


def test_empty_window_returns_prior_and_shapes():
    gp = SlidingWindowGP(signal_variance=4.0)
    mean, std = gp.predict(np.zeros(5), return_std=True)
    np.testing.assert_array_equal(mean, [0.0])
    np.testing.assert_array_equal(std, [2.0])
    gp.add(np.zeros(5), np.ones(3))
    assert gp.predict(np.zeros(5)).shape == (3,)
    mean, std = gp.predict(np.zeros((4, 5)), return_std=True)
    assert mean.shape == std.shape == (4, 3)


# --------------------------------------------------------------------------- 1-D sanity
@pytest.mark.smoke
def test_learns_sine_and_std_grows_away_from_data():
    rng = np.random.default_rng(4)
    gp = SlidingWindowGP(window=120, length_scales=1.0, noise_variance=1e-4, mean="zero")
    for x in rng.uniform(0.0, 2.0 * np.pi, 200):
        gp.add([x], [np.sin(x)])
    grid = np.linspace(0.3, 2.0 * np.pi - 0.3, 50)[:, None]
    mean, std = gp.predict(grid, return_std=True)
    assert np.max(np.abs(mean[:, 0] - np.sin(grid[:, 0]))) < 1e-2
    assert np.max(std) < 0.05
    edge = gp.window_inputs.max()
    away = edge + np.array([0.25, 0.5, 1.0, 2.0, 4.0, 10.0])
    _, std_away = gp.predict(away[:, None], return_std=True)
    assert np.all(np.diff(std_away[:, 0]) > 0)
    assert std_away[-1, 0] == pytest.approx(1.0, abs=1e-6)


# --------------------------------------------------------------------------- hyperparameters
@pytest.mark.parametrize("true_scale, dims", [(0.5, 1), (0.3, 2)])
def test_fit_hyperparameters_recovers_length_scale(true_scale, dims):
    rng = np.random.default_rng(1)
    n = 150
    X = rng.uniform(0.0, 3.0, (n, dims))
    K = _kernel(X, X, true_scale, 1.0) + 1e-8 * np.eye(n)
    Y = np.linalg.cholesky(K) @ rng.standard_normal((n, 2)) + 0.05 * rng.standard_normal((n, 2))
    gp = SlidingWindowGP(window=100, length_scales=np.full(dims, 2.0), mean="zero")
    result = gp.fit_hyperparameters(X, Y, n_restarts=1)
    fitted = np.asarray(gp.length_scales)
    assert np.all(fitted > true_scale / 2) and np.all(fitted < true_scale * 2), result
    assert gp.noise_variance == pytest.approx(0.05**2, rel=1.0)
    assert result["log_marginal_likelihood"] == pytest.approx(gp.log_marginal_likelihood(X, Y))
    # the fitted values are the ones used online, and a worse setting has a lower likelihood
    worse = SlidingWindowGP(length_scales=np.full(dims, 2.0), mean="zero")
    assert worse.log_marginal_likelihood(X, Y) < result["log_marginal_likelihood"]


def test_set_hyperparameters_refactorises_window():
    X, Y = _stream(60, seed=9)
    gp = SlidingWindowGP(window=30, length_scales=1.0)
    for x, y in zip(X, Y):
        gp.add(x, y)
    gp.set_hyperparameters(length_scales=LENGTH_SCALES, noise_variance=1e-3)
    _assert_matches_scratch(gp, X[-30:], Y[-30:], X[:5])
    for x, y in zip(X[:10], Y[:10]):
        gp.add(x, y)
    _assert_matches_scratch(gp, np.vstack([X[40:], X[:10]]), np.vstack([Y[40:], Y[:10]]), X[5:9])


# --------------------------------------------------------------------------- persistence
def test_save_load_round_trip_is_exact(tmp_path):
    X, Y = _stream(120, seed=6)
    gp = SlidingWindowGP(window=50, length_scales=LENGTH_SCALES, refactor_every=33)
    for x, y in zip(X[:80], Y[:80]):
        gp.add(x, y)
    x_query = np.random.default_rng(3).uniform(-1, 1, (7, 3))
    before = gp.predict(x_query, return_std=True)
    path = tmp_path / "gp.npz"
    gp.save(path)
    loaded = SlidingWindowGP.load(path)
    after = loaded.predict(x_query, return_std=True)
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])
    assert len(loaded) == len(gp) and loaded.adds_since_refactor == gp.adds_since_refactor
    for x, y in zip(X[80:], Y[80:]):      # both continue identically (same refactor schedule)
        gp.add(x, y)
        loaded.add(x, y)
    np.testing.assert_array_equal(gp.predict(x_query), loaded.predict(x_query))
    empty_path = tmp_path / "empty.npz"
    SlidingWindowGP(window=5, length_scales=0.3).save(empty_path)
    empty = SlidingWindowGP.load(empty_path)
    assert len(empty) == 0 and empty.window == 5 and empty.length_scales == 0.3


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize("kwargs, name", [
    ({"window": 0}, "window"),
    ({"window": 2.5}, "window"),
    ({"window": True}, "window"),
    ({"length_scales": 0.0}, "length_scales"),
    ({"length_scales": [1.0, -1.0]}, "length_scales"),
    ({"length_scales": [[1.0]]}, "length_scales"),
    ({"length_scales": float("nan")}, "length_scales"),
    ({"signal_variance": -1.0}, "signal_variance"),
    ({"noise_variance": 0.0}, "noise_variance"),
    ({"noise_variance": float("inf")}, "noise_variance"),
    ({"mean": "median"}, "mean"),
    ({"refactor_every": 0}, "refactor_every"),
])
def test_bad_constructor_arguments_raise(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SlidingWindowGP(**kwargs)


def test_bad_samples_raise():
    gp = SlidingWindowGP(length_scales=[1.0, 1.0])
    with pytest.raises(ValueError, match="x must have 2"):
        gp.add([0.0, 1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="y must be finite"):
        gp.add([0.0, 1.0], [np.nan])
    gp.add([0.0, 1.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="y must have 2"):
        gp.add([0.0, 1.0], [1.0])
    with pytest.raises(ValueError, match="x must have 2"):
        gp.predict(np.zeros((3, 4)))
