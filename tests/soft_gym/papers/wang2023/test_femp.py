"""F-emp estimator: learns the tip pose from simulated FBG readings; selective updates."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from soft_gym.robots import get_preset
from soft_gym.papers.wang2023.femp import FEmpEstimator
from soft_gym.sensors.fbg import FBGFiber
from soft_gym.engines.pybullet.simulator import ArmSimulator


@pytest.fixture(scope="module")
def exploration():
    """wang2023 driven through a breathing spiral in pressure space: FBG shifts and true poses."""
    spec = get_preset("wang2023")
    sim = ArmSimulator(spec)
    sim.reset(settle_s=0.5)
    fiber = FBGFiber(rate_hz=None)
    fiber.reset(sim, np.random.default_rng(0))
    shifts, positions, quaternions = [], [], []
    for k in range(1200):
        t = k * spec.control_period_s
        radius = 0.15 + 0.85 * (0.5 - 0.5 * np.cos(2 * np.pi * t / 30.0))
        phase = 2 * np.pi * t / 8.0 - 2 * np.pi * np.arange(3) / 3
        sim.set_pressures(radius * (0.5 + 0.5 * np.cos(phase)) * spec.p_max_pa)
        sim.step_physics(spec.control_period_s)
        shifts.append(fiber.read(sim, sim.time_s))
        position, quaternion = sim.tip_pose()
        positions.append(position)
        quaternions.append(quaternion)
    sim.close()
    return np.array(shifts, float), np.array(positions), np.array(quaternions)


def test_femp_estimates_the_tip_within_a_millimetre_after_initialisation(exploration):
    shifts, positions, quaternions = exploration
    estimator = FEmpEstimator()
    estimator.initialize(shifts[:450], positions[:450], quaternions[:450])
    errors = []
    for k in range(450, len(shifts)):
        position, quaternion = estimator.predict(shifts[k])
        errors.append(np.linalg.norm(position - positions[k]))
        assert np.linalg.norm(quaternion) == pytest.approx(1.0)
        estimator.update(shifts[k], positions[k], quaternions[k], reprojection_error_px=0.8)
    errors = np.array(errors) * 1000
    assert errors.mean() < 1.0, f"mean {errors.mean():.3f} mm, max {errors.max():.3f} mm"
    assert estimator.updates == len(shifts) - 450


def test_selective_update_skips_poor_or_lost_camera_frames(exploration):
    shifts, positions, quaternions = exploration
    estimator = FEmpEstimator(update_threshold_px=1.4)
    estimator.initialize(shifts[:200], positions[:200], quaternions[:200])
    before = estimator.elm.beta.copy()
    assert not estimator.update(shifts[300], positions[300], quaternions[300], 1.4)
    assert not estimator.update(shifts[300], positions[300], quaternions[300], 0.5, lost=True)
    assert not estimator.update(shifts[300], positions[300], quaternions[300], float("inf"))
    np.testing.assert_array_equal(estimator.elm.beta, before)
    assert estimator.update(shifts[300], positions[300], quaternions[300], 1.39)


def test_save_load_round_trip(exploration, tmp_path):
    shifts, positions, quaternions = exploration
    estimator = FEmpEstimator(n_hidden=50)
    estimator.initialize(shifts[:200], positions[:200], quaternions[:200])
    estimator.update(shifts[201], positions[201], quaternions[201], 0.3)
    estimator.save(tmp_path / "femp")
    loaded = FEmpEstimator.load(tmp_path / "femp")
    for k in (250, 600):
        np.testing.assert_array_equal(loaded.predict(shifts[k])[0], estimator.predict(shifts[k])[0])


def test_bad_use_raises():
    with pytest.raises(ValueError, match="not initialised"):
        FEmpEstimator().predict(np.zeros(17))
    with pytest.raises(ValueError, match="update_threshold_px"):
        FEmpEstimator(update_threshold_px=0.0)
    with pytest.raises(ValueError, match="positions_m"):
        FEmpEstimator().initialize(np.zeros((10, 17)), np.zeros((9, 3)), np.zeros((10, 4)))


def test_exploration_common_mode_decouples_extension_from_bending():
    """Without ``common`` the chambers' mean pressure (extension) is locked to the bend
    amplitude; with it the calibration sequence also visits extended straight-ish shapes."""
    from soft_gym.papers.wang2023.exploration import spiral_fractions

    t = np.arange(0.0, 22.5, 0.05)
    for common, locked in ((0.0, True), (0.3, False)):
        fractions = spiral_fractions(t, turn_s=8.0, breath_s=45.0, low=0.05, high=0.6,
                                     common=common, common_s=11.0)
        mean = fractions.mean(axis=1)
        bend = np.ptp(fractions, axis=1)
        correlation = np.corrcoef(mean, bend)[0, 1]
        assert (correlation > 0.99) == locked, correlation
        assert np.all((fractions >= 0) & (fractions <= 1))
    with pytest.raises(ValueError, match="common"):
        spiral_fractions(t, common=1.5)


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour of the F-emp estimator (wang2023 Section II-C) that a
# surviving mutant changed unnoticed: the documented defaults (200 hidden nodes, 1.4 px selective
# update), the hyper-parameters reaching the OS-ELM, quaternion labels kept in one hemisphere, the
# output standardisation, saving into a new or an existing directory and resuming online learning
# after loading, and errors that name their parameter first. The data are synthetic: smooth maps
# from random "wavelength shifts" to a pose, so each test runs in milliseconds.
# ==========================================================================================


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
