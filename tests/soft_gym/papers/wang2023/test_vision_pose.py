"""Vision pose estimator (ORB + PnP against a keyframe map) on the eye-in-hand camera.

wang2023: ORB-SLAM2 tracks the tip camera within 0.998 mm of the EM tracker in clean conditions,
is lost under full occlusion and darkness (holding the last pose), and degrades (larger e_S and
error) under partial occlusion, glare and blur (Figs. 6-7).
"""

from __future__ import annotations

import copy

import cv2
import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from soft_gym.robots import get_preset
from soft_gym.papers.wang2023.exploration import spiral_fractions
from soft_gym.papers.wang2023.vision_pose import MATCH_STAGES, VisionPoseEstimator, _Keyframe
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


@pytest.mark.slow  # about 14 s; the other faults run by default
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


def _track_random_pressures(options: dict, use_prior: bool = False, frames: int = 80,
                            high: float = 0.5) -> tuple[dict[str, int], float, int]:
    """A random pressure every control period, up to ``high`` of the range (the image jumps
    between frames): the stages that decided the frames, the mean tip error (mm) and the frames
    lost."""
    spec = get_preset("wang2023")
    rng = np.random.default_rng(4)
    pressures = spec.p_pre_pa + rng.uniform(0.0, high, (frames, 3)) * (spec.p_max_pa
                                                                       - spec.p_pre_pa)
    sim = ArmSimulator(spec)
    sim.reset(settle_s=0.5)
    camera = EyeInHandCamera()
    camera.reset(sim, np.random.default_rng(0))
    tip_from_camera = np.eye(4)
    tip_from_camera[:3, 3] = camera.offset_m
    estimator = VisionPoseEstimator(camera.K(), tip_from_camera, **options)
    estimator.calibrate(*camera.render_clean(sim), camera.pose_matrix(sim))
    errors, lost = [], 0
    for target in pressures:
        sim.set_pressures(target)
        sim.step_physics(spec.control_period_s)
        prior = None
        if use_prior:
            prior = camera.pose_matrix(sim) @ np.linalg.inv(tip_from_camera)
        estimate = estimator.update(camera.read(sim, sim.time_s), camera.last_depth, prior)
        errors.append(np.linalg.norm(estimate.position_m - sim.tip_pose()[0]) * 1000)
        lost += estimate.lost
    sim.close()
    assert sum(estimator.match_stages.values()) == frames  # every frame had features
    return estimator.match_stages, float(np.mean(errors)), lost


OLD_MATCHING = {"image_motion_prediction": False}


def test_a_pose_prior_replaces_the_motion_model_under_jerky_motion():
    """Under a random pressure every control period the motion model mispredicts and, with the
    image-motion stage and the wider window off, most frames are matched against the whole
    local map; a tip-pose prior from another sensor (here the true pose, as F-emp approximates
    it) keeps the search by projection working."""
    stages, _, _ = _track_random_pressures(OLD_MATCHING)
    assert stages["whole_map"] > 20 and stages["image_motion"] == stages["wide_window"] == 0
    stages, error_mm, _ = _track_random_pressures(OLD_MATCHING, use_prior=True)
    assert stages["whole_map"] <= 3, stages
    assert error_mm < 2.0
    estimator = _estimator()
    estimator.last = estimator._estimate(WORLD_FROM_CAMERA, 0.5, 100, False)
    with pytest.raises(ValueError, match="prior_world_from_tip"):
        estimator.update(np.zeros((120, 160, 3), np.uint8) + 100, None, np.eye(3))


@pytest.fixture(scope="module")
def jerky_tracking() -> tuple[tuple, tuple]:
    """Random pressures over the whole range every control period, tracked with the image-motion
    stage and without it: (stages, mean error mm, frames lost) of each."""
    return (_track_random_pressures({}, high=1.0),
            _track_random_pressures(OLD_MATCHING, high=1.0))


def test_the_image_motion_replaces_the_whole_map_under_jerky_motion(jerky_tracking):
    """A random pressure over the whole range every control period (the motion model misses most
    frames), without a prior: once the misses are the rule, the last pose turned by the image's
    shift (and, if needed, the wider window) keeps the search by projection working, as a prior
    from another sensor does, and tracking is as accurate as with the whole-map matching."""
    (stages, error_mm, lost), (old_stages, old_error_mm, old_lost) = jerky_tracking
    # the whole map only until the motion model has missed 6 of 10 frames, and after losses
    assert stages["whole_map"] <= 0.5 * old_stages["whole_map"], (stages, old_stages)
    assert stages["image_motion"] > 20, stages
    assert error_mm < 2.0 and error_mm <= 1.1 * old_error_mm, (error_mm, old_error_mm)
    assert lost <= old_lost


@pytest.mark.xfail(strict=True, reason=(
    "aimed at: at most a tenth of the jerky frames matched against the whole map; measured 11 "
    "of 80 (63 without the image-motion stage): the first 6 misses go to the whole map before "
    "the stage opens (image_motion_min_misses, which keeps the flick run's whole-map matching), "
    "so does the frame after each of the 2 losses, and 3 more where the stage had closed or "
    "found too few matches"))
def test_at_most_a_tenth_of_jerky_frames_are_matched_against_the_whole_map(jerky_tracking):
    (stages, _, _), _ = jerky_tracking
    assert stages["whole_map"] <= 8, stages


def _texture(seed: int = 0, shape: tuple[int, int] = (120, 160)) -> np.ndarray:
    """A smooth random grey texture (uint8)."""
    noise = np.random.default_rng(seed).random((shape[0] // 4, shape[1] // 4))
    return (255 * cv2.resize(noise, shape[::-1], interpolation=cv2.INTER_CUBIC).clip(0, 1)
            ).astype(np.uint8)


@pytest.mark.parametrize("shift_px", [(5.0, -3.0), (-8.0, 0.0), (0.0, 6.0)])
def test_image_motion_turns_the_camera_so_the_scene_moves_by_the_shift(shift_px) -> None:
    """A frame whose content moved by (dx, dy) px: the turned pose projects the point that was at
    the principal point of the last frame (at any depth) to the principal point + (dx, dy), to
    the phase correlation's sub-pixel accuracy, and keeps the camera's position."""
    dx, dy = shift_px
    K_image = np.array([[150.0, 0.0, 80.0], [0.0, 150.0, 60.0], [0.0, 0.0, 1.0]])
    estimator = VisionPoseEstimator(K_image, np.eye(4))
    last = _pose([0.2, -0.1, 0.3], [0.01, -0.02, 0.15])
    estimator.last = estimator._estimate(last, 0.5, 100, False)
    image = _texture().astype(np.float32)
    moved = cv2.warpAffine(image, np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]]), (160, 120),
                           borderMode=cv2.BORDER_REFLECT)
    estimator._last_gray = image
    turned = estimator._turned_by_image_motion(moved)
    np.testing.assert_array_equal(turned[:3, 3], last[:3, 3])
    for depth_m in (0.05, 0.5):
        point = last[:3, :3] @ np.array([0.0, 0.0, depth_m]) + last[:3, 3]
        camera = np.linalg.inv(turned)
        p = camera[:3, :3] @ point + camera[:3, 3]
        pixel = K_image[:2, :2] @ (p[:2] / p[2]) + K_image[:2, 2]
        np.testing.assert_allclose(pixel, [80.0 + dx, 60.0 + dy], atol=0.3)


