"""Vision pose estimator (ORB + PnP against a keyframe map) on the eye-in-hand camera.

wang2023: ORB-SLAM2 tracks the tip camera within 0.998 mm of the EM tracker in clean conditions,
is lost under full occlusion and darkness (holding the last pose), and degrades (larger e_S and
error) under partial occlusion, glare and blur (Figs. 6-7).
"""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.sensing.wang2023.exploration import spiral_fractions
from soft_gym.sensing.wang2023.vision_pose import VisionPoseEstimator
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.engines.pybullet.simulator import ArmSimulator


def _run(faults=None, steps: int = 1200, turn_s: float = 8.0, high: float = 0.3, seed: int = 0):
    """Slow spiral exploration of wang2023; returns per-step error (mm), e_S, lost flags, poses."""
    spec = get_preset("wang2023")
    sim = ArmSimulator(spec)
    sim.reset(settle_s=0.5)
    camera = EyeInHandCamera(faults=faults)
    camera.reset(sim, np.random.default_rng(seed))
    tip_from_camera = np.eye(4)
    tip_from_camera[:3, 3] = camera.offset_m
    estimator = VisionPoseEstimator(camera.K(), tip_from_camera)
    image, depth = camera.render_clean(sim)
    estimator.calibrate(image, depth, camera.pose_matrix(sim))
    errors, e_s, lost, estimates = [], [], [], []
    for k in range(steps):
        fraction = spiral_fractions(k * spec.control_period_s, turn_s=turn_s, low=0.05, high=high)
        sim.set_pressures(spec.p_pre_pa + fraction * (spec.p_max_pa - spec.p_pre_pa))
        sim.step_physics(spec.control_period_s)
        frame = camera.read(sim, sim.time_s)
        estimate = estimator.update(frame, camera.last_depth)
        errors.append(np.linalg.norm(estimate.position_m - sim.tip_pose()[0]) * 1000)
        e_s.append(estimate.reprojection_error_px)
        lost.append(estimate.lost)
        estimates.append(estimate.position_m)
    sim.close()
    return np.array(errors), np.array(e_s), np.array(lost), np.array(estimates)


@pytest.fixture(scope="module")
def clean():
    return _run()


def test_clean_spiral_tracks_within_a_millimetre_and_is_never_lost(clean):
    errors, e_s, lost, _ = clean
    rmse = float(np.sqrt(np.mean(errors**2)))
    assert not lost.any()
    # measured 0.46 mm (the paper's ORB-SLAM2: 0.998 mm); the bound is the paper's, with 5 % margin
    assert rmse <= 1.05, f"RMSE {rmse:.3f} mm"
    assert np.all(e_s < 2.0)


@pytest.mark.parametrize("fault", [
    {"name": "moving_occluder", "mode": "full", "start_s": 5.0, "period_s": 6.0, "cover_s": 2.0},
    {"name": "low_light", "strength": 1.0, "start_s": 5.0, "end_s": 9.0},
])
def test_full_occlusion_and_darkness_lose_tracking_and_hold_the_last_pose(fault):
    errors, e_s, lost, estimates = _run(faults=fault, steps=200)
    assert not lost[:95].any()
    # a full cover lasts 2 s and darkness 4 s: tracking is lost for at least 1.5 s on end
    runs, longest = 0, 0
    for flag in lost:
        runs = runs + 1 if flag else 0
        longest = max(longest, runs)
    assert longest >= 30, f"longest lost run {longest} frames"
    assert np.isinf(e_s[lost]).all()
    first = int(np.argmax(lost))
    # while lost, the estimate holds the last valid pose
    held = estimates[first:first + 5][lost[first:first + 5]]
    np.testing.assert_array_equal(held, np.repeat(estimates[first - 1][None], len(held), axis=0))


