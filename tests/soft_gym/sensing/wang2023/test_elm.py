"""OS-ELM with forgetting against batch weighted least squares and plain ridge regression."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.sensing.wang2023.elm import OSELM


def _data(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 17))
    z = np.stack([np.sin(x[:, 0] + x[:, 1]), x[:, 2] * x[:, 3], np.cos(x[:, 4]) - x[:, 5]], axis=1)
    return x, z


def _weighted_ridge(model: OSELM, x: np.ndarray, z: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Reference: argmin sum_j weight_j ||z_j - phi_j beta||^2 + lambda ||beta||^2, solved whole."""
    phi = model.features(x)
    information = phi.T @ (weights[:, None] * phi) + model.ridge * np.eye(model.n_hidden)
    return np.linalg.solve(information, phi.T @ (weights[:, None] * z))


@pytest.mark.parametrize("forgetting", [1.0, 0.99])
def test_recursive_updates_equal_batch_weighted_least_squares(forgetting):
    x, z = _data(300)
    n0, updates = 200, 100
    model = OSELM(n_hidden=60, forgetting=forgetting, ridge=1e-3, refactor_every=100, seed=1)
    model.fit(x[:n0], z[:n0])
    for i in range(n0, n0 + updates):
        model.update(x[i], z[i])
    # initial samples carry w^k, the j-th update w^(k - j)
    weights = np.r_[np.full(n0, forgetting**updates), forgetting ** np.arange(updates - 1, -1, -1)]
    reference = _weighted_ridge(model, x, z, weights)
    np.testing.assert_allclose(model.beta, reference, rtol=0, atol=1e-6 * np.abs(reference).max())


def test_pure_recursion_between_refactors_tracks_the_batch_solution():
    x, z = _data(300, seed=2)
    model = OSELM(n_hidden=60, forgetting=0.995, ridge=1e-3, refactor_every=10_000, seed=1)
    model.fit(x[:200], z[:200])
    for i in range(200, 300):
        model.update(x[i], z[i])
    weights = np.r_[np.full(200, 0.995**100), 0.995 ** np.arange(99, -1, -1)]
    reference = _weighted_ridge(model, x, z, weights)
    # the Sherman-Morrison recursion omits only the (1 - w) lambda ridge top-ups, which the
    # periodic refactorisation restores
    assert np.abs(model.beta - reference).max() < 1e-2 * np.abs(reference).max()


def test_without_forgetting_matches_numpy_ridge_regression():
    x, z = _data(250, seed=3)
    model = OSELM(n_hidden=40, forgetting=1.0, ridge=1e-2, refactor_every=1, seed=4)
    model.fit(x[:150], z[:150])
    for i in range(150, 250):
        model.update(x[i], z[i])
    phi = model.features(x)
    ridge = np.linalg.lstsq(np.vstack([phi, np.sqrt(1e-2) * np.eye(40)]),
                            np.vstack([z, np.zeros((40, 3))]), rcond=None)[0]
    np.testing.assert_allclose(model.beta, ridge, atol=1e-8 * np.abs(ridge).max())


def _fbg_like(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """17 sinusoidal 'grating' signals of a 3-D bending state, and a smooth pose of that state."""
    rng = np.random.default_rng(seed)
    latent = rng.uniform(-1, 1, (n, 3))
    psi = np.linspace(0, 4 * np.pi, 17)
    x = latent[:, :1] * np.cos(psi) + latent[:, 1:2] * np.sin(psi) + 0.3 * latent[:, 2:]
    z = np.stack([np.sin(latent[:, 0]), latent[:, 1] * latent[:, 2], np.cos(latent[:, 1])], 1)
    return x, z


def test_learns_a_smooth_map_and_forgetting_follows_a_change():
    x, z = _fbg_like(1200, seed=5)
    model = OSELM(n_hidden=200, forgetting=1.0, ridge=1e-4, seed=0).fit(x[:800], z[:800])
    error = np.abs(model.predict(x[800:]) - z[800:]).mean()
    assert error < 0.02 * np.abs(z).mean()
    # the map shifts by +0.5 (say a load changed the arm): forgetting follows it, no forgetting
    # keeps averaging it with the old data
    errors = {}
    for forgetting in (1.0, 0.99):
        model = OSELM(n_hidden=200, forgetting=forgetting, ridge=1e-4, seed=0)
        model.fit(x[:800], z[:800])
        for i in range(800, 1200):
            model.update(x[i], z[i] + 0.5)
        errors[forgetting] = np.abs(model.predict(x[:200]) - (z[:200] + 0.5)).mean()
    assert errors[0.99] < 0.1 and errors[0.99] < errors[1.0] / 3


def test_save_and_load_predict_identically(tmp_path):
    x, z = _data(300, seed=6)
    model = OSELM(n_hidden=50, seed=2).fit(x[:200], z[:200])
    for i in range(200, 237):
        model.update(x[i], z[i])
    model.save(tmp_path / "elm.npz")
    loaded = OSELM.load(tmp_path / "elm.npz")
    np.testing.assert_array_equal(loaded.predict(x), model.predict(x))
    model.update(x[250], z[250])
    loaded.update(x[250], z[250])
    np.testing.assert_array_equal(loaded.beta, model.beta)


@pytest.mark.parametrize("kwargs, name", [({"n_hidden": 0}, "n_hidden"),
                                          ({"forgetting": 1.5}, "forgetting"),
                                          ({"ridge": -1.0}, "ridge"),
                                          ({"refactor_every": 0}, "refactor_every")])
def test_bad_parameters_raise(kwargs, name):
    with pytest.raises(ValueError, match=name):
        OSELM(**kwargs)


def test_bad_data_raise():
    model = OSELM(n_hidden=10)
    with pytest.raises(ValueError, match="not initialised"):
        model.predict(np.zeros(3))
    with pytest.raises(ValueError, match="inputs"):
        model.fit(np.full((5, 3), np.nan), np.zeros((5, 2)))
    model.fit(np.random.default_rng(0).random((20, 3)), np.zeros((20, 2)))
    with pytest.raises(ValueError, match="target"):
        model.update(np.zeros(3), np.zeros(3))
