"""Checks of ``soft_gym.sensing.wang2023.femp`` that mutation testing found missing
(docs/mutation_testing.md).

Each test pins a documented behaviour of the F-emp estimator (wang2023 Section II-C) that a
surviving mutant changed unnoticed: the documented defaults (200 hidden nodes, 1.4 px selective
update), the hyper-parameters reaching the OS-ELM, quaternion labels kept in one hemisphere,
the output standardisation, saving into a new or an existing directory and resuming online
learning after loading, and errors that name their parameter first. The data are synthetic:
smooth maps from random "wavelength shifts" to a pose, so each test runs in milliseconds.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from soft_gym.sensing.wang2023.femp import FEmpEstimator


def _poses(n: int, seed: int = 0, flip: bool = True):
    """Shifts (n, 6) -> position (m) and a unit quaternion; with ``flip`` about half the
    quaternion labels are given as ``-q`` (the same rotation on the other hemisphere)."""
    rng = np.random.default_rng(seed)
    shifts = rng.uniform(-1.0, 1.0, (n, 6))
    positions = np.stack([0.02 * shifts[:, 0] + 0.005 * shifts[:, 1] ** 2,
                          0.02 * shifts[:, 2],
                          0.1 + 0.01 * np.sin(shifts[:, 3])], axis=1)
    rotvecs = 0.4 * np.stack([shifts[:, 0], shifts[:, 2], 0.5 * shifts[:, 4]], axis=1)
    quaternions = Rotation.from_rotvec(rotvecs).as_quat()
    quaternions[quaternions[:, 3] < 0] *= -1  # all with w >= 0 ...
    if flip:  # ... then about half sent to the other hemisphere
        quaternions[rng.random(n) < 0.5] *= -1
    return shifts, positions, quaternions


def _angle(q0: np.ndarray, q1: np.ndarray) -> float:
    """Rotation angle (rad) between two quaternions, whatever their signs."""
    return float((Rotation.from_quat(q0).inv() * Rotation.from_quat(q1)).magnitude())


def test_defaults_and_a_fresh_estimator() -> None:
    """wang2023's 200 hidden nodes and 1.4 px threshold, the OS-ELM defaults, seed 0; a fresh
    estimator holds no learned state, is not ready and has counted no update."""
    estimator = FEmpEstimator()
    elm = estimator.elm
    assert (elm.n_hidden, elm.forgetting, elm.ridge, elm.seed) == (200, 0.999, 1e-3, 0)
    assert estimator.update_threshold_px == 1.4
    assert not estimator.is_ready
    assert estimator.output_mean is None and estimator.output_scale is None
    assert estimator.reference_quaternion is None
    assert estimator.updates == 0


def test_hyper_parameters_reach_the_elm() -> None:
    """Every constructor argument but the threshold is handed to the OS-ELM unchanged."""
    estimator = FEmpEstimator(n_hidden=17, forgetting=0.9, ridge=0.25, seed=5)
    elm = estimator.elm
    assert (elm.n_hidden, elm.forgetting, elm.ridge, elm.seed) == (17, 0.9, 0.25, 5)


def test_default_threshold_is_one_point_four_pixels() -> None:
    """With the default bound an ``e_S`` of 1.39 px updates the model and 1.4 px does not."""
    shifts, positions, quaternions = _poses(80)
    estimator = FEmpEstimator(n_hidden=20)
    estimator.initialize(shifts[:60], positions[:60], quaternions[:60])
    assert not estimator.update(shifts[70], positions[70], quaternions[70], 1.4)
    assert estimator.update(shifts[70], positions[70], quaternions[70], 1.39)
    assert estimator.updates == 1


def test_output_mean_is_the_mean_of_hemisphere_aligned_labels() -> None:
    """Targets are ``[position, q]`` with each ``q`` replaced by ``-q`` where its dot product
    with the normalised mean label quaternion is negative; ``output_mean`` is their mean."""
    shifts, positions, quaternions = _poses(200, seed=1)
    estimator = FEmpEstimator(n_hidden=30)
    estimator.initialize(shifts, positions, quaternions)
    reference = quaternions.mean(axis=0) / np.linalg.norm(quaternions.mean(axis=0))
    np.testing.assert_allclose(estimator.reference_quaternion, reference, rtol=1e-12)
    aligned = np.array([q if q @ reference >= 0 else -q for q in quaternions])
    assert np.all(aligned @ reference > 0), "test data must not sit on the hemisphere boundary"
    expected = np.r_[positions.mean(axis=0), aligned.mean(axis=0)]
    np.testing.assert_allclose(estimator.output_mean, expected, rtol=1e-12, atol=1e-15)


def test_labels_on_both_hemispheres_are_learnt_as_one_continuous_target() -> None:
    """Labels given as ``q`` or ``-q`` at random (the same rotations) give the same model as
    labels all on one hemisphere: the same positions and the same rotations, to rounding."""
    shifts, positions, quaternions = _poses(300, seed=2)
    _, _, same_side = _poses(300, seed=2, flip=False)
    assert np.any(np.sum(quaternions * same_side, axis=1) < 0), "some labels must be flipped"
    mixed = FEmpEstimator(n_hidden=60)
    mixed.initialize(shifts, positions, quaternions)
    plain = FEmpEstimator(n_hidden=60)
    plain.initialize(shifts, positions, same_side)
    for k in range(0, 300, 7):
        position, quaternion = mixed.predict(shifts[k])
        expected_position, expected_quaternion = plain.predict(shifts[k])
        np.testing.assert_allclose(position, expected_position, rtol=1e-9, atol=1e-12)
        angle = _angle(quaternion, expected_quaternion)
        assert angle < 1e-6, f"sample {k}: rotations differ by {angle:.3g} rad"


def test_a_label_that_never_changes_is_reproduced_exactly() -> None:
    """An output that is constant over the calibration (here the orientation: the arm never
    turns) is predicted exactly, for any input, and nothing is divided by its zero spread."""
    shifts, positions, _ = _poses(60, seed=3)
    quaternion = np.array([0.5, -0.5, 0.5, 0.5])  # exact in binary: its spread is exactly zero
    estimator = FEmpEstimator(n_hidden=25)
    estimator.initialize(shifts, positions, np.tile(quaternion, (60, 1)))
    assert np.all(np.isfinite(estimator.output_scale)) and np.all(estimator.output_scale > 0)
    for probe in np.random.default_rng(4).uniform(-2.0, 2.0, (5, 6)):
        position, predicted = estimator.predict(probe)
        assert np.all(np.isfinite(position))
        np.testing.assert_allclose(predicted, quaternion, rtol=0, atol=1e-12)


def test_online_update_accepts_a_label_on_the_other_hemisphere() -> None:
    """An online label ``-q`` is the same rotation as ``q``: both updates leave the same model."""
    shifts, positions, quaternions = _poses(100, seed=5, flip=False)
    a, b = FEmpEstimator(n_hidden=30), FEmpEstimator(n_hidden=30)
    a.initialize(shifts[:80], positions[:80], quaternions[:80])
    b.initialize(shifts[:80], positions[:80], quaternions[:80])
    for k in range(80, 100):
        assert a.update(shifts[k], positions[k], quaternions[k], 0.5)
        assert b.update(shifts[k], positions[k], -quaternions[k], 0.5)
    np.testing.assert_allclose(a.elm.beta, b.elm.beta, rtol=1e-10, atol=1e-12)


def test_save_creates_parent_directories_overwrites_and_resumes_learning(tmp_path) -> None:
    """``save`` creates missing parent directories and may write over an earlier save; a loaded
    estimator keeps its update count and continues online learning exactly like the original."""
    shifts, positions, quaternions = _poses(120, seed=6)
    estimator = FEmpEstimator(n_hidden=20, update_threshold_px=0.9)
    estimator.initialize(shifts[:80], positions[:80], quaternions[:80])
    target = tmp_path / "nested" / "deeper" / "femp"
    estimator.save(target)
    estimator.update(shifts[80], positions[80], quaternions[80], 0.2)
    estimator.save(target)  # into the existing directory
    loaded = FEmpEstimator.load(target)
    assert loaded.updates == 1 and loaded.update_threshold_px == 0.9
    np.testing.assert_array_equal(loaded.reference_quaternion, estimator.reference_quaternion)
    for k in range(81, 120):
        assert loaded.update(shifts[k], positions[k], quaternions[k], 0.2)
        assert estimator.update(shifts[k], positions[k], quaternions[k], 0.2)
    assert loaded.updates == estimator.updates == 40
    for k in (5, 100):
        np.testing.assert_allclose(loaded.predict(shifts[k])[0], estimator.predict(shifts[k])[0],
                                   rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("which, name", [(0, "shifts_nm"), (1, "positions_m"),
                                         (2, "quaternions")])
def test_non_finite_calibration_data_name_their_argument(which: int, name: str) -> None:
    arrays = list(_poses(20, seed=7))
    arrays[which] = arrays[which].copy()
    arrays[which][3, 0] = np.nan
    with pytest.raises(ValueError, match=rf"^{name} must be finite"):
        FEmpEstimator(n_hidden=5).initialize(*arrays)


def test_errors_name_their_subject_first() -> None:
    with pytest.raises(ValueError, match=r"^update_threshold_px must be"):
        FEmpEstimator(update_threshold_px=-1.0)
    with pytest.raises(ValueError, match=r"^the F-emp estimator is not initialised"):
        FEmpEstimator().predict(np.zeros(6))
    with pytest.raises(ValueError, match=r"^the F-emp estimator is not initialised"):
        FEmpEstimator().update(np.zeros(6), np.zeros(3), np.r_[0.0, 0, 0, 1], 0.1)
