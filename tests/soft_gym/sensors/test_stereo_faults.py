"""Visual faults on zou2022's stereo pair (poor light, an occluder; zou2022 Section 4.4, Fig. 13a)
and their routing by the env's ``faults=``.

References: the same pair rendered by a fault-free camera in the same world; the images' mean
brightness; the occluder's depth in each view; ASES (``estimate_stereo_shape``) on the faulted
frames; gymnasium's env checker.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import soft_gym  # noqa: F401
from soft_gym.robots.presets import get_preset
from soft_gym.papers.zou2022.shape_dnn import STEREO_INTRINSICS
from soft_gym.papers.zou2022.stereo_shape import estimate_stereo_shape
from soft_gym.sensors.faults import (LowLight, MovingOccluder, copy_faults, faults_per_sensor,
                                     make_faults)
from soft_gym.sensors.stereo import OCCLUDER_FRACTION, StereoCamera
from soft_gym.engines.pybullet.simulator import ArmSimulator

GREY = (0.45, 0.45, 0.5, 1.0)
"""A neutral plate: the default skin colour lies inside ASES's orange HSV range."""
ALWAYS = {"mode": "full", "start_s": 0.0, "cover_s": 1e3, "period_s": 1e3 + 1.0, "jitter_s": 0.0}
"""A plate that stays in place for the whole test."""
SIDE_NAMES = ("right", "left", "bottom", "top")


def _stereo(sim, faults=None, seed=0) -> StereoCamera:
    camera = StereoCamera(intrinsics=dict(STEREO_INTRINSICS), faults=faults)
    camera.reset(sim, np.random.default_rng(seed))
    return camera


@pytest.fixture(scope="module")
def bent():
    """The zou2022 arm settled in a bent pose, and its clean stereo reading."""
    sim = ArmSimulator(get_preset("zou2022"))
    sim.reset(settle_s=0.5)
    sim.set_pressures(np.array([200e3, 0.0, 90e3]))
    sim.step_physics(1.5)
    clean = _stereo(sim).sample(sim)
    yield sim, clean
    sim.close()


# ---------------------------------------------------------------------------------- the sensor
def test_darkness_blacks_out_both_images_and_ases_reports_lost(bent):
    sim, clean = bent
    shape = estimate_stereo_shape(clean["left"], clean["right"], clean["P_left"], clean["P_right"])
    assert not shape.lost, shape.reason
    reading = _stereo(sim, LowLight(strength=1.0)).sample(sim)
    for side in ("left", "right"):
        assert reading[side].mean() < 3.0 and np.percentile(reading[side], 99) < 12
        assert clean[side].mean() > 150.0
    np.testing.assert_array_equal(reading["P_left"], clean["P_left"])
    shape = estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                  reading["P_right"])
    assert shape.lost and "arm pixels" in shape.reason and np.all(np.isnan(shape.points_m))
    # weak light (the same for both cameras) dims both images alike
    dim = _stereo(sim, LowLight(strength=0.5)).sample(sim)
    ratios = [dim[side].mean() / clean[side].mean() for side in ("left", "right")]
    assert ratios == pytest.approx([0.5, 0.5], abs=0.03)


def test_faulted_frames_are_fixed_by_the_seed(bent):
    sim, _ = bent
    faults = [{"name": "low_light", "strength": 0.6}, {"name": "sensor_noise"}]
    runs = [_stereo(sim, faults, seed).sample(sim) for seed in (3, 3, 4)]
    for side in ("left", "right"):
        np.testing.assert_array_equal(runs[0][side], runs[1][side])
        assert not np.array_equal(runs[0][side], runs[2][side])
    # each camera draws its own noise
    assert not np.array_equal(runs[0]["left"][:, 8:], runs[0]["right"][:, :-8])


def _occluded(sim, strength, seed):
    occluder = MovingOccluder(strength=strength, rgba=GREY, **ALWAYS)
    camera = _stereo(sim, occluder, seed)
    reading = camera.sample(sim)
    plate = occluder.plate_distance_m
    # the plate is perpendicular to the cameras' common axis: it lies at depth ``plate`` in both
    covered = {side: float((np.abs(camera.last_depth[side] - plate) < 1e-3).mean())
               for side in ("left", "right")}
    side = SIDE_NAMES[occluder.motion(sim.time_s)[1]]
    return reading, covered, side, camera, occluder


def test_a_plate_covers_the_views_it_stands_in_front_of(bent):
    sim, clean = bent
    seen = {}
    for seed in range(12):
        reading, covered, side, camera, occluder = _occluded(sim, 0.25, seed)
        changed = {s: not np.array_equal(reading[s], clean[s]) for s in ("left", "right")}
        if side in ("right", "left"):
            # coming in from one side it covers that camera's view (the pair's union view is
            # 30 % covered: ~40 % of the near camera's, none of the far one's)
            other = "left" if side == "right" else "right"
            assert 0.3 < covered[side] < 0.5 and covered[other] < 0.02, (side, covered)
            assert changed[side] and not changed[other], (side, changed)
            np.testing.assert_array_equal(reading[other], clean[other])
        else:
            # from above or below it covers the same rows of both views
            assert covered["left"] == pytest.approx(0.25, abs=0.02), (side, covered)
            assert covered["right"] == pytest.approx(0.25, abs=0.02), (side, covered)
            assert changed["left"] and changed["right"]
        seen[side in ("right", "left")] = True
        if len(seen) == 2:
            break
    assert len(seen) == 2, "twelve seeds gave plates from one kind of side only"
    # the plate is a body in the world, OCCLUDER_FRACTION of the way to the arm, parked after
    # the pair is rendered: a fault-free camera in the same world sees the clean arm
    assert occluder.plate_distance_m == pytest.approx(OCCLUDER_FRACTION * camera._layout(sim)[0])
    plate, _ = sim.client.getBasePositionAndOrientation(occluder._body)
    assert plate[2] < -100.0
    again = _stereo(sim).sample(sim)
    np.testing.assert_array_equal(again["left"], clean["left"])