@pytest.mark.parametrize("fault, factor", [
    ({"name": "moving_occluder", "mode": "partial", "strength": 0.9}, 2.0),
    ({"name": "led_glare", "strength": 1.0}, 2.0),
])
def test_partial_occlusion_and_glare_raise_the_error(clean, fault, factor):
    """Measured (300 steps): partial occluder 1.12 mm (2.9x, 41 % of frames lost), glare
    0.98 mm (2.6x), clean 0.38 mm; the paper's figures show about 2x."""
    clean_errors, clean_e_s, _, _ = clean
    errors, e_s, lost, _ = _run(faults=fault, steps=300)
    assert np.mean(e_s[~lost]) > np.mean(clean_e_s[:300])
    assert np.mean(errors) >= factor * np.mean(clean_errors[:300]), (
        f"{fault['name']}: {np.mean(errors):.2f} mm vs clean {np.mean(clean_errors[:300]):.2f} mm")


def test_motion_blur_raises_the_error_of_fast_motion():
    """A fast spiral (one turn a second, the tip at 15 mm/s, 2.7 px of blur per frame) with the
    exposure as long as the 20 Hz frame interval. Measured: 1.26 mm blurred vs 0.41 mm sharp
    (3.1x): the blurred features sit half an exposure behind the frame's pose, and fewer of
    them are found."""
    blurred, blurred_e_s, lost, _ = _run(
        faults={"name": "motion_blur", "strength": 1.0, "exposure_s": 0.05},
        steps=300, turn_s=1.0)
    sharp, sharp_e_s, _, _ = _run(steps=300, turn_s=1.0)
    assert not lost.any()
    assert np.mean(blurred_e_s) > np.mean(sharp_e_s)
    assert np.mean(blurred) >= 2.0 * np.mean(sharp), (
        f"{np.mean(blurred):.2f} mm blurred vs {np.mean(sharp):.2f} mm sharp")


def test_bad_configuration_raises():
    with pytest.raises(ValueError, match="min_inliers"):
        VisionPoseEstimator(np.eye(3), np.eye(4), min_inliers=2)
    with pytest.raises(ValueError, match="camera_matrix"):
        VisionPoseEstimator(np.eye(2), np.eye(4))
    with pytest.raises(ValueError, match="keyframe_window"):
        VisionPoseEstimator(np.eye(3), np.eye(4), keyframe_window=-1)
    with pytest.raises(ValueError, match="max_position_std_m"):
        VisionPoseEstimator(np.eye(3), np.eye(4), max_position_std_m=0.0)
    estimator = VisionPoseEstimator(np.eye(3), np.eye(4))
    with pytest.raises(ValueError, match="calibrate"):
        estimator.update(np.zeros((120, 160, 3), np.uint8))


def _reference_match_by_projection(estimator, pixels, descriptors, map_descriptors, map_points,
                                   camera_from_world, width, height):
    """Slow loop version of the search by projection, for comparison."""
    K = estimator.camera_matrix
    radius = estimator.search_radius_px
    projected = {}
    for j, point in enumerate(map_points):
        p = camera_from_world[:3, :3] @ point + camera_from_world[:3, 3]
        if p[2] <= estimator.min_depth_m:
            continue
        u, v = K[0, 0] * p[0] / p[2] + K[0, 2], K[1, 1] * p[1] / p[2] + K[1, 2]
        if -radius < u < width + radius and -radius < v < height + radius:
            projected[j] = np.array([u, v])
    chosen = {}
    for i, pixel in enumerate(pixels):
        candidates = sorted(
            (int(np.unpackbits(descriptors[i] ^ map_descriptors[j]).sum()), j)
            for j, uv in projected.items() if np.linalg.norm(uv - pixel) <= radius)
        if not candidates:
            continue
        best, j = candidates[0]
        second = candidates[1][0] if len(candidates) > 1 else np.inf
        if best <= estimator.max_descriptor_distance and best < estimator.ratio * second:
            if j not in chosen or (best, i) < chosen[j]:
                chosen[j] = (best, i)
    return sorted((i, j) for j, (_, i) in chosen.items())


