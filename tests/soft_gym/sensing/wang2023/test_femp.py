"""F-emp estimator: learns the tip pose from simulated FBG readings; selective updates."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.sensing.wang2023.femp import FEmpEstimator
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
    from soft_gym.sensing.wang2023.exploration import spiral_fractions

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
