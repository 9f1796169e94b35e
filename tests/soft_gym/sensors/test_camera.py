"""Eye-in-hand camera, its scene and visual faults (wang2023), and the stereo camera (zou2022)."""

from __future__ import annotations

import cv2
import numpy as np
import pybullet
import pytest
from pybullet_utils import bullet_client

from soft_gym.robots import get_preset
from soft_gym.engines.pybullet.world import render_camera
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.faults import (FAULT_PRESETS, FAULTS, LEDGlare, LowLight, MotionBlur,
                                     MovingOccluder, SensorNoise, make_faults)
from soft_gym.sensors.intrinsics import CameraIntrinsics
from soft_gym.engines.pybullet.scene import build_scene
from soft_gym.sensors.stereo import StereoCamera
from soft_gym.engines.pybullet.simulator import ArmSimulator


def _sim(preset: str = "wang2023", pressures=None, seconds: float = 0.0) -> ArmSimulator:
    sim = ArmSimulator(get_preset(preset))
    sim.reset(settle_s=0.5)
    if pressures is not None:
        sim.set_pressures(np.asarray(pressures, dtype=float))
        sim.step_physics(seconds)
    return sim


def _camera(sim: ArmSimulator, seed: int = 0, **kwargs) -> EyeInHandCamera:
    camera = EyeInHandCamera(**kwargs)
    camera.reset(sim, np.random.default_rng(seed))
    return camera