def test_search_by_projection_matches_a_slow_reference():
    rng = np.random.default_rng(3)
    K = np.array([[73.0, 0.0, 80.0], [0.0, 73.0, 60.0], [0.0, 0.0, 1.0]])
    estimator = VisionPoseEstimator(K, np.eye(4), search_radius_px=6.0)
    map_points = np.c_[rng.uniform(-0.06, 0.06, (400, 2)), rng.uniform(0.03, 0.08, 400)]
    map_descriptors = rng.integers(0, 256, (400, 32), dtype=np.uint8)
    # features: noisy projections of half the map points with a few flipped bits, plus clutter
    seen = rng.choice(400, 200, replace=False)
    pixels = (map_points[seen, :2] / map_points[seen, 2:] * 73.0 + [80.0, 60.0]
              + rng.normal(0.0, 1.5, (200, 2)))
    pixels = np.vstack([pixels, rng.uniform([0, 0], [160, 120], (100, 2))])
    descriptors = np.vstack([map_descriptors[seen], rng.integers(0, 256, (100, 32), np.uint8)])
    flips = rng.integers(0, 256, descriptors.shape, dtype=np.uint8) & rng.integers(
        0, 256, descriptors.shape, dtype=np.uint8) & rng.integers(0, 256, descriptors.shape,
                                                                  dtype=np.uint8)
    descriptors = descriptors ^ flips
    query, train = estimator._match_by_projection(pixels, descriptors, map_descriptors,
                                                  map_points, np.eye(4), 160, 120)
    reference = _reference_match_by_projection(estimator, pixels, descriptors, map_descriptors,
                                                map_points, np.eye(4), 160, 120)
    assert len(reference) > 100
    assert sorted(zip(query.tolist(), train.tolist())) == reference


def test_a_pose_prior_replaces_the_motion_model_under_jerky_motion(monkeypatch):
    """With a new random pressure every frame the constant-velocity prediction misses and each
    frame is matched against the whole local map; a tip-pose prior from another sensor (here the
    true pose, as F-emp approximates it) keeps the search by projection working."""
    spec = get_preset("wang2023")
    rng = np.random.default_rng(4)
    pressures = spec.p_pre_pa + rng.uniform(0.0, 0.5, (80, 3)) * (spec.p_max_pa - spec.p_pre_pa)
    results = {}
    for use_prior in (False, True):
        sim = ArmSimulator(spec)
        sim.reset(settle_s=0.5)
        camera = EyeInHandCamera()
        camera.reset(sim, np.random.default_rng(0))
        tip_from_camera = np.eye(4)
        tip_from_camera[:3, 3] = camera.offset_m
        estimator = VisionPoseEstimator(camera.K(), tip_from_camera)
        estimator.calibrate(*camera.render_clean(sim), camera.pose_matrix(sim))
        full_matches = []
        original = estimator._match_all
        monkeypatch.setattr(estimator, "_match_all",
                            lambda *args: full_matches.append(1) or original(*args))
        errors = []
        for target in pressures:
            sim.set_pressures(target)
            sim.step_physics(spec.control_period_s)
            prior = None
            if use_prior:
                prior = camera.pose_matrix(sim) @ np.linalg.inv(tip_from_camera)
            estimate = estimator.update(camera.read(sim, sim.time_s), camera.last_depth, prior)
            errors.append(np.linalg.norm(estimate.position_m - sim.tip_pose()[0]) * 1000)
        sim.close()
        results[use_prior] = (len(full_matches), float(np.mean(errors)))
    assert results[False][0] > 20, results
    assert results[True][0] <= 3, results
    assert results[True][1] < 2.0, results
    with pytest.raises(ValueError, match="prior_world_from_tip"):
        estimator.update(np.zeros((120, 160, 3), np.uint8) + 100, None, np.eye(3))
