"""LWPR against batch weighted least squares, on the cross function, and its persistence/checks."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

from agents.learners import LWPR


def _cross(X: np.ndarray) -> np.ndarray:
    """The 2-D benchmark of vijayakumar2005: a cross of two ridges and a central bump."""
    x1, x2 = X[:, 0], X[:, 1]
    return np.maximum.reduce([np.exp(-10.0 * x1**2), np.exp(-50.0 * x2**2),
                              1.25 * np.exp(-5.0 * (x1**2 + x2**2))])


def _cross_grid() -> np.ndarray:
    g = np.linspace(-1.0, 1.0, 41)
    return np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)


def _weighted_least_squares(X, Y, weights, X_query):
    """Slow reference: argmin_b sum_i w_i (y_i - [1, x_i] b)^2 by lstsq, evaluated at X_query."""
    A = np.hstack([np.ones((len(X), 1)), X])
    root = np.sqrt(weights)
    coef = np.linalg.lstsq(A * root[:, None], Y * root, rcond=None)[0]
    return np.hstack([np.ones((len(X_query), 1)), X_query]) @ coef


def _single_field(d: int, D: np.ndarray, **kwargs) -> LWPR:
    """One wide field with a fixed metric and no forgetting (it never creates a second one)."""
    return LWPR(d, init_d=D, w_gen=1e-3, update_d=False, init_lambda=1.0, final_lambda=1.0,
                **kwargs)


def _train(model: LWPR, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    return np.array([model.update(x, y) for x, y in zip(X, Y)])


# --------------------------------------------------------------------------- batch reference
@pytest.mark.parametrize("d, tolerance", [(1, 1e-3), (2, 1e-2)])
def test_single_field_matches_batch_weighted_least_squares(d, tolerance):
    """A field with fixed D, all d projections and no forgetting is weighted linear regression.

    The field is created by the first sample (which only sets its offset, with weight 1e-10),
    so the reference weighs samples 1.. with the field's Gaussian. At the weighted mean of the
    inputs both give the weighted mean of the outputs, to rounding. Elsewhere the incremental
    PLS is only asymptotically the batch fit: its statistics are accumulated with running means
    and, for d > 1, with projection directions u_j that keep moving as data arrive (earlier
    contributions are not recomputed, as in klanke2008). The bounds are ~3x the largest gap
    seen over several data seeds, and far below the gap between the weighted and an unweighted
    fit.
    """
    rng = np.random.default_rng(3)
    n = 6000
    scale = np.array([1.0, 0.4])[:d]
    X = rng.uniform(-1.0, 1.0, (n, d)) * scale
    X[0] = np.array([0.6, 0.2])[:d]                  # the field's centre
    Y = np.sin(2.0 * X[:, 0]) + np.cos(3.0 * X[:, -1]) * (d > 1) + 0.1 * rng.standard_normal(n)
    D = np.diag([3.0, 12.0][:d])
    model = _single_field(d, D)
    _train(model, X, Y)
    assert model.n_receptive_fields == 1

    centre = X[0]
    weights = np.exp(-0.5 * np.einsum("ni,ij,nj->n", X[1:] - centre, D, X[1:] - centre))
    assert weights.min() > 1e-3                      # every sample updated the field
    X_query = rng.uniform(-1.0, 1.0, (100, d)) * scale
    reference = _weighted_least_squares(X[1:], Y[1:], weights, X_query)
    unweighted = _weighted_least_squares(X[1:], Y[1:], np.ones(n - 1), X_query)
    prediction = model.predict_batch(X_query)[:, 0]
    gap = np.max(np.abs(prediction - reference))
    print(f"d={d}: max |LWPR - WLS| = {gap:.2e}, max |WLS - OLS| = "
          f"{np.max(np.abs(reference - unweighted)):.2e}")
    assert gap < tolerance
    assert gap < 0.05 * np.max(np.abs(reference - unweighted))

    x_bar = weights @ X[1:] / weights.sum()
    at_mean = _weighted_least_squares(X[1:], Y[1:], weights, x_bar[None, :])[0]
    assert abs(model.predict(x_bar)[0] - at_mean) < 1e-10


@pytest.mark.parametrize("slope, forgetting, n", [(2.5, 1.0, 500), (-1.5, 0.99, 4000)])
def test_linear_function_to_machine_precision(slope, forgetting, n):
    """A noise-free line is reproduced to ~1e-10 by one field (inputs and outputs scaled).

    With a negative slope the single PLS direction flips sign after the second sample, so the
    first samples' statistics are inconsistent; forgetting (lambda = 0.99) removes them.
    """
    rng = np.random.default_rng(0)
    x = rng.uniform(0.0, 200.0, n)
    y = slope * x - 70.0
    model = LWPR(1, init_d=0.5, w_gen=1e-3, update_d=False, init_lambda=forgetting,
                 final_lambda=forgetting, norm_in=100.0, norm_out=50.0)
    _train(model, x, y)
    assert model.n_receptive_fields == 1
    x_query = np.linspace(0.0, 200.0, 21)
    error = np.abs(model.predict_batch(x_query)[:, 0] - (slope * x_query - 70.0))
    assert np.max(error) < 1e-10 * np.max(np.abs(y))


# --------------------------------------------------------------------------- cross function
@pytest.mark.parametrize("n, bound", [(10_000, 0.05),
                                      pytest.param(50_000, 0.05, marks=pytest.mark.slow)])
def test_cross_function(n, bound):
    """The 2-D cross with noise sd 0.1 (klanke2008's example settings), nMSE on a clean grid."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1.0, 1.0, (n, 2))
    Y = _cross(X) + 0.1 * rng.standard_normal(n)
    model = LWPR(2, init_d=50.0, init_alpha=250.0, w_gen=0.2)
    start = time.perf_counter()
    _train(model, X, Y)
    elapsed = time.perf_counter() - start
    grid = _cross_grid()
    truth = _cross(grid)
    nmse = np.mean((model.predict_batch(grid)[:, 0] - truth) ** 2) / np.var(truth)
    print(f"cross, {n} samples: nMSE {nmse:.4f}, {model.n_receptive_fields} fields, "
          f"{n / elapsed:.0f} updates/s")
    assert nmse < bound
    assert 20 <= model.n_receptive_fields <= 150
    mean, conf = model.predict_batch(grid, return_confidence=True)
    assert np.all(np.isfinite(conf)) and np.all(conf > 0)
    assert 0.05 < np.median(conf) < 0.3          # about the noise sd
    far_mean, far_conf = model.predict([5.0, 5.0], return_confidence=True)
    assert far_mean[0] == 0.0 and far_conf[0] == np.inf


def test_full_metric_with_meta_learning_also_fits_the_cross():
    rng = np.random.default_rng(1)
    X = rng.uniform(-1.0, 1.0, (5000, 2))
    Y = _cross(X) + 0.1 * rng.standard_normal(5000)
    model = LWPR(2, init_d=25.0, init_alpha=250.0, w_gen=0.2, diag_only=False, meta=True)
    _train(model, X, Y)
    grid = _cross_grid()
    truth = _cross(grid)
    nmse = np.mean((model.predict_batch(grid)[:, 0] - truth) ** 2) / np.var(truth)
    assert nmse < 0.08
    _, D = model.receptive_fields()
    assert np.any(np.abs(D[:, 0, 1]) > 1e-6)      # off-diagonal metric entries were adapted
    assert np.all(np.linalg.eigvalsh(D) > 0)


# --------------------------------------------------------------------------- structure
def test_field_creation_and_pruning_of_the_narrower_field():
    model = LWPR(1, init_d=1.0, w_gen=0.5, w_prune=0.8, update_d=False)
    model.update(0.0, 0.0)
    model.update(1.2, 1.0)                 # w = exp(-0.72) = 0.49 <= w_gen: a second field
    assert model.n_receptive_fields == 2
    model._outputs[0].a["D"][1] = 1.2      # make the field at 1.2 the narrower one
    model._outputs[0].a["M"][1] = np.sqrt(1.2)
    model.update(0.6, 0.5)                 # activations 0.835 and 0.806, both > w_prune
    assert model.n_receptive_fields == 1 and model.n_pruned == 1
    np.testing.assert_array_equal(model.receptive_fields()[0], [[0.0]])


def test_receptive_fields_are_reported_in_input_units():
    model = LWPR(2, 2, init_d=[4.0, 9.0], norm_in=[2.0, 3.0], update_d=False)
    model.update([2.0, -3.0], [1.0, 2.0])
    model.update([20.0, -3.0], [1.0, 2.0])
    centres, D = model.receptive_fields(output=1)
    np.testing.assert_allclose(centres, [[2.0, -3.0], [20.0, -3.0]])
    np.testing.assert_allclose(D, [np.eye(2), np.eye(2)])
    every_centre, every_D = model.receptive_fields()
    assert every_centre.shape == (4, 2) and every_D.shape == (4, 2, 2)
    np.testing.assert_allclose(every_centre[2:], centres)


def test_update_returns_the_prediction_made_during_the_update():
    model = LWPR(1, w_gen=0.2)
    assert model.update(0.0, 3.0)[0] == 0.0           # no field yet
    for x in np.linspace(-0.1, 0.1, 10):
        last = model.update(x, 3.0)
    assert last[0] == pytest.approx(3.0, abs=1e-9)


# --------------------------------------------------------------------------- outputs, scaling
def test_outputs_are_independent_models():
    rng = np.random.default_rng(5)
    X = rng.uniform(-1.0, 1.0, (1500, 2))
    Y = np.stack([_cross(X), np.sin(3.0 * X[:, 0]) * X[:, 1]], axis=1)
    Y += 0.05 * rng.standard_normal(Y.shape)
    settings = dict(init_d=30.0, w_gen=0.2, diag_only=False)
    joint = LWPR(2, 2, norm_out=[1.0, 2.0], **settings)
    separate = [LWPR(2, 1, norm_out=scale, **settings) for scale in (1.0, 2.0)]
    during = _train(joint, X, Y)
    for j, model in enumerate(separate):
        np.testing.assert_array_equal(during[:, j], _train(model, X, Y[:, j])[:, 0])
    grid = _cross_grid()
    mean, conf = joint.predict_batch(grid, return_confidence=True)
    for j, model in enumerate(separate):
        single_mean, single_conf = model.predict_batch(grid, return_confidence=True)
        np.testing.assert_array_equal(mean[:, j], single_mean[:, 0])
        np.testing.assert_array_equal(conf[:, j], single_conf[:, 0])
    assert joint.fields_per_output == tuple(m.n_receptive_fields for m in separate)


def test_normalisation_equals_learning_on_scaled_data():
    rng = np.random.default_rng(2)
    scale_in, scale_out = np.array([10.0, 0.1]), 4.0
    X = rng.uniform(-1.0, 1.0, (800, 2))
    Y = _cross(X)
    scaled = LWPR(2, norm_in=scale_in, norm_out=scale_out, w_gen=0.2)
    plain = LWPR(2, w_gen=0.2)
    _train(scaled, X * scale_in, Y * scale_out)
    _train(plain, X, Y)
    grid = _cross_grid()
    np.testing.assert_allclose(scaled.predict_batch(grid * scale_in),
                               scale_out * plain.predict_batch(grid), rtol=1e-9, atol=1e-12)


@pytest.mark.smoke
def test_predict_matches_predict_batch_and_empty_model():
    model = LWPR(2, 2)
    mean, conf = model.predict([0.1, 0.2], return_confidence=True)
    assert mean.tolist() == [0.0, 0.0] and np.all(np.isinf(conf))
    rng = np.random.default_rng(4)
    X = rng.uniform(-1.0, 1.0, (600, 2))
    _train(model, X, np.stack([_cross(X), -_cross(X)], axis=1))
    queries = rng.uniform(-1.0, 1.0, (7, 2))
    batch = model.predict_batch(queries, return_confidence=True)
    for i, x in enumerate(queries):
        single = model.predict(x, return_confidence=True)
        np.testing.assert_array_equal(single[0], batch[0][i])
        np.testing.assert_array_equal(single[1], batch[1][i])


# --------------------------------------------------------------------------- persistence
def _trained_model(n: int = 1500) -> tuple[LWPR, np.random.Generator]:
    rng = np.random.default_rng(11)
    model = LWPR(2, 2, init_d=[20.0, 40.0], w_gen=0.25, diag_only=False, meta=True,
                 norm_in=[1.0, 2.0], norm_out=[0.5, 3.0])
    X = rng.uniform(-1.0, 1.0, (n, 2))
    _train(model, X, np.stack([_cross(X), X[:, 0] * X[:, 1]], axis=1))
    return model, rng


def test_save_load_gives_identical_predictions_and_updates(tmp_path):
    model, rng = _trained_model()
    path = tmp_path / "model.lwpr"                     # written under exactly this name
    model.save(path)
    loaded = LWPR.load(path)
    grid = _cross_grid()
    for a, b in zip(model.predict_batch(grid, return_confidence=True),
                    loaded.predict_batch(grid, return_confidence=True)):
        assert np.array_equal(a, b)
    assert loaded.fields_per_output == model.fields_per_output
    assert loaded.samples_seen == model.samples_seen

    X = rng.uniform(-1.2, 1.2, (500, 2))
    Y = np.stack([_cross(X), X[:, 0] * X[:, 1]], axis=1) + 0.05 * rng.standard_normal((500, 2))
    assert np.array_equal(_train(model, X, Y), _train(loaded, X, Y))
    assert loaded.fields_per_output == model.fields_per_output
    for a, b in zip(model.predict_batch(grid, return_confidence=True),
                    loaded.predict_batch(grid, return_confidence=True)):
        assert np.array_equal(a, b)


def test_save_load_through_an_open_binary_file():
    model, _ = _trained_model(300)
    buffer = io.BytesIO()
    model.save(buffer)
    loaded = LWPR.load(io.BytesIO(buffer.getvalue()))
    grid = _cross_grid()
    assert np.array_equal(model.predict_batch(grid), loaded.predict_batch(grid))
    with pytest.raises(ValueError, match="BytesIO"):
        LWPR.load(io.BytesIO(b"not an archive"))


def test_corrupt_or_foreign_files_are_refused(tmp_path):
    model, _ = _trained_model(200)
    good = tmp_path / "good.npz"
    model.save(good)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"this is not a zip archive")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good.read_bytes()[:300])
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, X=np.zeros(3))
    array_file = tmp_path / "array.npy"
    np.save(array_file, np.zeros(3))
    broken = tmp_path / "broken.npz"
    with np.load(good) as data:
        contents = {name: data[name] for name in data.files}
    contents["out0/U"] = contents["out0/U"][:, :1]
    np.savez(broken, **contents)
    for path in (garbage, truncated, foreign, array_file, broken, tmp_path / "missing.npz"):
        with pytest.raises(ValueError, match=str(path.name)):
            LWPR.load(path)


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, match", [
    (dict(input_dim=0), "input_dim"),
    (dict(input_dim=2.0), "input_dim"),
    (dict(output_dim=True), "output_dim"),
    (dict(init_d=-1.0), "init_d"),
    (dict(init_d=[1.0, 0.0]), "init_d"),
    (dict(init_d=[[1.0, 0.5], [0.5, 1.0]]), "init_d.*diag_only"),
    (dict(init_d=[[1.0, 2.0], [2.0, 1.0]], diag_only=False), "init_d"),
    (dict(init_d="25"), "init_d"),
    (dict(init_alpha=0.0), "init_alpha"),
    (dict(init_alpha=np.ones((3, 3))), "init_alpha"),
    (dict(w_gen=-0.1), r"w_gen.*-0\.1"),
    (dict(w_gen=1.0), "w_gen"),
    (dict(w_prune=0.05), "w_prune"),
    (dict(init_lambda=1.5), r"init_lambda.*1\.5"),
    (dict(final_lambda=0.0), "final_lambda"),
    (dict(tau_lambda=-0.1), "tau_lambda"),
    (dict(penalty=-1e-6), "penalty"),
    (dict(penalty=float("nan")), "penalty"),
    (dict(diag_only=1), "diag_only"),
    (dict(meta="yes"), "meta"),
    (dict(update_d=None), "update_d"),
    (dict(meta_rate=0.0), "meta_rate"),
    (dict(max_projections=3), "max_projections"),
    (dict(max_projections=0), "max_projections"),
    (dict(add_threshold=1.5), "add_threshold"),
    (dict(init_s2=0.0), "init_s2"),
    (dict(norm_in=[1.0, -1.0]), "norm_in"),
    (dict(norm_out=[1.0, 1.0]), "norm_out"),
])
def test_bad_hyperparameters(kwargs, match):
    settings = dict(input_dim=2)
    settings.update(kwargs)
    with pytest.raises(ValueError, match=match):
        LWPR(**settings)


@pytest.mark.parametrize("x, y, match", [
    ([0.1, np.nan], 1.0, "x"),
    ([0.1, np.inf], 1.0, "x"),
    ([0.1, 0.2, 0.3], 1.0, r"x.*\(2,\)"),
    ([[0.1, 0.2]], 1.0, "x"),
    ([0.1, 0.2], np.nan, "y"),
    ([0.1, 0.2], [1.0, 2.0], r"y.*\(1,\)"),
    ("ab", 1.0, "x"),
])
def test_bad_samples(x, y, match):
    model = LWPR(2)
    with pytest.raises(ValueError, match=match):
        model.update(x, y)
    assert model.samples_seen == 0 and model.n_receptive_fields == 0


def test_bad_queries():
    model = LWPR(2)
    model.update([0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="x"):
        model.predict([np.nan, 0.0])
    with pytest.raises(ValueError, match="X"):
        model.predict_batch(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="cutoff"):
        model.predict([0.0, 0.0], cutoff=-1.0)
    with pytest.raises(ValueError, match="output"):
        model.receptive_fields(output=1)
    with pytest.raises(ValueError, match="output"):
        model.receptive_fields(output=True)