def test_a_plate_over_the_whole_pair_makes_ases_lost(bent):
    sim, _ = bent
    reading, covered, _, _, _ = _occluded(sim, 1.0, 0)
    assert covered["left"] > 0.999 and covered["right"] > 0.999
    shape = estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                  reading["P_right"])
    assert shape.lost and "arm pixels" in shape.reason


def test_faults_per_sensor_and_copies():
    assert faults_per_sensor("low_light") is None
    assert faults_per_sensor({"name": "low_light"}) is None
    assert faults_per_sensor({"stereo": "low_light", "image": None}) == {
        "stereo": "low_light", "image": None}
    with pytest.raises(ValueError, match="keyed by"):
        faults_per_sensor({"camera": "low_light"})
    with pytest.raises(ValueError, match=r"faults\['stereo'\]"):
        faults_per_sensor({"stereo": "earthquake"})
    original = MovingOccluder(mode="full", strength=0.7, distance_m=0.1)
    (copy,) = copy_faults(original)
    assert copy is not original and repr(copy) == repr(original)
    assert [type(f) for f in copy_faults("wang2023_lighting")] == [
        type(f) for f in make_faults("wang2023_lighting")]


# ---------------------------------------------------------------------------------- the env
def _zou(**kwargs):
    return gym.make("SoftArmReach-v0", preset="zou2022", obs=("pose", "shape"), episode_steps=6,
                    **kwargs)


def test_env_darkness_makes_the_stereo_source_lost_holding_its_last_shape():
    dark_from = 0.12  # after two clean control steps (0.05 s each)
    env = _zou(feedback="stereo", faults={"name": "low_light", "start_s": dark_from})
    try:
        base = env.unwrapped
        env.reset(seed=0)
        for _ in range(2):
            observation, _, _, _, info = env.step(np.full(3, 0.3, dtype=np.float32))
        assert info["estimates"]["lost"] is False
        good = base.observation_part(observation, "shape").copy()
        for step in (1, 2):
            observation, _, _, _, info = env.step(np.full(3, 0.3, dtype=np.float32))
            assert info["time_s"] > dark_from
            for side in ("left", "right"):
                assert info["sensors"]["stereo"][side].mean() < 3.0
            estimates = info["estimates"]
            assert estimates["lost"] is True and "arm pixels" in estimates["reason"]
            assert estimates["held_steps"] == step
            np.testing.assert_array_equal(base.observation_part(observation, "shape"), good)
    finally:
        env.close()


def test_env_with_stereo_faults_passes_the_checker_and_is_seeded():
    env = _zou(feedback="stereo", faults={"name": "low_light", "strength": 0.6})
    try:
        check_env(env.unwrapped, skip_render_check=True)
        frames = []
        for seed in (5, 5, 6):
            _, info = env.reset(seed=seed)
            frames.append(info["sensors"]["stereo"]["left"])
        np.testing.assert_array_equal(frames[0], frames[1])
        assert not np.array_equal(frames[0], frames[2])
        assert not info["estimates"]["lost"]  # 60 % less light: ASES still finds the arm
    finally:
        env.close()


def test_env_routes_faults_to_each_simulated_camera():
    kwargs = {"preset": "wang2023", "feedback": "em", "obs": ("pose", "image"),
              "obs_format": "dict", "sensors": ("stereo",), "episode_steps": 3}
    env = gym.make("SoftArmReach-v0", faults="low_light", **kwargs)
    try:
        base = env.unwrapped
        image, stereo = base.sensors["image"], base.sensors["stereo"]
        assert [type(f) for f in image.faults] == [type(f) for f in stereo.faults] == [LowLight]
        assert image.faults[0] is not stereo.faults[0]  # one instance per camera
        observation, info = env.reset(seed=0)
        assert observation["image"].mean() < 3.0
        assert info["sensors"]["stereo"]["left"].mean() < 3.0
    finally:
        env.close()
    env = gym.make("SoftArmReach-v0", faults={"stereo": "low_light", "image": None}, **kwargs)
    try:
        observation, info = env.reset(seed=0)
        assert env.unwrapped.sensors["image"].faults == []
        assert observation["image"].mean() > 20.0
        assert info["sensors"]["stereo"]["right"].mean() < 3.0
    finally:
        env.close()


def test_env_refuses_faults_without_the_camera_they_name():
    with pytest.raises(ValueError, match=r"eye-in-hand camera \('image'\) and the stereo pair "
                                         r"\('stereo'\)"):
        _zou(feedback="encoder_cc", faults="low_light")
    with pytest.raises(ValueError, match=r"faults\['image'\] is for a camera"):
        _zou(feedback="stereo", faults={"image": "low_light"})
    with pytest.raises(ValueError, match="keyed by"):
        _zou(feedback="stereo", faults={"left": "low_light"})
    with pytest.raises(ValueError, match="faults"):
        _zou(feedback="stereo", faults="earthquake")
