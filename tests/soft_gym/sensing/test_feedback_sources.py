"""Feedback sources as plug-ins, one measurement per step, and the calibration cache."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from soft_gym.sensing import calibration_cache
from soft_gym.sensing import FEEDBACK_SOURCES, FeedbackEstimate, FeedbackSource

QUICK = {"n_init": 40}
"""A short calibration (40 labelled exploration steps) for tests that only compare runs."""


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """A private, empty disk cache and an empty in-process cache."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("SOFT_GYM_CACHE", "on")
    calibration_cache.clear_memory()
    yield tmp_path
    calibration_cache.clear_memory()


def _run(env, steps: int = 15) -> np.ndarray:
    observation, _ = env.reset(seed=3)
    rng = np.random.default_rng(3)
    record = [observation]
    for _ in range(steps):
        observation, *_ = env.step(rng.uniform(-0.6, 0.6, 3).astype(np.float32))
        record.append(observation)
    env.close()
    return np.array(record)


def test_calibration_does_not_depend_on_what_was_built_before(cache_dir, monkeypatch):
    monkeypatch.setenv("SOFT_GYM_CACHE", "off")
    alone = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    calibration_cache.clear_memory()
    gym.make("SoftArmTrackWang2023-v0", sensing=QUICK,
             scenario={"name": "tip_mass", "mass_kg": 0.02}).close()
    after_loaded = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    assert np.array_equal(alone, after_loaded)


_SECOND_PROCESS = """
import numpy as np, gymnasium as gym, soft_gym
from soft_gym.sensing.wang2023.pipeline import SensingPipeline

def refuse(*args, **kwargs):
    raise AssertionError("the second process calibrated instead of reading the disk cache")

SensingPipeline.begin_calibration = refuse
env = gym.make("SoftArmTrackWang2023-v0", sensing={"n_init": 40})
observation, _ = env.reset(seed=3)
rng = np.random.default_rng(3)
record = [observation]
for _ in range(15):
    observation, *_ = env.step(rng.uniform(-0.6, 0.6, 3).astype(np.float32))
    record.append(observation)
np.save(OUT_PATH, np.array(record))
"""


def test_a_second_process_reads_the_disk_cache(cache_dir, tmp_path):
    first = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    files = list((cache_dir / "soft-arm-gym" / "calibration").glob("*.pkl"))
    assert len(files) == 1
    out = tmp_path / "second.npy"
    result = subprocess.run([sys.executable, "-c", _SECOND_PROCESS.replace("OUT_PATH", repr(str(out)))],
                            env={**os.environ, "XDG_CACHE_HOME": str(cache_dir)},
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    assert np.array_equal(np.load(out), first)


def test_a_corrupt_cache_file_is_ignored_and_rebuilt(cache_dir):
    reference = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    (path,) = (cache_dir / "soft-arm-gym" / "calibration").glob("*.pkl")
    data = bytearray(path.read_bytes())
    data[-100] ^= 0xFF
    path.write_bytes(bytes(data))
    calibration_cache.clear_memory()
    with pytest.warns(RuntimeWarning, match="ignoring calibration cache file"):
        rebuilt = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    assert np.array_equal(rebuilt, reference)
    calibration_cache.clear_memory()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the rebuilt file is trusted again
        gym.make("SoftArmTrackWang2023-v0", sensing=QUICK).close()


def test_faults_need_a_simulated_camera():
    for feedback in ("em", "ground_truth"):
        with pytest.raises(ValueError, match="faults act on the eye-in-hand camera"):
            gym.make("SoftArmReachWang2023-v0", feedback=feedback, faults="low_light")
    env = gym.make("SoftArmReachWang2023-v0", feedback="em", faults="low_light",
                   obs=("pose", "image"), obs_format="dict")
    env.close()


def test_sensing_options_only_for_the_pipeline():
    with pytest.raises(ValueError, match="feedback 'em' takes no sensing options"):
        gym.make("SoftArmReachWang2023-v0", feedback="em", sensing={"n_init": 50})
    with pytest.raises(ValueError, match="sensing options must be among"):
        gym.make("SoftArmReachWang2023-v0", sensing={"n_innit": 50})


def test_a_new_estimator_is_one_registered_class():
    class BaseTwinFeedback(FeedbackSource):
        """A toy estimator: the EM position mirrored through the base plane."""

        name = "test_mirrored_em"
        sensors = ("em",)

        def estimate(self, measurement):
            reading = np.asarray(measurement["em"], dtype=float)
            return FeedbackEstimate(reading[:3] * np.array([1.0, 1.0, -1.0]), reading[3:])

    FEEDBACK_SOURCES.register(BaseTwinFeedback.name, BaseTwinFeedback)
    try:
        env = gym.make("SoftArmReachWang2023-v0", feedback="test_mirrored_em")
        observation, info = env.reset(seed=0)
        assert observation[2] == pytest.approx(-info["sensors"]["em"][2], abs=1e-6)
        assert "em" in env.unwrapped.sensors
        env.close()
    finally:
        FEEDBACK_SOURCES.unregister("test_mirrored_em")


def test_every_sensor_is_sampled_once_per_step():
    env = gym.make("SoftArmReachWang2023-v0", feedback="em", obs=("pose", "fbg", "em"),
                   sensor_config={"fbg": {"rate_hz": None}}).unwrapped
    counts = {}
    for name, sensor in env.sensors.items():
        original = sensor.sample

        def counting(sim, _original=original, _name=name):
            counts[_name] = counts.get(_name, 0) + 1
            return _original(sim)

        sensor.sample = counting
    env.reset(seed=0)
    counts.clear()
    for _ in range(5):
        observation, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert counts["fbg"] == 5
    assert np.array_equal(observation[7:7 + len(info["sensors"]["fbg"])],
                          info["sensors"]["fbg"].astype(np.float32))
    env.close()