def _gray(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def _sharpness(image: np.ndarray) -> float:
    return float(cv2.Laplacian(_gray(image), cv2.CV_64F).var())


@pytest.fixture(scope="module")
def resting():
    """The resting wang2023 arm with the scene built and one clean frame."""
    sim = _sim()
    camera = _camera(sim)
    frame = camera.read(sim, sim.time_s)
    yield sim, camera, frame
    sim.close()


# ---------------------------------------------------------------------- intrinsics, projection
def test_intrinsics_match_the_opengl_projection():
    intrinsics = CameraIntrinsics()
    K = intrinsics.K()
    assert (intrinsics.width, intrinsics.height) == (160, 120)
    assert 90.0 <= intrinsics.hfov_deg <= 100.0
    assert K[0, 0] == pytest.approx(80.0 / np.tan(np.radians(intrinsics.hfov_deg) / 2))
    projection = np.array(intrinsics.projection_matrix()).reshape(4, 4).T
    assert projection[0, 0] == pytest.approx(2 * K[0, 0] / 160)
    assert projection[1, 1] == pytest.approx(2 * K[1, 1] / 120)
    reference = pybullet.computeProjectionMatrixFOV(intrinsics.vfov_deg, 160 / 120,
                                                    intrinsics.near_m, intrinsics.far_m)
    np.testing.assert_allclose(intrinsics.projection_matrix(), reference, rtol=1e-5, atol=1e-7)


def test_markers_appear_where_cv2_project_points_puts_them():
    """Small coloured spheres at known world points, seen by the bent arm's camera."""
    sim = _sim(pressures=[100e3, 0.0, 30e3], seconds=1.5)
    camera = _camera(sim, scene=False)
    rotation, position = camera.camera_pose(sim)
    assert abs(rotation[:, 2] @ [0, 0, 1]) < 0.95  # the camera is tilted
    local = np.array([[0.0, 0.0, 0.06], [0.025, -0.015, 0.05], [-0.03, 0.02, 0.07],
                      [0.04, 0.025, 0.045]])
    world = local @ rotation.T + position
    colours = ([1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1])
    for point, colour in zip(world, colours):
        visual = sim.client.createVisualShape(pybullet.GEOM_SPHERE, radius=0.0012,
                                              rgbaColor=[*colour, 1])
        sim.client.createMultiBody(0.0, -1, visual, point.tolist())
    image = camera.sample(sim).astype(int)
    rvec, _ = cv2.Rodrigues(rotation.T)
    tvec = -rotation.T @ position
    expected, _ = cv2.projectPoints(world, rvec, tvec, camera.K(), None)
    for (u, v), colour in zip(expected.reshape(-1, 2), colours):
        on = np.array(colour, dtype=bool)
        mask = np.all(image[:, :, on] > 100, axis=2) & np.all(image[:, :, ~on] < 60, axis=2)
        rows, cols = np.nonzero(mask)
        assert len(rows) >= 3, f"marker {colour} not visible"
        assert abs(cols.mean() - u) < 0.5 and abs(rows.mean() - v) < 0.5, (
            (cols.mean(), rows.mean()), (u, v))


def test_depth_is_metric_along_the_optical_axis():
    sim = _sim()
    camera = _camera(sim, scene=False)
    rotation, position = camera.camera_pose(sim)
    visual = sim.client.createVisualShape(pybullet.GEOM_BOX, halfExtents=[0.5, 0.5, 0.001])
    sim.client.createMultiBody(0.0, -1, visual, (position + [0, 0, 0.051]).tolist())
    depth = camera.render_clean(sim)[1]
    assert depth.shape == (120, 160)
    np.testing.assert_allclose(depth, 0.05, atol=2e-5)


# ---------------------------------------------------------------------- clean frames
def test_clean_frame_is_deterministic_and_in_space(resting):
    sim, camera, frame = resting
    assert frame.dtype == np.uint8 and frame.shape == (120, 160, 3)
    assert camera.space(sim).contains(frame)
    other_sim = _sim()
    other = _camera(other_sim, seed=123).sample(other_sim)
    np.testing.assert_array_equal(frame, other)
    np.testing.assert_array_equal(frame, camera.sample(sim))
    # the reading carries the pose and the depth of the frame
    rotation, position = camera.last_pose
    tip, _ = sim.tip_pose()
    np.testing.assert_allclose(position, tip + rotation[:, 2] * 0.003, atol=1e-12)
    assert camera.last_depth.shape == (120, 160)


def test_scene_fills_the_view_with_orb_features(resting):
    """wang2023 reports ~600 features per frame on its LEGO scene (Section IV-C1)."""
    sim, camera, frame = resting
    keypoints = cv2.ORB_create().detect(_gray(frame), None)
    dense = cv2.ORB_create(nfeatures=1000, edgeThreshold=15, patchSize=15).detect(_gray(frame),
                                                                                 None)
    assert len(keypoints) >= 100, len(keypoints)
    assert len(dense) >= 300, len(dense)
    depth = camera.render_clean(sim)[1]
    assert 0.03 < np.median(depth) < 0.08  # ground 60 mm beyond the tip, bricks in front


def test_scene_is_seeded_and_stays_out_of_the_arms_way():
    a = bullet_client.BulletClient(pybullet.DIRECT)
    b = bullet_client.BulletClient(pybullet.DIRECT)
    try:
        ids_a = build_scene(a, 0.09, seed=3)
        ids_b = build_scene(b, 0.09, seed=3)
        assert len(ids_a) == len(ids_b) > 10
        for i, j in zip(ids_a, ids_b):
            assert a.getBasePositionAndOrientation(i) == b.getBasePositionAndOrientation(j)
        # seen from the base: nothing comes closer than the ground minus the tallest brick
        wide = CameraIntrinsics(width=200, height=200, hfov_deg=120.0)
        _, depth = render_camera(a, wide, np.eye(3), np.zeros(3), np.array([0.0, 0.0, -1.0]))
        assert depth.min() > 0.09 + 0.06 - 0.012 - 1e-4
        assert np.median(depth) < 0.16
        assert all(a.getCollisionShapeData(i, -1) == () for i in ids_a)
    finally:
        a.disconnect()
        b.disconnect()


# ---------------------------------------------------------------------- faults
def _frames(sim, faults, seed, n=3, step_s=0.05):
    camera = _camera(sim, seed=seed, faults=faults)
    frames = []
    for _ in range(n):
        frames.append(camera.sample(sim))
        sim.step_physics(step_s)
    return frames


@pytest.mark.parametrize("fault", [SensorNoise(), LEDGlare(), MovingOccluder(mode="partial"),
                                   LowLight(strength=0.5)])
def test_faults_are_deterministic_under_a_seed_and_differ_between_seeds(fault):
    runs = {}
    for key, seed in (("a", 1), ("b", 1), ("c", 2)):
        sim = _sim(pressures=[60e3, 0, 0])
        runs[key] = _frames(sim, fault, seed)
        sim.close()
    for x, y in zip(runs["a"], runs["b"]):
        np.testing.assert_array_equal(x, y)
    assert any(not np.array_equal(x, y) for x, y in zip(runs["a"], runs["c"]))


def test_darkness_gives_a_near_black_frame_without_features(resting):
    sim, _, _ = resting
    frame = _camera(sim, faults=LowLight(strength=1.0)).sample(sim)
    assert frame.mean() < 3.0 and np.percentile(frame, 99) < 12
    assert len(cv2.ORB_create().detect(_gray(frame), None)) == 0


def test_low_light_dims_and_raises_relative_noise(resting):
    sim, _, clean = resting
    relative = [0.0]
    means = [clean.mean()]
    for strength in (0.3, 0.6, 0.85):
        frame = _camera(sim, faults=LowLight(strength=strength)).sample(sim).astype(float)
        residual = frame - (1.0 - strength) * clean
        means.append(frame.mean())
        relative.append(residual.std() / frame.mean())
    assert all(np.diff(means) < 0), means
    assert all(np.diff(relative) > 0), relative


def test_glare_saturates_a_moving_blob(resting):
    sim, _, clean = resting
    glare = LEDGlare(strength=1.0)
    camera = _camera(sim, faults=glare)
    frame = camera.sample(sim)
    u, v = glare.centre_px(sim.time_s, 160, 120)
    radius = glare.radius_px(160)
    rows, cols = np.mgrid[0:120, 0:160]
    core = (cols - u) ** 2 + (rows - v) ** 2 <= (0.9 * radius) ** 2
    assert core.sum() > 50
    assert np.all(frame[core] == 255)
    saturated = np.all(frame == 255, axis=2).mean()
    assert 0.03 < saturated < 0.5
    assert not np.allclose(glare.centre_px(1.0, 160, 120), glare.centre_px(3.0, 160, 120))


def test_full_occlusion_covers_the_view_and_follows_the_camera():
    sim = _sim(pressures=[0, 110e3, 0], seconds=1.0)
    occluder = MovingOccluder(mode="full", start_s=0.0, cover_s=2.0, period_s=6.0, jitter_s=0.0)
    camera = _camera(sim, faults=occluder)
    frame = camera.sample(sim)
    near = camera.last_depth < 0.02  # the plate is 15 mm in front of the camera
    assert near.mean() > 0.995
    assert _gray(frame).std() < 3.0
    assert len(cv2.ORB_create().detect(_gray(frame), None)) == 0
    # it is a body in the world, between camera and scene
    rotation, position = camera.last_pose
    plate, _ = sim.client.getBasePositionAndOrientation(occluder._body)
    assert (np.asarray(plate) - position) @ rotation[:, 2] == pytest.approx(0.015, abs=1e-6)
    # after cover_s it is gone
    sim.step_physics(2.5)
    camera.sample(sim)
    assert (camera.last_depth < 0.02).mean() == 0.0


def test_partial_occlusion_covers_a_moving_part_of_the_view():
    sim = _sim()
    camera = _camera(sim, faults=MovingOccluder(mode="partial", strength=0.6, sweep_s=2.0), seed=4)
    fractions, masks = [], []
    for _ in range(12):
        camera.sample(sim)
        mask = camera.last_depth < 0.02
        fractions.append(mask.mean())
        masks.append(mask)
        sim.step_physics(0.2)
    assert max(fractions) < 0.65 and max(fractions) > 0.3
    assert min(fractions) < 0.1
    assert any(not np.array_equal(a, b) for a, b in zip(masks, masks[1:]))


def test_motion_blur_lowers_sharpness_when_the_tip_moves():
    sim = _sim()
    blur = MotionBlur()
    camera = _camera(sim, faults=blur)
    still = camera.sample(sim)
    sim.step_physics(0.05)
    np.testing.assert_array_equal(camera.sample(sim), still)  # at rest: no blur
    sim.set_pressures(np.array([110e3, 0.0, 0.0]))
    ratios = []
    for _ in range(3):
        sim.step_physics(0.05)
        blurred = camera.sample(sim)
        clean, _ = camera.render_clean(sim)
        ratios.append(_sharpness(blurred) / _sharpness(clean))
    assert max(ratios) < 0.5, ratios


def test_motion_blur_streak_trails_the_motion():
    """The exposure ends at the frame time: a point now at p was at p - s v earlier in the
    exposure, so its streak runs from p - v to p with its centroid at p - v / 2."""
    image = np.zeros((40, 60), np.float32)
    image[20, 30] = 1.0
    for vector in (np.array([6.0, 0.0]), np.array([-3.0, 4.0])):
        blurred = cv2.filter2D(image, -1, MotionBlur.kernel(vector),
                               borderType=cv2.BORDER_CONSTANT)
        rows, columns = np.nonzero(blurred > 1e-6)
        weights = blurred[rows, columns]
        centroid = np.array([np.sum(columns * weights), np.sum(rows * weights)]) / weights.sum()
        np.testing.assert_allclose(centroid, np.array([30.0, 20.0]) - vector / 2, atol=0.05)
        assert blurred.sum() == pytest.approx(1.0, abs=1e-5)


# ---------------------------------------------------------------------- schedules and registry
def test_schedules_interpolate_and_step():
    fault = LowLight(start_s=10.0, end_s=30.0, strength=[(10, 0.0), (20, 0.8), (20, 1.0)])
    assert fault.strength_at(5.0) == 0.0
    assert fault.strength_at(15.0) == pytest.approx(0.4)
    assert fault.strength_at(20.0) == 1.0
    assert fault.strength_at(25.0) == 1.0
    assert fault.strength_at(30.0) == 0.0


def test_make_faults_accepts_names_dicts_instances_lists_and_presets():
    assert make_faults(None) == []
    noise = SensorNoise()
    made = make_faults(["low_light", {"name": "led_glare", "strength": 0.5}, noise])
    assert [type(f) for f in made] == [LowLight, LEDGlare, SensorNoise]
    assert made[1].strength == 0.5 and made[2] is noise
    assert set(FAULTS) == {"moving_occluder", "low_light", "led_glare", "motion_blur",
                           "sensor_noise"}
    lighting = make_faults({"name": "wang2023_lighting", "time_scale": 0.1})
    dark = next(f for f in lighting if isinstance(f, LowLight))
    glare = next(f for f in lighting if isinstance(f, LEDGlare))
    assert dark.strength_at(10.0) == 1.0 and dark.strength_at(15.5) == 0.0  # 75-150 s scaled
    assert glare.start_s == pytest.approx(15.0) and glare.end_s == pytest.approx(20.0)
    occlusion = make_faults("wang2023_occlusion")
    assert {f.mode for f in occlusion} == {"partial", "full"}
    full = next(f for f in occlusion if f.mode == "full")
    assert full.cover_s == pytest.approx(2.0) and full.start_s >= 100.0
    assert set(FAULT_PRESETS) == {"wang2023_occlusion", "wang2023_lighting"}


@pytest.mark.parametrize("build, parameter", [
    (lambda: make_faults("fog"), "faults"),
    (lambda: make_faults({"name": "low_light", "brightness": 2}), "faults"),
    (lambda: LowLight(strength=1.5), "strength"),
    (lambda: LowLight(strength=[(5, 0.5), (1, 0.2)]), "strength"),
    (lambda: LEDGlare(start_s=5.0, end_s=2.0), "end_s"),
    (lambda: MovingOccluder(mode="sideways"), "mode"),
    (lambda: MovingOccluder(mode="full", cover_s=3.0, period_s=2.0), "period_s"),
    (lambda: MotionBlur(exposure_s=0.0), "exposure_s"),
    (lambda: SensorNoise(read_noise_dn=-1.0), "read_noise_dn"),
    (lambda: CameraIntrinsics(width=0), "width"),
    (lambda: CameraIntrinsics(hfov_deg=190.0), "hfov_deg"),
    (lambda: CameraIntrinsics(near_m=0.5, far_m=0.1), "far_m"),
    (lambda: EyeInHandCamera(offset_m=(0.0, 0.0)), "offset_m"),
    (lambda: EyeInHandCamera(intrinsics={"widht": 10}), "intrinsics"),
    (lambda: StereoCamera(baseline_m=-0.1), "baseline_m"),
    (lambda: build_scene(None, 0.09, ground_distance_m=0.01, max_block_height_m=0.02),
     "max_block_height_m"),
    (lambda: build_scene(None, -1.0), "arm_length_m"),
])
def test_bad_values_raise_value_error_naming_the_parameter(build, parameter):
    with pytest.raises(ValueError, match=parameter):
        build()


def test_make_faults_lists_the_allowed_names():
    with pytest.raises(ValueError) as error:
        make_faults("fog")
    for name in list(FAULTS) + list(FAULT_PRESETS):
        assert name in str(error.value)


# ---------------------------------------------------------------------- stereo (zou2022)
def test_stereo_triangulation_recovers_the_backbone():
    sim = _sim("zou2022", pressures=[250e3, 0.0, 80e3], seconds=1.5)
    stereo = StereoCamera()
    stereo.reset(sim, np.random.default_rng(0))
    reading = stereo.sample(sim)
    assert stereo.space(sim).contains(reading)
    backbone = sim.backbone()
    homogeneous = np.vstack([backbone.T, np.ones(len(backbone))])
    uv = {}
    for side in ("left", "right"):
        projected = reading[f"P_{side}"] @ homogeneous
        uv[side] = projected[:2] / projected[2]
    points = cv2.triangulatePoints(reading["P_left"], reading["P_right"], uv["left"], uv["right"])
    np.testing.assert_allclose((points[:3] / points[3]).T, backbone, atol=1e-6)
    # the rendered arm (orange, on a white background) lies where P projects the backbone
    assert reading["left"][0, 0].tolist() == [255, 255, 255]
    for side in ("left", "right"):
        hsv = cv2.cvtColor(reading[side], cv2.COLOR_RGB2HSV)
        for u, v in uv[side].T[1:-1]:  # link ends inside the body (not the grey base)
            h, s, _ = hsv[int(round(v)), int(round(u))]
            assert 5 <= h <= 25 and s > 100, (side, u, v, h, s)
    # the rig is parallel (zou2022 eqs. 13-15): same rows, disparity f T_x / Z
    np.testing.assert_allclose(uv["left"][1], uv["right"][1], atol=1e-9)
    assert np.all(uv["left"][0] > uv["right"][0])


def test_stereo_images_show_the_extended_arm_without_gaps():
    """zou2022's links stretch to ~3x their rest length: the rendered body must still cover the
    whole backbone between the joints (each link's visual spans its stretched length)."""
    sim = _sim("zou2022", pressures=[300e3, 300e3, 300e3], seconds=2.0)
    rest = get_preset("zou2022").length_m
    backbone = sim.backbone()
    assert np.sum(np.linalg.norm(np.diff(backbone, axis=0), axis=1)) > 2.5 * rest
    stereo = StereoCamera()
    stereo.reset(sim, np.random.default_rng(0))
    reading = stereo.sample(sim)
    fractions = np.linspace(0.05, 0.95, 10)
    points = np.vstack([a + f * (b - a) for a, b in zip(backbone[1:-1], backbone[2:])
                        for f in fractions])
    homogeneous = np.vstack([points.T, np.ones(len(points))])
    for side in ("left", "right"):
        projected = reading[f"P_{side}"] @ homogeneous
        hsv = cv2.cvtColor(reading[side], cv2.COLOR_RGB2HSV)
        for u, v in (projected[:2] / projected[2]).T:
            h, s, _ = hsv[int(round(v)), int(round(u))]
            assert 5 <= h <= 25 and s > 100, (side, u, v, h, s)


def test_faults_belong_to_the_camera_without_an_import_cycle():
    """The faults need the intrinsics, not the camera: the faults module imports no camera
    module (the cameras import the faults), and the old home under scenarios is gone."""
    import ast
    import importlib.util
    from pathlib import Path

    import soft_gym.sensors.faults as faults_module

    tree = ast.parse(Path(faults_module.__file__).read_text(encoding="utf-8"))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names}
    assert "soft_gym.sensors.intrinsics" in imported
    assert not imported & {"soft_gym.sensors.camera", "soft_gym.sensors.stereo"}
    assert importlib.util.find_spec("soft_gym.scenarios.faults") is None