def test_jerky_motion_tries_the_image_motion_first(monkeypatch) -> None:
    """While the motion model missed at least 6 of the last 10 frames, including the last one,
    a frame searches from the image's motion first; otherwise from the motion model first."""
    estimator = _estimator()
    points, pixels = _scene(200)
    descriptors = np.random.default_rng(1).integers(0, 256, (200, 32), dtype=np.uint8)
    estimator.keyframes = [_Keyframe(descriptors, points, WORLD_FROM_CAMERA.copy(), 200,
                                     octaves=np.zeros(200, np.int64))]
    estimator.last = estimator._estimate(WORLD_FROM_CAMERA, 0.5, 200, False)
    estimator.previous = estimator.last
    estimator._last_gray = np.zeros((240, 320), np.float32)
    keypoints = [cv2.KeyPoint(float(u), float(v), 7.0) for u, v in pixels]

    class Detector:  # the scene's own keypoints and descriptors, whatever the image
        @staticmethod
        def detectAndCompute(gray, mask):
            return keypoints, descriptors

    monkeypatch.setattr(estimator, "_orb", Detector())
    turned = _pose([0.1, -0.2, 0.05], [0.01, 0.02, -0.03])
    monkeypatch.setattr(estimator, "_turned_by_image_motion", lambda gray: turned)
    centres = []
    original = estimator._search_by_projection

    def search(frame, local_map, centre, start, radius):
        centres.append("image_motion" if centre is turned
                       else "second search" if radius == 3.0 else "prediction")
        return original(frame, local_map, centre, start, radius)

    monkeypatch.setattr(estimator, "_search_by_projection", search)
    image = np.zeros((240, 320), np.uint8)
    # the image motion only once the motion model missed 6 of the last 10 frames; first
    # when it missed the last one
    for misses, searches in (([True] * 5 + [False] * 5, ["prediction"]),
                             ([True] * 6 + [False] * 4, ["prediction"]),
                             ([False] * 4 + [True] * 6, ["image_motion", "second search"])):
        estimator._misses = list(misses)
        estimator.previous = estimator.last
        estimator._last_gray = np.zeros((240, 320), np.float32)
        centres.clear()
        estimator.update(image)
        # the first search tracked the frame; the image motion's pose is searched again, from
        # itself in half the window (refine_radius_factor)
        assert centres == searches
        # the motion model predicted this still camera exactly: no miss recorded
        assert estimator._misses == (list(misses) + [False])[-10:]
    assert estimator.match_stages == {"prediction": 2, "image_motion": 1, "wide_window": 0,
                                      "whole_map": 0}
    assert tuple(estimator.match_stages) == MATCH_STAGES


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour of the tracker's geometric core on synthetic data (no
# rendering): the pinhole residuals and their Jacobian for the update ``R <- exp(w) R``,
# ``t <- exp(w) t + dt`` (against finite differences), the weighted Gauss-Newton refinement (against
# scipy's least squares), the tip-position standard deviation (against a numerically differentiated
# covariance), RANSAC PnP with ``e_S`` and the lost rules, ORB-SLAM2's level variances, the motion
# and prior predictions, keyframe back-projection and pruning, the local map, brute-force matching
# with the ratio test (against a loop over Hamming distances), the re-posing of keyframes by a fit
# in time (against ``np.polyfit``) and the settings' checks.
# ==========================================================================================


K = np.array([[300.0, 0.0, 160.0], [0.0, 280.0, 120.0], [0.0, 0.0, 1.0]])
OFFSET = np.array([0.002, -0.001, 0.005])  # camera position in the tip frame (m)
LEVEL_SCALE2 = 1.2 ** 2  # ORB's default scale factor between pyramid levels, squared


def _tip_from_camera(rotvec=(0.0, 0.0, 0.0)) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    pose[:3, 3] = OFFSET
    return pose


def _estimator(**options) -> VisionPoseEstimator:
    return VisionPoseEstimator(K, _tip_from_camera(), **options)


def _pose(rotvec, translation) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    pose[:3, 3] = translation
    return pose


WORLD_FROM_CAMERA = _pose([0.1, -0.2, 0.05], [0.01, 0.02, -0.03])
CAMERA_FROM_WORLD = np.linalg.inv(WORLD_FROM_CAMERA)


