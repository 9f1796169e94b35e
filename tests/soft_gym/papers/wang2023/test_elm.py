"""OS-ELM with forgetting against batch weighted least squares and plain ridge regression."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.papers.wang2023.elm import OSELM


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


@pytest.mark.smoke
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


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour of the OS-ELM that a surviving mutant changed unnoticed: the
# hidden layer is eq. (3) of wang2023 on inputs standardised per feature, the random layer is fixed
# by the seed, the widths are ``width_scale`` times the spread times U(0.5, 1.5), the bookkeeping
# (``updates``, ``samples_since_refactor``) counts what its name says, and errors name their
# parameter first. References are written here from the module docstring.
# ==========================================================================================


def _five_input_data(n: int, n_inputs: int = 5, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, n_inputs))
    z = np.stack([np.sin(x[:, 0] + x[:, 1]), x[:, 2] * x[:, 3]], axis=1)
    return x, z


def test_defaults_and_a_fresh_model() -> None:
    """wang2023's 200 hidden nodes and the documented defaults; an unfitted model holds no
    learned state and has counted nothing."""
    model = OSELM()
    assert (model.n_hidden, model.forgetting, model.ridge, model.width_scale,
            model.refactor_every, model.seed) == (200, 0.999, 1e-3, 1.0, 50, 0)
    assert not model.is_fitted
    for name in ("centres", "widths", "input_mean", "input_scale", "beta", "information",
                 "inverse", "moment"):
        assert getattr(model, name) is None, name
    assert model.updates == 0 and model.samples_since_refactor == 0


def test_smallest_valid_sizes() -> None:
    """One hidden node and two samples are allowed (``n_hidden >= 1``, "at least 2 samples");
    fewer samples than nodes draws centres with replacement."""
    x, z = _five_input_data(2)
    model = OSELM(n_hidden=1).fit(x, z)
    assert model.predict(x).shape == (2, 2)
    model = OSELM(n_hidden=30).fit(x, z)
    assert model.centres.shape == (30, 5)


def test_duplicate_centres_are_separated_by_jitter() -> None:
    """With fewer samples than nodes several centres come from the same sample; the jitter
    drawn per centre and per input keeps them apart (identical nodes would be redundant)."""
    x, z = _five_input_data(4)
    model = OSELM(n_hidden=40, seed=3).fit(x, z)
    distances = np.linalg.norm(model.centres[:, None] - model.centres[None], axis=-1)
    assert distances[~np.eye(40, dtype=bool)].min() > 1e-3


def test_features_are_equation_3_on_standardised_inputs() -> None:
    """``phi_i(x) = exp(-||x_s - a_i||^2 / b_i)`` with ``x_s`` the input standardised by the
    training mean and standard deviation of each feature (wang2023 eq. (3))."""
    x, z = _five_input_data(300)
    model = OSELM(n_hidden=25, seed=1).fit(x, z)
    np.testing.assert_allclose(model.input_mean, x.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(model.input_scale, x.std(axis=0), rtol=1e-12)
    probe = np.random.default_rng(9).uniform(-1, 1, (7, 5))
    standard = (probe - x.mean(axis=0)) / x.std(axis=0)
    squared = ((standard[:, None, :] - model.centres[None, :, :]) ** 2).sum(axis=-1)
    np.testing.assert_allclose(model.features(probe), np.exp(-squared / model.widths),
                               rtol=1e-10)


def test_standardisation_makes_the_model_blind_to_feature_units() -> None:
    """Rescaling and offsetting each input feature (units, offsets; here scales 0.01 to 1000)
    changes nothing: the same seed gives the same predictions on the transformed inputs."""
    x, z = _five_input_data(300)
    scale = np.array([0.01, 0.3, 1.0, 50.0, 1000.0])
    offset = np.array([5.0, -2.0, 0.0, 100.0, -3e3])
    plain = OSELM(n_hidden=40, seed=2).fit(x, z)
    moved = OSELM(n_hidden=40, seed=2).fit(x * scale + offset, z)
    probe = np.random.default_rng(4).uniform(-1, 1, (20, 5))
    np.testing.assert_allclose(moved.predict(probe * scale + offset), plain.predict(probe),
                               rtol=1e-6, atol=1e-9)


def test_a_constant_input_stays_finite() -> None:
    """A feature that never changed in training (a dead grating) is left unscaled instead of
    divided by its zero standard deviation."""
    x, z = _five_input_data(100)
    x[:, 2] = 0.7
    model = OSELM(n_hidden=20).fit(x, z)
    assert model.input_scale[2] == 1.0
    assert np.all(np.isfinite(model.predict(x)))


def test_widths_follow_the_spread_times_uniform_half_to_one_and_a_half() -> None:
    """``b_i = width_scale * spread * U(0.5, 1.5)``, spread = mean squared distance of the
    standardised training inputs from their mean (= the number of varying features)."""
    x, z = _five_input_data(500)
    model = OSELM(n_hidden=400, width_scale=2.0, seed=5).fit(x, z)
    ratio = model.widths / (2.0 * 5.0)
    assert ratio.min() >= 0.5 and ratio.max() <= 1.5, (ratio.min(), ratio.max())
    assert ratio.min() < 0.55 and ratio.max() > 1.45, (ratio.min(), ratio.max())


def test_the_seed_fixes_the_random_layer() -> None:
    """Two models with the same seed on the same data are identical; another seed is not."""
    x, z = _five_input_data(200)
    a, b = OSELM(n_hidden=30, seed=7).fit(x, z), OSELM(n_hidden=30, seed=7).fit(x, z)
    np.testing.assert_array_equal(a.centres, b.centres)
    np.testing.assert_array_equal(a.widths, b.widths)
    assert not np.allclose(a.centres, OSELM(n_hidden=30, seed=8).fit(x, z).centres)


def test_counters_and_refactor_schedule() -> None:
    """``updates`` counts updates since ``fit`` (which resets it); the exact re-solve from ``K``
    happens every ``refactor_every`` samples, resetting ``samples_since_refactor``."""
    x, z = _five_input_data(100)
    model = OSELM(n_hidden=20, refactor_every=10).fit(x[:50], z[:50])
    assert model.updates == 0 and model.samples_since_refactor == 0
    for k in range(1, 10):
        model.update(x[50 + k], z[50 + k])
        assert (model.updates, model.samples_since_refactor) == (k, k)
    model.update(x[60], z[60])
    assert (model.updates, model.samples_since_refactor) == (10, 0)
    model.fit(x[:50], z[:50])
    assert model.updates == 0


def test_update_accepts_a_sample_in_any_shape() -> None:
    """One sample may come as a flat vector, a row or a column; all give the same update."""
    x, z = _five_input_data(60)
    reference = OSELM(n_hidden=20, seed=1).fit(x[:50], z[:50])
    reference.update(x[55], z[55])
    for reshape in (lambda v: v[None, :], lambda v: v[:, None]):
        model = OSELM(n_hidden=20, seed=1).fit(x[:50], z[:50])
        model.update(reshape(x[55]), reshape(z[55]))
        np.testing.assert_allclose(model.beta, reference.beta, rtol=1e-12, atol=1e-15)


def test_predict_returns_one_row_for_one_input() -> None:
    """``(l,) -> (m,)``: a single input gives its row of the batch prediction."""
    x, z = _five_input_data(60)
    model = OSELM(n_hidden=20).fit(x, z)
    single = model.predict(x[3])
    assert single.shape == (2,)
    np.testing.assert_array_equal(single, model.predict(x[3:4])[0])


def test_load_restores_the_settings(tmp_path) -> None:
    """:meth:`OSELM.load` restores every setting, the seed included."""
    x, z = _five_input_data(60)
    model = OSELM(n_hidden=20, forgetting=0.99, ridge=2e-3, width_scale=1.5, refactor_every=7,
                  seed=4).fit(x, z)
    model.save(tmp_path / "elm.npz")
    loaded = OSELM.load(tmp_path / "elm.npz")
    for name in ("n_hidden", "forgetting", "ridge", "width_scale", "refactor_every", "seed"):
        assert getattr(loaded, name) == getattr(model, name), name


@pytest.mark.parametrize("call, message", [
    (lambda: OSELM(forgetting=0.0), r"^forgetting must be within \[1e-06, 1\.0\]"),
    (lambda: OSELM(ridge=0.0), r"^ridge must be a finite number > 0"),
    (lambda: OSELM(width_scale=-1.0), r"^width_scale must be a finite number > 0"),
    (lambda: OSELM(n_hidden=0), r"^n_hidden must be an integer >= 1"),
    (lambda: OSELM().fit(np.full((5, 3), np.nan), np.zeros((5, 2))), r"^inputs must be finite"),
    (lambda: OSELM().fit(np.zeros((5, 3)), np.full((5, 2), np.inf)), r"^targets must be finite"),
    (lambda: OSELM().fit(np.zeros((5, 3)), np.zeros((4, 2))),
     r"^inputs \(n, l\) and targets \(n, m\) must have matching rows, got shapes \(5, 3\) and "
     r"\(4, 2\)"),
    (lambda: OSELM().fit(np.zeros(5), np.zeros((5, 2))),
     r"^inputs \(n, l\) and targets \(n, m\) must have matching rows"),
    (lambda: OSELM().fit(np.zeros((1, 3)), np.zeros((1, 2))),
     r"^inputs must hold at least 2 samples, got 1"),
    (lambda: OSELM().predict(np.zeros(3)),
     r"^the OSELM model is not initialised: call fit\(inputs, targets\) first"),
])
def test_errors_name_the_parameter_first(call, message) -> None:
    """Errors start with the parameter's name (soft_gym._validation's convention)."""
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize("inputs, target, message", [
    (np.full(5, np.nan), np.zeros(2), r"^inputs must be finite"),
    (np.zeros(5), np.array([0.0, np.nan]), r"^target must be finite"),
])
def test_update_errors_name_the_parameter_first(inputs, target, message) -> None:
    x, z = _five_input_data(20)
    model = OSELM(n_hidden=10).fit(x, z)
    with pytest.raises(ValueError, match=message):
        model.update(inputs, target)