def _scene(n: int, seed: int = 0, spread: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """World points in front of the camera and their exact pixels."""
    rng = np.random.default_rng(seed)
    camera_points = np.c_[rng.uniform(-spread, spread, (n, 2)), rng.uniform(0.1, 0.3, n)]
    world = camera_points @ WORLD_FROM_CAMERA[:3, :3].T + WORLD_FROM_CAMERA[:3, 3]
    return world, _project(world, CAMERA_FROM_WORLD[:3, :3], CAMERA_FROM_WORLD[:3, 3])


def _project(world: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Pinhole projection with ``K``, written out."""
    p = world @ rotation.T + translation
    return np.c_[K[0, 0] * p[:, 0] / p[:, 2] + K[0, 2], K[1, 1] * p[:, 1] / p[:, 2] + K[1, 2]]


def _apply(theta: np.ndarray, rotation: np.ndarray, translation: np.ndarray):
    """The documented update ``R <- exp(w) R``, ``t <- exp(w) t + dt`` for ``theta = (w, dt)``."""
    turn = Rotation.from_rotvec(theta[:3]).as_matrix()
    return turn @ rotation, turn @ translation + theta[3:]


def _numeric_jacobian(f, size: int = 6, h: float = 1e-6) -> np.ndarray:
    columns = []
    for i in range(size):
        step = np.zeros(size)
        step[i] = h
        columns.append((f(step) - f(-step)) / (2 * h))
    return np.stack(columns, axis=1)


def _residual_vector(world, pixels, rotation, translation) -> np.ndarray:
    """All u residuals, then all v residuals (px)."""
    projected = _project(world, rotation, translation)
    return np.r_[projected[:, 0] - pixels[:, 0], projected[:, 1] - pixels[:, 1]]


# ------------------------------------------------------------------ geometry
def test_jacobian_rotation_columns_are_the_point_cross_the_translation_columns() -> None:
    """d(p)/d(w) = -[p]x: each row's rotation part is ``p x`` its translation part, with p the
    point in the camera frame (numpy's cross product as the reference, to rounding)."""
    rng = np.random.default_rng(0)
    world = rng.uniform(-0.05, 0.05, size=(40, 3)) + [0.0, 0.0, 0.3]
    rotation = Rotation.from_rotvec([0.05, -0.1, 0.02]).as_matrix()
    translation = np.array([0.01, -0.02, 0.03])
    _, jacobian = _estimator()._residuals(world, np.zeros((40, 2)), rotation, translation)
    p = world @ rotation.T + translation
    points = np.vstack([p, p])
    np.testing.assert_allclose(jacobian[:, :3], np.cross(points, jacobian[:, 3:]), rtol=1e-14,
                               atol=1e-12)


def test_residuals_and_their_jacobian() -> None:
    """Residuals are projection minus pixel, all u then all v; the Jacobian is the derivative
    for the documented left-multiplied update (finite differences)."""
    world, pixels = _scene(12)
    rng = np.random.default_rng(1)
    pixels = pixels + rng.normal(0.0, 2.0, pixels.shape)
    rotation = Rotation.from_rotvec([0.11, -0.19, 0.06]).as_matrix()
    translation = CAMERA_FROM_WORLD[:3, 3] + [0.001, -0.002, 0.003]
    residual, jacobian = _estimator()._residuals(world, pixels, rotation, translation)
    np.testing.assert_allclose(residual, _residual_vector(world, pixels, rotation, translation),
                               rtol=1e-12, atol=1e-9)
    numeric = _numeric_jacobian(
        lambda theta: _residual_vector(world, pixels, *_apply(theta, rotation, translation)))
    np.testing.assert_allclose(jacobian, numeric, rtol=1e-5, atol=1e-3)


def test_refinement_recovers_an_exact_pose() -> None:
    world, pixels = _scene(40)
    start = Rotation.from_rotvec([0.03, -0.02, 0.01]).as_matrix() @ CAMERA_FROM_WORLD[:3, :3]
    rvec = Rotation.from_matrix(start).as_rotvec().reshape(3, 1)
    tvec = (CAMERA_FROM_WORLD[:3, 3] + [0.004, -0.003, 0.005]).reshape(3, 1)
    rvec, tvec = _estimator()._refine_weighted(world, pixels, np.ones(40), rvec, tvec)
    assert tvec.shape == (3, 1)
    np.testing.assert_allclose(Rotation.from_rotvec(rvec.ravel()).as_matrix(),
                               CAMERA_FROM_WORLD[:3, :3], atol=1e-10)
    np.testing.assert_allclose(tvec.ravel(), CAMERA_FROM_WORLD[:3, 3], atol=1e-11)


def test_one_refinement_iteration_is_an_undamped_gauss_newton_step() -> None:
    """One iteration solves the weighted normal equations ``(J^T W J) x = -J^T W r`` for
    ``x = (w, dt)`` and applies the documented update."""
    world, pixels = _scene(30, seed=13)
    rng = np.random.default_rng(14)
    pixels = pixels + rng.normal(0.0, 1.0, pixels.shape)
    weights = rng.uniform(0.2, 1.0, 30)
    rotation = Rotation.from_rotvec([0.02, 0.0, -0.01]).as_matrix() @ CAMERA_FROM_WORLD[:3, :3]
    translation = CAMERA_FROM_WORLD[:3, 3] + [0.002, 0.001, -0.003]
    estimator = _estimator()
    rvec, tvec = estimator._refine_weighted(
        world, pixels, weights, Rotation.from_matrix(rotation).as_rotvec().reshape(3, 1),
        translation.reshape(3, 1), iterations=1)
    residual = _residual_vector(world, pixels, rotation, translation)
    jacobian = estimator._residuals(world, pixels, rotation, translation)[1]
    w = np.r_[weights, weights]
    step = np.linalg.solve(jacobian.T @ (jacobian * w[:, None]), -jacobian.T @ (residual * w))
    expected_rotation, expected_translation = _apply(step, rotation, translation)
    np.testing.assert_allclose(Rotation.from_rotvec(rvec.ravel()).as_matrix(), expected_rotation,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(tvec.ravel(), expected_translation, rtol=0, atol=1e-13)


def test_refinement_is_weighted_least_squares() -> None:
    """With noisy pixels the result minimises ``sum w_i (du_i^2 + dv_i^2)``, each observation's
    weight applying to both its coordinates (scipy's least squares on the same cost)."""
    world, pixels = _scene(30, seed=2)
    rng = np.random.default_rng(3)
    pixels = pixels + rng.normal(0.0, 1.0, pixels.shape)
    weights = rng.uniform(0.05, 1.0, 30)
    rvec0 = Rotation.from_matrix(CAMERA_FROM_WORLD[:3, :3]).as_rotvec()
    rvec, tvec = _estimator()._refine_weighted(world, pixels, weights, rvec0.reshape(3, 1),
                                               CAMERA_FROM_WORLD[:3, 3].reshape(3, 1))

    def cost(params):
        rotation = Rotation.from_rotvec(params[:3]).as_matrix()
        return np.sqrt(np.r_[weights, weights]) * _residual_vector(world, pixels, rotation,
                                                                   params[3:])

    reference = least_squares(cost, np.r_[rvec0, CAMERA_FROM_WORLD[:3, 3]], xtol=1e-15,
                              ftol=1e-15, gtol=1e-15).x
    np.testing.assert_allclose(rvec.ravel(), reference[:3], atol=1e-8)
    np.testing.assert_allclose(tvec.ravel(), reference[3:], atol=1e-9)


@pytest.mark.parametrize("tip_rotvec, n", [((0.0, 0.0, 0.0), 25), ((0.3, -0.2, 0.5), 25),
                                           ((0.1, 0.2, 0.0), 3)])
def test_tip_position_std_is_the_propagated_covariance(tip_rotvec, n: int) -> None:
    """``sqrt(trace(D C D^T))`` with ``C = s^2 (J^T W J)^-1``, ``s^2`` the weighted residual
    sum over max(2n - 6, 1) and ``D`` the derivative of the tip position ``c + R^T o`` (``o``
    the tip in the camera frame); here both derivatives are taken numerically."""
    world, pixels = _scene(n, seed=4)
    rng = np.random.default_rng(5)
    pixels = pixels + rng.normal(0.0, 0.7, pixels.shape)
    weights = rng.uniform(0.2, 1.0, n)
    estimator = VisionPoseEstimator(K, _tip_from_camera(tip_rotvec))
    rotation, translation = CAMERA_FROM_WORLD[:3, :3], CAMERA_FROM_WORLD[:3, 3]
    std = estimator._tip_position_std(world, pixels, weights, rotation, translation)
    w = np.r_[weights, weights]
    residual = _residual_vector(world, pixels, rotation, translation)
    jacobian = _numeric_jacobian(
        lambda theta: _residual_vector(world, pixels, *_apply(theta, rotation, translation)))
    covariance = np.sum(w * residual**2) / max(2 * n - 6, 1) * np.linalg.inv(
        jacobian.T @ (jacobian * w[:, None]))
    tip_in_camera = np.linalg.inv(_tip_from_camera(tip_rotvec))[:3, 3]

    def tip(theta):
        r, t = _apply(theta, rotation, translation)
        return -r.T @ t + r.T @ tip_in_camera

    d_tip = _numeric_jacobian(tip)
    expected = np.sqrt(np.trace(d_tip @ covariance @ d_tip.T))
    assert std == pytest.approx(expected, rel=1e-5)


def test_tip_position_std_of_an_unconstrained_pose_is_infinite() -> None:
    """Inliers that carry no weight leave the pose unconstrained (a singular information
    matrix): the standard deviation is infinite, so the frame counts as lost."""
    world, pixels = _scene(10, seed=15)
    std = _estimator()._tip_position_std(world, pixels + 0.5, np.zeros(10),
                                         CAMERA_FROM_WORLD[:3, :3], CAMERA_FROM_WORLD[:3, 3])
    assert std == np.inf


def test_sigma2_adds_the_level_variances_of_both_keypoints() -> None:
    octaves, map_octaves = np.array([0, 1, 2, 3]), np.array([0, 0, 3, 1])
    np.testing.assert_allclose(_estimator()._sigma2(octaves, map_octaves),
                               LEVEL_SCALE2 ** octaves + LEVEL_SCALE2 ** map_octaves, rtol=1e-6)


# ------------------------------------------------------------------ PnP
def _calibrated(**options) -> VisionPoseEstimator:
    estimator = _estimator(**options)
    estimator.last = estimator._estimate(np.eye(4), 0.0, 100, False)
    return estimator


def test_solve_recovers_the_pose_rejects_outliers_and_reports_e_s() -> None:
    """From a guess 5 mm and 0.03 rad off, RANSAC PnP and the refinement give the camera pose;
    pixels moved 30 px away are not inliers; ``e_S`` is the RMS reprojection error of the
    inliers at the returned pose (px); the reported pose is the tip's."""
    world, pixels = _scene(80, seed=6)
    rng = np.random.default_rng(7)
    pixels = pixels + rng.normal(0.0, 0.3, pixels.shape)
    pixels[:10] += 5.0 * np.c_[np.cos(np.arange(10)), np.sin(np.arange(10))]
    guess = WORLD_FROM_CAMERA @ _pose([0.02, 0.02, -0.01], [0.003, -0.004, 0.0])
    estimator = _calibrated()
    estimate = estimator._solve(world, pixels, guess, np.ones(80))
    assert estimate.lost is False and estimate.inliers == 70
    assert sorted(estimator._inliers.tolist()) == list(range(10, 80))
    np.testing.assert_allclose(estimate.world_from_camera, WORLD_FROM_CAMERA, atol=3e-3)
    camera_from_world = np.linalg.inv(estimate.world_from_camera)
    residual = _project(world[10:], camera_from_world[:3, :3], camera_from_world[:3, 3]) \
        - pixels[10:]
    expected = np.sqrt(np.mean(np.sum(residual**2, axis=1)))
    assert estimate.reprojection_error_px == pytest.approx(expected, rel=1e-6)
    world_from_tip = estimate.world_from_camera @ np.linalg.inv(_tip_from_camera())
    np.testing.assert_allclose(estimate.position_m, world_from_tip[:3, 3], atol=1e-12)
    # a RANSAC threshold above the 5 px displacement takes (most of) them in
    assert _calibrated(ransac_threshold_px=8.0)._solve(world, pixels, guess,
                                                        np.ones(80)).inliers > 70


def test_ransac_samples_come_from_the_episode_generator() -> None:
    """OpenCV's RANSAC samples with a fixed generator of its own (``cv2.setRNGSeed`` does not
    reach it), so without a generator a frame's inliers are the same in every run; with one
    (``set_rng``: the env hands each episode a child of its ``np_random``) they are drawn from
    it: two seeds pick different inliers (1 px noise against a 2 px threshold) and the same
    seed the same ones, bit for bit, as does a copy. Inliers are reported in match order."""
    world, pixels = _scene(80, seed=6)
    pixels = pixels + np.random.default_rng(7).normal(0.0, 1.0, pixels.shape)

    def solve(rng, opencv_seed: int = 0, estimator=None):
        estimator = estimator or _calibrated()
        estimator.set_rng(rng)
        cv2.setRNGSeed(opencv_seed)
        estimate = estimator._solve(world, pixels, WORLD_FROM_CAMERA, np.ones(80))
        assert not estimate.lost
        return estimate.world_from_camera, estimator._inliers.copy()

    fixed, fixed_inliers = solve(None, opencv_seed=0)
    for opencv_seed in (1, 12345):
        again, again_inliers = solve(None, opencv_seed)
        np.testing.assert_array_equal(again, fixed)
        np.testing.assert_array_equal(again_inliers, fixed_inliers)
    draws = {seed: solve(np.random.default_rng(seed)) for seed in (0, 1, 2)}
    for pose, inliers in draws.values():
        assert np.all(np.diff(inliers) > 0)
    assert len({inliers.tobytes() for _, inliers in draws.values()}) == 3
    assert len({pose.tobytes() for pose, _ in draws.values()}) == 3
    repeat, repeat_inliers = solve(np.random.default_rng(0), opencv_seed=99)
    np.testing.assert_array_equal(repeat, draws[0][0])
    np.testing.assert_array_equal(repeat_inliers, draws[0][1])
    original = _calibrated()
    original.set_rng(np.random.default_rng(1))
    twin = copy.deepcopy(original)
    first = solve(original._rng, estimator=original)
    second = solve(twin._rng, estimator=twin)
    np.testing.assert_array_equal(first[0], second[0])
    with pytest.raises(ValueError, match="rng must be None or a numpy Generator"):
        _calibrated().set_rng(0)


def test_solve_uses_the_level_weights() -> None:
    """The refinement weights each inlier by ``1 / sigma2``: the pose is the weighted least
    squares one, not the unweighted one."""
    world, pixels = _scene(60, seed=8)
    rng = np.random.default_rng(9)
    pixels = pixels + rng.normal(0.0, 0.5, pixels.shape)
    sigma2 = rng.choice([2.0, 2.88, 4.15, 8.6], 60)
    estimate = _calibrated()._solve(world, pixels, WORLD_FROM_CAMERA, sigma2)
    rvec0 = Rotation.from_matrix(CAMERA_FROM_WORLD[:3, :3]).as_rotvec()
    rvec, tvec = _estimator()._refine_weighted(world, pixels, 1.0 / sigma2, rvec0.reshape(3, 1),
                                               CAMERA_FROM_WORLD[:3, 3].reshape(3, 1))
    camera_from_world = np.linalg.inv(estimate.world_from_camera)
    np.testing.assert_allclose(camera_from_world[:3, 3], tvec.ravel(), atol=1e-9)
    unweighted = _estimator()._refine_weighted(world, pixels, np.ones(60), rvec0.reshape(3, 1),
                                               CAMERA_FROM_WORLD[:3, 3].reshape(3, 1))[1]
    assert np.abs(camera_from_world[:3, 3] - unweighted.ravel()).max() > 1e-7


def test_solve_with_too_few_matches_or_a_poorly_constrained_pose_is_lost() -> None:
    """Fewer matches than ``min_inliers``: lost, reporting the match count; a tip position
    standard deviation above ``max_position_std_m``: lost, reporting the inlier count. A lost
    frame holds the last pose with an infinite ``e_S``."""
    world, pixels = _scene(40, seed=10)
    pixels = pixels + np.random.default_rng(11).normal(0.0, 0.5, pixels.shape)
    estimator = _calibrated(min_inliers=30)
    few = estimator._solve(world[:29], pixels[:29], WORLD_FROM_CAMERA, np.ones(29))
    assert few.lost and few.inliers == 29 and few.reprojection_error_px == np.inf
    np.testing.assert_array_equal(few.world_from_camera, np.eye(4))
    enough = estimator._solve(world[:30], pixels[:30], WORLD_FROM_CAMERA, np.ones(30))
    assert not enough.lost and enough.inliers == 30
    strict = _calibrated(max_position_std_m=estimator._position_std * 0.5)
    shaky = strict._solve(world[:30], pixels[:30], WORLD_FROM_CAMERA, np.ones(30))
    assert shaky.lost and shaky.inliers == 30
    loose = _calibrated(max_position_std_m=estimator._position_std * 1.01)
    assert not loose._solve(world[:30], pixels[:30], WORLD_FROM_CAMERA, np.ones(30)).lost


def test_solve_with_too_few_inliers_or_no_model_is_lost() -> None:
    """Enough matches but fewer RANSAC inliers than ``min_inliers``: lost, reporting the
    inlier count; no consistent model at all (random pixels): lost with 0 inliers."""
    world, pixels = _scene(40, seed=10)
    rng = np.random.default_rng(3)
    angles = rng.uniform(0.0, 2 * np.pi, 15)
    pixels[25:] += 40.0 * np.c_[np.cos(angles), np.sin(angles)]
    estimator = _calibrated(min_inliers=30)
    estimate = estimator._solve(world, pixels, WORLD_FROM_CAMERA, np.ones(40))
    assert estimate.lost and estimate.inliers == 25 and estimate.reprojection_error_px == np.inf
    noise = np.random.default_rng(4).uniform([0, 0], [320, 240], (40, 2))
    estimate = estimator._solve(world, noise, WORLD_FROM_CAMERA, np.ones(40))
    assert estimate.lost and estimate.inliers == 0


def test_lost_holds_a_copy_of_the_last_pose() -> None:
    estimator = _calibrated()
    estimator.last = estimator._estimate(WORLD_FROM_CAMERA, 0.4, 70, False)
    held = estimator._lost(12)
    assert held.lost and held.inliers == 12 and held.reprojection_error_px == np.inf
    np.testing.assert_array_equal(held.position_m, estimator.last.position_m)
    np.testing.assert_array_equal(held.quaternion, estimator.last.quaternion)
    np.testing.assert_array_equal(held.world_from_camera, WORLD_FROM_CAMERA)
    held.position_m[0] = 5.0
    held.world_from_camera[0, 3] = 5.0
    held.quaternion[0] = 5.0
    assert estimator.last.position_m[0] != 5.0 and estimator.last.quaternion[0] != 5.0
    assert estimator.last.world_from_camera[0, 3] != 5.0


def test_estimate_reports_the_tip_pose() -> None:
    """``world_from_tip = world_from_camera @ inv(tip_from_camera)``, quaternion (x, y, z, w)."""
    tip_from_camera = _tip_from_camera((0.2, 0.0, -0.4))
    estimator = VisionPoseEstimator(K, tip_from_camera)
    estimate = estimator._estimate(WORLD_FROM_CAMERA, 0.7, 55, False)
    world_from_tip = WORLD_FROM_CAMERA @ np.linalg.inv(tip_from_camera)
    np.testing.assert_allclose(estimate.position_m, world_from_tip[:3, 3], atol=1e-14)
    rotation = Rotation.from_quat(estimate.quaternion).as_matrix()
    np.testing.assert_allclose(rotation, world_from_tip[:3, :3], atol=1e-12)
    assert (estimate.reprojection_error_px, estimate.inliers, estimate.lost) == (0.7, 55, False)
    np.testing.assert_array_equal(estimate.world_from_camera, WORLD_FROM_CAMERA)


def test_prediction_from_a_prior_or_constant_velocity() -> None:
    """A tip-pose prior gives ``prior @ tip_from_camera``; without one, the constant-velocity
    model ``last @ inv(previous) @ last`` (one more step of the last motion), or ``None``
    when there is no previous frame."""
    estimator = _calibrated()
    prior = _pose([0.0, 0.1, 0.0], [0.01, 0.0, 0.1])
    np.testing.assert_allclose(estimator._predicted_world_from_camera(prior),
                               prior @ _tip_from_camera(), atol=1e-15)
    estimator.previous = None
    assert estimator._predicted_world_from_camera(None) is None
    first = _pose([0.0, 0.0, 0.1], [0.0, 0.0, 0.1])
    motion = _pose([0.0, 0.02, 0.0], [0.001, 0.0, 0.0])
    estimator.previous = estimator._estimate(first, 0.5, 60, False)
    estimator.last = estimator._estimate(first @ motion, 0.5, 60, False)
    np.testing.assert_allclose(estimator._predicted_world_from_camera(None),
                               first @ motion @ motion, atol=1e-14)


# ------------------------------------------------------------------ map
def _features(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    pixels = rng.uniform([0, 0], [320, 240], (n, 2))
    descriptors = rng.integers(0, 256, (n, 32), dtype=np.uint8)
    octaves = rng.integers(0, 8, n)
    return pixels, descriptors, octaves


def test_keyframe_back_projects_the_depth_from_the_given_pose() -> None:
    """Each feature's depth is read at its rounded pixel (clipped into the image), kept if
    strictly between ``min_depth_m`` and ``max_depth_m``, and back-projected through K from
    the keyframe's pose."""
    pixels = np.array([[10.2, 20.7], [300.0, 200.0], [-4.0, 250.0], [150.0, 5.0], [50.0, 60.0],
                       [319.4, 0.3], [330.0, -6.0]])
    descriptors = np.arange(7 * 32, dtype=np.uint8).reshape(7, 32)
    octaves = np.array([0, 1, 2, 3, 4, 5, 6])
    depth = np.full((240, 320), 0.2)
    depth[21, 10] = 0.15
    depth[239, 0] = 0.25            # the clipped corner of the third feature
    depth[5, 150] = 0.005           # at min_depth_m: not kept
    depth[60, 50] = 1.0             # at max_depth_m: not kept
    depth[0, 319] = 0.3             # the last two: the top right corner (the last clipped)
    estimator = _estimator()
    count = estimator.add_keyframe(None, depth, WORLD_FROM_CAMERA, (pixels, descriptors, octaves))
    assert count == 5
    keyframe = estimator.keyframes[-1]
    kept = [0, 1, 2, 5, 6]
    z = np.array([0.15, 0.2, 0.25, 0.3, 0.3])
    camera = np.c_[(pixels[kept, 0] - 160.0) / 300.0 * z, (pixels[kept, 1] - 120.0) / 280.0 * z, z]
    np.testing.assert_allclose(keyframe.points_world_m,
                               camera @ WORLD_FROM_CAMERA[:3, :3].T + WORLD_FROM_CAMERA[:3, 3],
                               atol=1e-15)
    np.testing.assert_array_equal(keyframe.descriptors, descriptors[kept])
    np.testing.assert_array_equal(keyframe.octaves, octaves[kept])
    np.testing.assert_array_equal(keyframe.world_from_camera, WORLD_FROM_CAMERA)
    assert keyframe.inliers_at_creation == 5 and keyframe.uncertainty == 0.0
    none = np.full((240, 320), 2.0)
    assert estimator.add_keyframe(None, none, WORLD_FROM_CAMERA, _features(5)) == 0
    assert len(estimator.keyframes) == 1


def _textured_image(seed: int = 0) -> np.ndarray:
    """A 240 x 320 RGB image of random 8 px blocks: plenty of ORB corners."""
    blocks = np.random.default_rng(seed).integers(0, 256, (30, 40, 3), dtype=np.uint8)
    return np.ascontiguousarray(np.repeat(np.repeat(blocks, 8, axis=0), 8, axis=1))


def test_keyframe_detects_features_itself_when_none_are_given() -> None:
    """Without ``features`` the ORB features of the image are detected: the keyframe is the
    one built from the features given explicitly; an image without texture adds nothing."""
    image = _textured_image()
    depth = np.full((240, 320), 0.2)
    estimator = _estimator(n_features=300)
    keypoints, descriptors = estimator._orb.detectAndCompute(
        np.ascontiguousarray(image.mean(axis=2).round().astype(np.uint8)), None)
    count = estimator.add_keyframe(image, depth, WORLD_FROM_CAMERA)
    assert count == len(estimator.keyframes[0].descriptors) > 100
    given = _estimator(n_features=300)
    features = estimator._detect(image)
    pixels = np.array([k.pt for k in features[0]])
    octaves = np.array([k.octave for k in features[0]])
    assert given.add_keyframe(None, depth, WORLD_FROM_CAMERA,
                              (pixels, features[1], octaves)) == count
    ours, theirs = estimator.keyframes[0], given.keyframes[0]
    np.testing.assert_array_equal(ours.descriptors, theirs.descriptors)
    np.testing.assert_allclose(ours.points_world_m, theirs.points_world_m, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ours.octaves, theirs.octaves)
    assert ours.octaves.dtype == np.int64 and ours.octaves.max() > 0
    assert len(keypoints) > 100
    assert estimator.add_keyframe(np.full((240, 320, 3), 90, np.uint8), depth,
                                  WORLD_FROM_CAMERA) == 0
    assert len(estimator.keyframes) == 1


def test_keyframe_pruning_drops_the_most_uncertain_but_never_the_calibration_one() -> None:
    estimator = _estimator(max_keyframes=3)
    depth = np.full((240, 320), 0.2)
    for k in range(3):
        estimator.add_keyframe(None, depth, _pose([0, 0, 0], [0.001 * k, 0, 0]), _features(8, k))
    estimator.keyframes[0].uncertainty = 9.0
    estimator.keyframes[1].uncertainty = 2.0
    estimator.keyframes[2].uncertainty = 1.0
    assert estimator.add_keyframe(None, depth, _pose([0, 0, 0], [0.003, 0, 0]),
                                  _features(8, 3)) == 8
    assert [k.world_from_camera[0, 3] for k in estimator.keyframes] == [0.0, 0.002, 0.003]
    estimator.keyframes[-1].uncertainty = 1.5  # now the most uncertain of the middle ones
    estimator.add_keyframe(None, depth, _pose([0, 0, 0], [0.004, 0, 0]), _features(8, 4))
    assert [k.world_from_camera[0, 3] for k in estimator.keyframes] == [0.0, 0.002, 0.004]


def test_local_map_is_the_calibration_keyframe_and_the_nearest_ones() -> None:
    estimator = _estimator(match_keyframes=2)
    depth = np.full((240, 320), 0.2)
    xs = [0.0, 0.010, 0.004, 0.006, 0.020]
    for k, x in enumerate(xs):
        estimator.add_keyframe(None, depth, _pose([0, 0, 0], [x, 0, 0]), _features(4 + k, k))
        estimator.keyframes[-1].uncertainty = float(k)
    descriptors, points, nearest, octaves = estimator._local_map(_pose([0, 0, 0],
                                                                       [0.0052, 0, 0]))
    chosen = [estimator.keyframes[i] for i in (0, 3, 2)]  # calibration, then by distance
    assert nearest is estimator.keyframes[3]
    np.testing.assert_array_equal(descriptors, np.vstack([k.descriptors for k in chosen]))
    np.testing.assert_array_equal(points, np.vstack([k.points_world_m for k in chosen]))
    np.testing.assert_array_equal(octaves, np.concatenate([k.octaves for k in chosen]))
    np.testing.assert_array_equal(estimator._local_uncertainty,
                                  np.repeat([0.0, 3.0, 2.0], [4, 7, 6]))
    # near the calibration keyframe it is one of the nearest, not listed twice
    descriptors, _, nearest, _ = estimator._local_map(_pose([0, 0, 0], [0.001, 0, 0]))
    assert nearest is estimator.keyframes[0]
    np.testing.assert_array_equal(descriptors, np.vstack([estimator.keyframes[i].descriptors
                                                          for i in (0, 2)]))



def test_local_map_follows_re_posed_keyframes_and_changed_uncertainties() -> None:
    """The local map's stacks are reused between frames only while nothing in them changed: a
    keyframe re-posed (its points replaced) or given a new uncertainty shows at once."""
    estimator = _estimator(match_keyframes=2)
    depth = np.full((240, 320), 0.2)
    for k, x in enumerate([0.0, 0.004, 0.006]):
        estimator.add_keyframe(None, depth, _pose([0, 0, 0], [x, 0, 0]), _features(5, k))
    pose = _pose([0, 0, 0], [0.005, 0, 0])
    _, points_before, _, _ = estimator._local_map(pose)
    keyframe = estimator.keyframes[1]
    keyframe.points_world_m = keyframe.points_world_m + [0.0, 0.0, 0.001]
    keyframe.uncertainty = 4.0
    _, points_after, _, _ = estimator._local_map(pose)
    np.testing.assert_array_equal(points_after,
                                  np.vstack([k.points_world_m for k in estimator.keyframes]))
    assert not np.array_equal(points_after, points_before)
    np.testing.assert_array_equal(estimator._local_uncertainty, np.repeat([0.0, 4.0, 0.0], 5))

def test_match_all_is_the_ratio_test_with_each_map_point_used_once() -> None:
    """Each feature's nearest map descriptor (Hamming) is kept if closer than ``ratio`` times
    the second nearest and not already taken by an earlier feature."""
    rng = np.random.default_rng(12)
    map_descriptors = rng.integers(0, 256, (60, 32), dtype=np.uint8)
    picks = np.r_[rng.choice(60, 40, replace=False), [5, 5, 7]]
    noise = (rng.integers(0, 256, (43, 32), dtype=np.uint8)
             & rng.integers(0, 256, (43, 32), dtype=np.uint8)
             & rng.integers(0, 256, (43, 32), dtype=np.uint8))
    noise[rng.random(43) < 0.3] |= rng.integers(0, 256, 32, dtype=np.uint8)
    descriptors = np.vstack([map_descriptors[picks] ^ noise,
                             rng.integers(0, 256, (20, 32), dtype=np.uint8)])
    estimator = _estimator(ratio=0.7)
    query, train = estimator._match_all(descriptors, map_descriptors)
    expected, used = [], set()
    for i, d in enumerate(descriptors):
        distances = np.unpackbits(d ^ map_descriptors, axis=1).sum(axis=1)
        order = np.argsort(distances, kind="stable")
        best, second = distances[order[0]], distances[order[1]]
        if best < 0.7 * second and int(order[0]) not in used:
            used.add(int(order[0]))
            expected.append((i, int(order[0])))
    assert 20 < len(expected) < 63
    assert list(zip(query.tolist(), train.tolist())) == expected
    assert query.dtype == np.int64 and train.dtype == np.int64


def _flipped(descriptor: np.ndarray, bits) -> np.ndarray:
    """``descriptor`` with the given bit positions (0..255) flipped."""
    unpacked = np.unpackbits(descriptor)
    unpacked[list(bits)] ^= 1
    return np.packbits(unpacked)


def test_match_all_ratio_test_is_strict_and_no_match_gives_empty_index_arrays() -> None:
    """A best distance exactly ``ratio`` times the second is not a match; with no match the
    result is two empty integer index arrays."""
    base = np.random.default_rng(16).integers(0, 256, 32, dtype=np.uint8)
    map_descriptors = np.stack([_flipped(base, range(10)), _flipped(base, range(100, 120)),
                                _flipped(base, range(200, 250))])
    estimator = _estimator(ratio=0.5)
    query, train = estimator._match_all(base[None], map_descriptors)  # 10 vs 20: 10 = 0.5 * 20
    assert len(query) == len(train) == 0
    assert query.dtype == np.int64 and train.dtype == np.int64
    query, train = estimator._match_all(_flipped(base, [255])[None], map_descriptors)  # 11 vs 21
    assert len(query) == 0
    query, train = estimator._match_all(_flipped(base, [9])[None], map_descriptors)  # 9 vs 19
    assert query.tolist() == [0] and train.tolist() == [0]


# ------------------------------------------------------------------ search by projection
K_SMALL = np.array([[64.0, 0.0, 64.0], [0.0, 64.0, 48.0], [0.0, 0.0, 1.0]])  # 128 x 96 frames
SEARCH_FROM_WORLD = _pose([0.05, -0.08, 0.1], [0.01, -0.02, 0.03])




def _world_points(pixels_uv: np.ndarray, depths: np.ndarray) -> np.ndarray:
    """World points that project to ``pixels_uv`` at ``depths`` from ``SEARCH_FROM_WORLD``."""
    camera = np.c_[(pixels_uv[:, 0] - 64.0) / 64.0 * depths, (pixels_uv[:, 1] - 48.0) / 64.0
                   * depths, depths]
    return (camera - SEARCH_FROM_WORLD[:3, 3]) @ SEARCH_FROM_WORLD[:3, :3]


def _cluster_scene(seed: int, last_candidates: int):
    """Clusters of 1-3 map points and 1-3 features within 2 px of a centre, clusters 16 px
    apart; descriptors within a cluster are one base with 0-60 flipped bits each, so the
    distances straddle the ratio test and ``max_descriptor_distance``; map points may be
    contested. The last feature sits apart (over 8 px from every cluster) with
    ``last_candidates`` map points."""
    rng = np.random.default_rng(seed)
    map_uv, map_desc, feat_uv, feat_desc = [], [], [], []
    for u in range(8, 121, 16):
        for v in range(8, 89, 16):
            base = rng.integers(0, 256, 32, dtype=np.uint8)
            for _ in range(rng.integers(1, 4)):
                map_uv.append([u, v] + rng.uniform(-2, 2, 2))
                map_desc.append(_flipped(base, rng.choice(256, rng.integers(0, 61), False)))
            for _ in range(rng.integers(1, 4)):
                feat_uv.append([u, v] + rng.uniform(-2, 2, 2))
                feat_desc.append(_flipped(base, rng.choice(256, rng.integers(0, 61), False)))
    base = rng.integers(0, 256, 32, dtype=np.uint8)
    feat_uv.append([64.0, 95.5])
    feat_desc.append(base)
    for k in range(last_candidates):  # 10 and 11 bits away: one candidate matches, two do not
        map_uv.append([64.0 + k, 95.0])
        map_desc.append(_flipped(base, range(10 + k)))
    map_uv = np.array(map_uv)
    points = _world_points(map_uv, rng.uniform(0.05, 0.2, len(map_uv)))
    return (np.array(feat_uv), np.array(feat_desc), np.array(map_desc), points)


@pytest.mark.parametrize("seed, last_candidates", [(0, 1), (1, 2), (2, 1)])
def test_search_by_projection_on_contested_clusters(seed: int, last_candidates: int) -> None:
    pixels, descriptors, map_descriptors, points = _cluster_scene(seed, last_candidates)
    estimator = VisionPoseEstimator(K_SMALL, np.eye(4), search_radius_px=6.0)
    query, train = estimator._match_by_projection(pixels, descriptors, map_descriptors, points,
                                                  SEARCH_FROM_WORLD, 128, 96)
    reference = _reference_match_by_projection(estimator, pixels, descriptors, map_descriptors,
                                               points, SEARCH_FROM_WORLD, 128, 96)
    assert len(reference) > 15
    assert sorted(zip(query.tolist(), train.tolist())) == reference
    last = len(pixels) - 1
    assert (last in query.tolist()) == (last_candidates == 1)


def test_search_by_projection_uses_all_256_bits_and_the_distance_bound() -> None:
    """Each feature has one map point in reach (no second candidate): it is matched exactly
    when the Hamming distance over all four 64-bit words is at most 80, whichever words the
    differing bits lie in."""
    rng = np.random.default_rng(17)
    layouts = {"80 in words 0, 1": list(range(64)) + list(range(64, 80)),
               "81 in words 0, 1": list(range(64)) + list(range(64, 81)),
               "81 in words 2, 3": list(range(128, 192)) + list(range(192, 209)),
               "81 in words 1, 2": list(range(64, 128)) + list(range(128, 145)),
               "79 in words 3, 0": list(range(192, 256)) + list(range(0, 15))}
    uv = np.array([[10.0 + 25.0 * k, 40.0] for k in range(len(layouts))])
    map_descriptors = rng.integers(0, 256, (len(layouts), 32), dtype=np.uint8)
    descriptors = np.stack([_flipped(d, bits) for d, bits in zip(map_descriptors,
                                                                 layouts.values())])
    estimator = VisionPoseEstimator(K_SMALL, np.eye(4))
    query, train = estimator._match_by_projection(
        uv + 0.5, descriptors, map_descriptors, _world_points(uv, np.full(len(uv), 0.1)),
        SEARCH_FROM_WORLD, 128, 96)
    assert query.tolist() == train.tolist() == [0, 4], list(layouts)


def test_search_by_projection_ratio_test_is_strict() -> None:
    """A feature whose nearest map point is exactly ``ratio`` times as far (in bits) as the
    second nearest is not matched; a bit closer, it is."""
    base = np.random.default_rng(19).integers(0, 256, 32, dtype=np.uint8)
    map_descriptors = np.stack([_flipped(base, range(10)), _flipped(base, range(100, 120))])
    points = _world_points(np.array([[50.0, 50.0], [51.0, 50.0]]), np.array([0.1, 0.12]))
    estimator = VisionPoseEstimator(K_SMALL, np.eye(4), ratio=0.5)
    for descriptor, expected in ((base, []), (_flipped(base, [9]), [0])):  # 10/20, 9/19 bits
        query, train = estimator._match_by_projection(np.array([[50.5, 50.5]]),
                                                      descriptor[None], map_descriptors, points,
                                                      SEARCH_FROM_WORLD, 128, 96)
        assert train.tolist() == expected and query.tolist() == [0] * len(expected)


def test_search_by_projection_gives_a_contested_point_to_the_first_of_equals() -> None:
    """Two features equally close (in bits) to the one map point near them: the map point goes
    to the feature with the lower index."""
    base = np.random.default_rng(20).integers(0, 256, 32, dtype=np.uint8)
    point = _world_points(np.array([[70.0, 30.0]]), np.array([0.1]))
    descriptors = np.stack([_flipped(base, range(20)), _flipped(base, range(50, 70)),
                            _flipped(base, range(100, 130))])
    estimator = VisionPoseEstimator(K_SMALL, np.eye(4))
    pixels = np.array([[71.0, 30.0], [69.0, 31.0], [70.0, 29.0]])
    for order in ([0, 1, 2], [2, 1, 0], [1, 2, 0]):
        query, train = estimator._match_by_projection(pixels[order], descriptors[order],
                                                      base[None], point, SEARCH_FROM_WORLD,
                                                      128, 96)
        first_of_equals = min(order.index(0), order.index(1))
        assert query.tolist() == [first_of_equals] and train.tolist() == [0], order


def test_search_by_projection_with_one_or_no_candidate() -> None:
    """One map point in view and one feature next to it: one match. A map point behind the
    camera, or no feature near the projection: two empty index arrays."""
    rng = np.random.default_rng(18)
    descriptor = rng.integers(0, 256, (1, 32), dtype=np.uint8)
    estimator = VisionPoseEstimator(K_SMALL, np.eye(4))
    point = _world_points(np.array([[50.0, 50.0]]), np.array([0.1]))
    query, train = estimator._match_by_projection(np.array([[51.0, 49.0]]), descriptor,
                                                  descriptor, point, SEARCH_FROM_WORLD, 128, 96)
    assert query.tolist() == [0] and train.tolist() == [0]
    behind = _world_points(np.array([[50.0, 50.0]]), np.array([-0.1]))
    far_feature = np.array([[90.0, 20.0]])
    for pixels, points in ((np.array([[51.0, 49.0]]), behind), (far_feature, point)):
        query, train = estimator._match_by_projection(pixels, descriptor, descriptor, points,
                                                      SEARCH_FROM_WORLD, 128, 96)
        assert query.shape == train.shape == (0,)
        assert query.dtype == np.int64 and train.dtype == np.int64


# ------------------------------------------------------------------ keyframe re-posing
def _path(t: float) -> np.ndarray:
    """A camera pose moving on a quadratic in time (translation and rotation vector)."""
    return _pose([0.01 * t + 0.002 * t**2, -0.005 * t, 0.1 + 0.003 * t**2],
                 [0.001 * t + 0.0003 * t**2, 0.002 - 0.0004 * t**2, 0.1 + 0.0002 * t])


def _pending_keyframe(estimator: VisionPoseEstimator, frame: int, raw: np.ndarray):
    estimator.add_keyframe(None, np.full((240, 320), 0.2), raw, _features(10, frame))
    keyframe = estimator.keyframes[-1]
    estimator._pending.append((frame, keyframe, raw))
    return keyframe


def _fitted(frames, raw: np.ndarray, frame: int, degree: int) -> np.ndarray:
    """The documented fit, written with np.polyfit: translation and the rotation relative to the
    raw pose, each a polynomial in (k - frame), evaluated at the keyframe's frame."""
    t = np.array([k - frame for k in frames], dtype=float)
    poses = [_history_pose(k, frame) for k in frames]
    translations = np.array([p[:3, 3] for p in poses])
    rotvecs = Rotation.from_matrix(np.array([raw[:3, :3].T @ p[:3, :3] for p in poses])
                                   ).as_rotvec()
    at_zero = [np.polyval(np.polyfit(t, column, degree), 0.0)
               for column in np.c_[translations, rotvecs].T]
    pose = np.eye(4)
    pose[:3, 3] = at_zero[:3]
    pose[:3, :3] = raw[:3, :3] @ Rotation.from_rotvec(at_zero[3:]).as_matrix()
    return pose


def _history_pose(k: int, frame: int) -> np.ndarray:
    """The tracked pose of frame k: the path, with the keyframe's own frame off by 0.3 mm."""
    pose = _path(float(k))
    if k == frame:
        pose = pose @ _pose([0.0005, 0.0, -0.0004], [0.0003, -0.0002, 0.0001])
    return pose


@pytest.mark.parametrize("window, frames, degree", [
    (2, [8, 9, 10, 11, 12], 2),   # five frames: a quadratic
    (3, [7, 8, 9, 10, 11, 12], 2),  # six frames, more before than after
    (3, [9, 10, 11, 12], 1),      # four frames (the window is not full yet): a straight line
    (2, [8, 9, 10, 11], 1),       # four frames, one after the keyframe
    (1, [9, 10, 11], 1),          # three frames, the fewest
])
def test_flush_reposes_a_keyframe_to_the_fit_through_its_window(window, frames, degree) -> None:
    estimator = _estimator(keyframe_window=window)
    raw = _history_pose(10, 10)
    keyframe = _pending_keyframe(estimator, 10, raw)
    points_in_camera = (keyframe.points_world_m - raw[:3, 3]) @ raw[:3, :3]
    estimator._history = [(k, _history_pose(k, 10)) for k in [3, *frames]]
    estimator._flush_pending(9)  # not yet: up_to_frame is before the keyframe's frame ...
    assert estimator._pending and keyframe.world_from_camera is not None
    np.testing.assert_array_equal(keyframe.world_from_camera, raw)
    estimator._flush_pending(10)  # ... now
    assert not estimator._pending
    expected = _fitted(frames, raw, 10, degree)
    np.testing.assert_allclose(keyframe.world_from_camera, expected, atol=1e-12)
    moved = (keyframe.points_world_m - expected[:3, 3]) @ expected[:3, :3]
    np.testing.assert_allclose(moved, points_in_camera, atol=1e-12)


def test_flush_keeps_the_raw_pose_without_a_smooth_window() -> None:
    """The keyframe keeps its own pose with fewer than three tracked frames in its window, with
    no frame after it, or when the fit misses the positions by more than
    ``max_fit_residual_m`` (RMS)."""
    for history in ([9, 10], [7, 8, 9, 10]):
        estimator = _estimator(keyframe_window=3)
        raw = _history_pose(10, 10)
        keyframe = _pending_keyframe(estimator, 10, raw)
        estimator._history = [(k, _history_pose(k, 10)) for k in history]
        estimator._flush_pending()
        assert not estimator._pending
        np.testing.assert_array_equal(keyframe.world_from_camera, raw)
    estimator = _estimator(keyframe_window=2, max_fit_residual_m=1e-5)
    raw = _history_pose(10, 10)
    keyframe = _pending_keyframe(estimator, 10, raw)
    estimator._history = [(k, _history_pose(k, 10)) for k in range(8, 13)]
    estimator._flush_pending()
    np.testing.assert_array_equal(keyframe.world_from_camera, raw)
    loose = _estimator(keyframe_window=2, max_fit_residual_m=1e-3)
    keyframe = _pending_keyframe(loose, 10, raw)
    loose._history = [(k, _history_pose(k, 10)) for k in range(8, 13)]
    loose._flush_pending()
    assert np.abs(keyframe.world_from_camera - raw).max() > 1e-5


def test_fit_residual_is_the_rms_over_frames_of_the_position_miss() -> None:
    """The bound applies to the root mean (over the window's frames) of the squared position
    misses: just above that RMS the keyframe is re-posed, just below it keeps its pose."""
    frames = list(range(8, 13))
    t = np.array(frames, dtype=float) - 10
    translations = np.array([_history_pose(k, 10)[:3, 3] for k in frames])
    fit = np.stack([np.polyval(np.polyfit(t, c, 2), t) for c in translations.T], axis=1)
    rms = np.sqrt(np.mean(np.sum((translations - fit) ** 2, axis=1)))
    raw = _history_pose(10, 10)
    for factor, reposed in ((1.2, True), (0.8, False)):
        estimator = _estimator(keyframe_window=2, max_fit_residual_m=factor * rms)
        keyframe = _pending_keyframe(estimator, 10, raw)
        estimator._history = [(k, _history_pose(k, 10)) for k in frames]
        estimator._flush_pending()
        assert (np.abs(keyframe.world_from_camera - raw).max() > 1e-6) == reposed, factor


def test_flush_goes_on_past_a_keyframe_it_leaves_alone() -> None:
    """A keyframe that keeps its pose (no frame after it yet, or a window that was not smooth)
    does not stop the re-posing of the keyframes pending after it."""
    # frame 8 is a flick: 5 mm off the path
    history = {k: _path(float(k)) for k in range(8, 15)}
    history[8] = history[8] @ _pose([0.0, 0.0, 0.0], [0.005, 0.0, 0.0])
    for first_frame in (14, 9):  # 14: nothing after it; 9: its window holds the flick
        estimator = _estimator(keyframe_window=2)
        first = _pending_keyframe(estimator, first_frame, history[first_frame])
        second = _pending_keyframe(estimator, 12, history[12])
        estimator._history = sorted(history.items())
        estimator._flush_pending()
        assert not estimator._pending
        np.testing.assert_array_equal(first.world_from_camera, history[first_frame])
        frames = [10, 11, 12, 13, 14]
        t = np.array(frames, dtype=float) - 12
        translation = [np.polyval(np.polyfit(t, [history[k][i, 3] for k in frames], 2), 0.0)
                       for i in range(3)]
        np.testing.assert_allclose(second.world_from_camera[:3, 3], translation, atol=1e-12)


# ------------------------------------------------------------------ settings
def test_defaults() -> None:
    estimator = _estimator()
    assert (estimator.n_features, estimator.min_inliers, estimator.ratio,
            estimator.ransac_threshold_px, estimator.keyframe_inlier_ratio,
            estimator.max_keyframes, estimator.match_keyframes, estimator.ransac_iterations,
            estimator.keyframe_spacing_m, estimator.search_radius_px,
            estimator.max_descriptor_distance, estimator.min_depth_m, estimator.max_depth_m,
            estimator.keyframe_window, estimator.max_fit_residual_m,
            estimator.max_position_std_m, estimator.keyframe_position_std_m) == (
        1000, 30, 0.8, 2.0, 0.35, 1000, 6, 200, 0.001, 6.0, 80, 0.005, 1.0, 5, 0.001, 0.001,
        0.0005)
    assert estimator.keyframes == [] and estimator.last is None and estimator.previous is None
    assert estimator._orb.getMaxFeatures() == 1000
    # ORB tuned for small frames: 15 px border and patch, FAST threshold 10
    assert (estimator._orb.getEdgeThreshold(), estimator._orb.getPatchSize(),
            estimator._orb.getFastThreshold()) == (15, 15, 10)
    assert estimator._history == [] and estimator._pending == [] and estimator._frame == 0
    assert _estimator(n_features=321)._orb.getMaxFeatures() == 321
    np.testing.assert_allclose(estimator._camera_from_tip, np.linalg.inv(_tip_from_camera()))


@pytest.mark.parametrize("options", [
    {"min_inliers": 4}, {"n_features": 10}, {"ratio": 1.0}, {"keyframe_window": 0},
    {"search_radius_px": None}, {"max_descriptor_distance": 256}, {"max_descriptor_distance": 1},
    {"image_motion_prediction": False}, {"wide_search_factor": None},
    {"wide_search_factor": 1.5}, {"wide_search_factor": 3}, {"image_motion_min_misses": 0},
    {"image_motion_min_misses": 10}, {"refine_radius_factor": None},
    {"refine_radius_factor": 0.25},
])
def test_boundary_settings_are_accepted(options: dict) -> None:
    estimator = _estimator(**options)
    for name, value in options.items():
        assert getattr(estimator, name) == value


@pytest.mark.parametrize("options, message", [
    ({"min_inliers": 3}, r"^min_inliers must be an integer >= 4, got 3$"),
    ({"min_inliers": 30.0}, r"^min_inliers must be an integer >= 4, got 30\.0$"),
    ({"n_features": 9}, r"^n_features must be an integer >= 10, got 9$"),
    ({"n_features": 100.0}, r"^n_features must be an integer >= 10, got 100\.0$"),
    ({"ratio": 0.0}, r"^ratio must be in \(0, 1\], got 0\.0$"),
    ({"ratio": 1.01}, r"^ratio must be in \(0, 1\], got 1\.01$"),
    ({"ransac_threshold_px": 0.0}, r"^ransac_threshold_px must be"),
    ({"max_depth_m": -1.0}, r"^max_depth_m must be"),
    ({"keyframe_window": True}, r"^keyframe_window must be an integer >= 0, got True$"),
    ({"keyframe_window": 2.0}, r"^keyframe_window must be an integer >= 0, got 2\.0$"),
    ({"keyframe_window": -1}, r"^keyframe_window must be an integer >= 0, got -1$"),
    ({"max_fit_residual_m": 0.0}, r"^max_fit_residual_m must be"),
    ({"max_position_std_m": 0.0}, r"^max_position_std_m must be"),
    ({"keyframe_position_std_m": 0.0}, r"^keyframe_position_std_m must be"),
    ({"search_radius_px": 0.0}, r"^search_radius_px must be"),
    ({"max_descriptor_distance": 0}, r"^max_descriptor_distance must be an integer in "
                                     r"\(0, 256\], got 0$"),
    ({"max_descriptor_distance": 257}, r"^max_descriptor_distance must be an integer"),
    ({"max_descriptor_distance": 80.0}, r"^max_descriptor_distance must be an integer"),
    ({"image_motion_prediction": 1}, r"^image_motion_prediction must be True or False, got 1$"),
    ({"image_motion_prediction": "yes"}, r"^image_motion_prediction must be True or False"),
    ({"wide_search_factor": 1.0}, r"^wide_search_factor must be a finite number > 1 or None, "
                                  r"got 1\.0$"),
    ({"wide_search_factor": float("nan")}, r"^wide_search_factor must be a finite number > 1"),
    ({"wide_search_factor": True}, r"^wide_search_factor must be a finite number > 1"),
    ({"wide_search_factor": "2"}, r"^wide_search_factor must be a finite number > 1"),
    ({"refine_radius_factor": 0.0}, r"^refine_radius_factor must be a finite number > 0 or "
                                    r"None, got 0\.0$"),
    ({"refine_radius_factor": float("inf")}, r"^refine_radius_factor must be a finite"),
    ({"image_motion_min_misses": 11}, r"^image_motion_min_misses must be an integer in "
                                      r"\[0, 10\], got 11$"),
    ({"image_motion_min_misses": -1}, r"^image_motion_min_misses must be an integer"),
    ({"image_motion_min_misses": 6.0}, r"^image_motion_min_misses must be an integer"),
    ({"image_motion_min_misses": True}, r"^image_motion_min_misses must be an integer"),
])
def test_bad_settings_are_named_first(options: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _estimator(**options)


def test_bad_poses_are_named_first() -> None:
    with pytest.raises(ValueError, match=r"^camera_matrix must have shape \(3, 3\)"):
        VisionPoseEstimator(np.eye(4), np.eye(4))
    with pytest.raises(ValueError, match=r"^tip_from_camera must have shape \(4, 4\)"):
        VisionPoseEstimator(K, np.eye(3))
