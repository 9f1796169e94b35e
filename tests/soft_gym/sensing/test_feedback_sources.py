"""Feedback sources as plug-ins, one measurement per step, and the calibration cache."""

from __future__ import annotations

import os
import subprocess
import sys
import types
import warnings

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from soft_gym.papers.wang2023 import calibration as wang2023_calibration
from soft_gym.papers.zhao2021 import exploration as zhao2021_exploration
from soft_gym.procedures import calibration as procedures
from soft_gym.robots import get_preset
from soft_gym.sensing import calibration_cache
from soft_gym.sensing import FEEDBACK_SOURCES, FeedbackEstimate, FeedbackSource
from soft_gym.sensing.feedback import EMFeedback, GroundTruthFeedback
from soft_gym.sensing.feedback_base import CalibrationContext
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.wang2023 import pipeline
from soft_gym.papers.wang2023.feedback import CameraFeedback, FEmpFeedback, FusedFeedback
from soft_gym.papers.zhao2021 import shape_reconstruction
from soft_gym.papers.zhao2021.feedback import StrainShapeFeedback

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


def test_a_value_is_computed_on_one_thread_whatever_threads_the_caller_runs(cache_dir):
    """A cached calibration is a function of its key: computed with one BLAS, OpenMP and torch
    thread even where the caller (a training process, say) runs several, which it gets back."""
    import torch
    from threadpoolctl import threadpool_info, threadpool_limits

    def threads() -> tuple[int, int]:
        return torch.get_num_threads(), max(pool["num_threads"] for pool in threadpool_info())

    seen = []

    def compute() -> int:
        seen.append(threads())
        return 1

    torch_threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        with threadpool_limits(limits=2):
            assert threads() == (2, 2)
            calibration_cache.cached({"test": "threads"}, compute)
            calibration_cache.cached({"test": "threads"}, compute, use_cache=False)
            after = threads()
    finally:
        torch.set_num_threads(torch_threads)
    assert seen == [(1, 1), (1, 1)]
    assert after == (2, 2)


_SECOND_PROCESS = """
import numpy as np, gymnasium as gym, soft_gym
from soft_gym.papers.wang2023.pipeline import SensingPipeline

def refuse(*args, **kwargs):
    raise AssertionError("the second process calibrated instead of reading the disk cache")

SensingPipeline.begin_calibration = refuse
import soft_gym.procedures.workspace as workspace
workspace.make_simulator = refuse  # the reachable tips come from the disk cache too
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
    assert len(files) == 2  # the sensing calibration and the arm's reachable tips
    out = tmp_path / "second.npy"
    result = subprocess.run([sys.executable, "-c", _SECOND_PROCESS.replace("OUT_PATH", repr(str(out)))],
                            env={**os.environ, "XDG_CACHE_HOME": str(cache_dir)},
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    assert np.array_equal(np.load(out), first)


def test_a_corrupt_cache_file_is_ignored_and_rebuilt(cache_dir):
    reference = _run(gym.make("SoftArmTrackWang2023-v0", sensing=QUICK))
    # the sensing calibration: the larger of its file and the reachable tips'
    path = max((cache_dir / "soft-arm-gym" / "calibration").glob("*.pkl"),
               key=lambda file: file.stat().st_size)
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


# ==========================================================================================
# Checks that mutation testing found missing (docs/mutation_testing.md)
#
# Each test pins a documented behaviour of a feedback source that a surviving mutant changed
# unnoticed, with scripted stand-ins for the slow collaborators (the simulator, the sensing
# pipeline, the shape reconstructor): ``ground_truth`` passes the truth sensor's pose and backbone
# and its key points at sixths of the rest length; ``em`` splits the tracker's reading; the pipeline
# sources are calibrated by their procedure (:mod:`soft_gym.procedures.calibration`) on a private
# simulator at rest with fresh, fault-free sensors, through the calibration cache, return to that
# calibration on ``restore`` and report their own output with the details; ``strain_sr`` hands the
# networks the commands sent and the readings of every ``history_step_s`` of simulated time (the
# last five plus the present one) and starts afresh when the clock goes back.
# ==========================================================================================


ZHAO = get_preset("zhao2021")   # two segments of 100.9 mm, four links each, six chambers


# ---------------------------------------------------------------------------------- ground truth
@pytest.mark.smoke
def test_ground_truth_is_the_truth_sensors_pose_and_backbone_and_key_points() -> None:
    arcs = np.r_[0.0, np.cumsum([0.02675] * 8)]
    backbone = np.c_[0.3 * arcs ** 2, -arcs ** 3, arcs + 0.01]
    source = GroundTruthFeedback()
    assert source.sensors == ("truth",)
    source.prepare(CalibrationContext(spec=ZHAO))
    truth = {"position_m": np.array([0.1, 0.2, 0.3]),
             "quaternion": np.array([0.0, 0.6, 0.0, 0.8]), "backbone_m": backbone}
    estimate = source.estimate(Measurement(0.0, {"truth": truth}))
    np.testing.assert_array_equal(estimate.position_m, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(estimate.quaternion, [0.0, 0.6, 0.0, 0.8])
    np.testing.assert_array_equal(estimate.shape_m, backbone)
    points = source.shape_points(estimate)
    targets = 0.214 * np.arange(1, 7) / 6.0                       # sixths of the rest length
    expected = np.stack([np.interp(targets, arcs, backbone[:, i]) for i in range(3)], axis=1)
    assert points.shape == (7, 3)
    np.testing.assert_array_equal(points[0], backbone[0])    # the base
    np.testing.assert_allclose(points[1:], expected, rtol=0, atol=1e-15)


@pytest.mark.smoke
def test_em_splits_the_trackers_reading() -> None:
    reading = np.array([0.01, -0.02, 0.15, 0.0, 0.0, 0.6, 0.8], dtype=np.float32)
    estimate = EMFeedback().estimate(Measurement(0.0, {"em": reading}))
    np.testing.assert_array_equal(estimate.position_m, reading[:3])
    np.testing.assert_array_equal(estimate.quaternion, reading[3:])


# ---------------------------------------------------------------------------------- pipeline
class Fusion:
    @staticmethod
    def weight(error_px, lost) -> float:
        return -1.0 if lost else 1.0 / (1.0 + error_px)


class Pipeline:
    """Stands in for ``SensingPipeline``: records how it is built and calibrated."""

    OPTIONS = pipeline.SensingPipeline.OPTIONS
    built: list = []

    def __init__(self, camera, fiber, **options) -> None:
        self.camera, self.fiber, self.options = camera, fiber, options
        self.fusion = Fusion()
        self.vision = self.femp = self.calibration_samples = None
        self.calls: list = []
        Pipeline.built.append(self)

    def calibrate(self, sim, rng) -> None:
        self.calls.append(("calibrate", sim.settled, sim.loads, rng.standard_normal()))
        self.vision = {"map": [1, 2, 3]}
        self.femp = {"weights": [0.5]}
        self.calibration_samples = 40

    def observe(self, measurement):
        return types.SimpleNamespace(
            camera=(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0])),
            femp=(np.array([2.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, 0.0])),
            fused=(np.array([3.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0, 0.0])),
            reprojection_error_px=measurement.time_s, lost=measurement.time_s > 5.0,
            femp_updated=True)


class RestSim:
    """Stands in for the procedure's private simulator: records its loads, settle and close."""

    made: list = []

    def __init__(self, spec) -> None:
        self.spec, self.loads, self.settled, self.closed = spec, [], None, False
        RestSim.made.append(self)

    def add_load(self, load) -> None:
        self.loads.append(load)

    def reset(self, settle_s=None) -> None:
        self.settled = settle_s

    def close(self) -> None:
        self.closed = True


@pytest.fixture
def stand_in_pipeline(monkeypatch):
    monkeypatch.setattr(wang2023_calibration, "SensingPipeline", Pipeline)
    monkeypatch.setattr(procedures, "make_simulator", RestSim)
    monkeypatch.setattr(wang2023_calibration, "calibrate_pipeline",
                        lambda built, sim, rng: built.calibrate(sim, rng))
    monkeypatch.setenv("SOFT_GYM_CACHE", "off")
    calibration_cache.clear_memory()
    Pipeline.built, RestSim.made = [], []
    yield Pipeline
    calibration_cache.clear_memory()


def _context(key=None) -> CalibrationContext:
    return CalibrationContext(spec=get_preset("wang2023"), settle_s=0.7,
                              key=key or {"arm": "wang2023-test-feedback"},
                              make_sensor=lambda name: f"fresh {name}",
                              make_loads=lambda: ["load copy"])


def test_pipeline_sources_read_the_fiber_every_step_and_refuse_unknown_options() -> None:
    assert CameraFeedback().sensor_options() == {"fbg": {"rate_hz": None}}
    with pytest.raises(ValueError, match=r"^sensing options must be among \[.*'n_init'.*\], "
                                         r"got \['bogus', 'n_innit'\]$"):
        FusedFeedback({"n_innit": 50, "bogus": 1})


def test_calibration_on_a_private_arm_at_rest_with_fresh_sensors(stand_in_pipeline) -> None:
    options = {"n_init": 50}
    source = FEmpFeedback(options)
    options["n_init"] = 7                  # the source keeps its own copy of the options
    procedures.calibrate(source, _context())
    built = stand_in_pipeline.built[-1]
    assert built.camera == "fresh image" and built.fiber == "fresh fbg"
    assert built.options == {"n_init": 50}
    noise = np.random.default_rng(0).standard_normal()
    assert built.calls == [("calibrate", 0.7, ["load copy"], noise)]
    assert RestSim.made[-1].closed                               # the private arm is closed
    assert source.pipeline is built
    assert (built.vision, built.femp, built.calibration_samples) == (
        {"map": [1, 2, 3]}, {"weights": [0.5]}, 40)


def test_calibration_comes_from_the_cache_for_the_same_key(stand_in_pipeline) -> None:
    first, second = CameraFeedback({"n_init": 50}), CameraFeedback({"n_init": 50})
    procedures.calibrate(first, _context())
    procedures.calibrate(second, _context())
    assert sum(len(p.calls) for p in stand_in_pipeline.built) == 1
    other = CameraFeedback({"n_init": 60})         # other options: another key
    procedures.calibrate(other, _context())
    assert sum(len(p.calls) for p in stand_in_pipeline.built) == 2
    fresh = CameraFeedback({"n_init": 50})         # no cache: calibrated again
    procedures.calibrate(fresh, _context(), use_cache=False)
    assert sum(len(p.calls) for p in stand_in_pipeline.built) == 3


def test_restore_returns_to_the_calibrated_state_every_time(stand_in_pipeline) -> None:
    source = FusedFeedback()
    procedures.calibrate(source, _context(), use_cache=False)
    source.pipeline.femp["weights"].append(9.0)    # online learning changes the model
    source.pipeline.vision["map"].clear()
    source.pipeline.calibration_samples = 41
    source.restore()
    assert source.pipeline.femp == {"weights": [0.5]}
    assert source.pipeline.vision == {"map": [1, 2, 3]}
    assert source.pipeline.calibration_samples == 40
    source.pipeline.femp["weights"].append(9.0)
    source.restore()
    assert source.pipeline.femp == {"weights": [0.5]}


@pytest.mark.parametrize("source_class, expected_x", [(CameraFeedback, 1.0), (FEmpFeedback, 2.0),
                                                      (FusedFeedback, 3.0)])
def test_each_pipeline_source_reports_its_own_output_with_the_details(
        stand_in_pipeline, source_class, expected_x) -> None:
    source = source_class()
    procedures.calibrate(source, _context(), use_cache=False)
    estimate = source.estimate(Measurement(3.0, {}))
    np.testing.assert_array_equal(estimate.position_m, [expected_x, 0.0, 0.0])
    expected_q = {1.0: [0, 0, 0, 1], 2.0: [0, 0, 1, 0], 3.0: [0, 1, 0, 0]}[expected_x]
    np.testing.assert_array_equal(estimate.quaternion, expected_q)
    details = estimate.details
    assert sorted(details) == ["camera", "femp", "femp_updated", "femp_weight", "fused", "lost",
                               "reprojection_error_px"]
    np.testing.assert_array_equal(details["camera"], [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(details["femp"], [2.0, 0.0, 0.0])
    np.testing.assert_array_equal(details["fused"], [3.0, 0.0, 0.0])
    assert details["reprojection_error_px"] == 3.0 and details["lost"] is False
    assert details["femp_weight"] == pytest.approx(0.25) and details["femp_updated"] is True
    lost = source.estimate(Measurement(6.0, {})).details
    assert lost["lost"] is True and lost["femp_weight"] == -1.0


# ---------------------------------------------------------------------------------- strain_sr
class Reconstructor:
    window = 5

    def __init__(self) -> None:
        self.calls: list = []

    def reconstruct(self, pressures, readings):
        self.calls.append((pressures.copy(), readings.copy()))
        key = np.arange(1.0, 19.0).reshape(6, 3) * readings[-1, 0]
        return shape_reconstruction.ShapeEstimate(
            key_points_m=key, backbone_m=np.ones((11, 3)) * readings[-1, 0],
            tip_position_m=key[-1], tip_quaternion=np.array([0.0, 0.0, 0.0, 1.0]))


def _strain_source(options: dict | None = None) -> StrainShapeFeedback:
    source = StrainShapeFeedback(options)
    source.prepare(CalibrationContext(spec=ZHAO))
    source.reconstructor = Reconstructor()
    return source


def _step(source, time_s: float, value: float):
    """One step whose commanded pressures are ``value`` kPa and gauge readings ``value``."""
    return source.estimate(Measurement(time_s, {"strain": np.full(6, value)},
                                       command_pa=np.full(6, 1e3 * value)))


def _windows(source) -> list[list[float]]:
    """The readings handed to the networks at each call, one value per row."""
    return [list(readings[:, 0]) for _, readings in source.reconstructor.calls]


def test_strain_sr_history_keeps_one_state_per_history_step() -> None:
    source = _strain_source({"history_step_s": 1.0})
    _step(source, 0.0, 1.0)
    _step(source, 0.5, 2.0)
    _step(source, 1.0, 3.0)                   # due: joins the history
    _step(source, 1.5, 4.0)
    _step(source, 2.0 - 5e-10, 5.0)           # due within the 1e-9 s tolerance
    _step(source, 2.5, 6.0)
    assert _windows(source) == [
        [1.0] * 6,
        [1.0] * 5 + [2.0],
        [1.0] * 4 + [3.0, 3.0],
        [1.0] * 4 + [3.0, 4.0],
        [1.0] * 3 + [3.0, 5.0, 5.0],
        [1.0] * 3 + [3.0, 5.0, 6.0],
    ]
    pressures, readings = source.reconstructor.calls[-1]
    assert pressures.shape == readings.shape == (6, 6)
    np.testing.assert_array_equal(pressures[-1], np.full(6, 6e3))   # commanded pressures first


def test_strain_sr_starts_afresh_when_the_clock_goes_back() -> None:
    source = _strain_source()                       # history_step_s = 1 s by default
    _step(source, 0.0, 1.0)
    _step(source, 1.0, 2.0)
    _step(source, 1.0 - 5e-10, 3.0)            # the same time to 1e-9 s: no new episode
    _step(source, 0.1, 4.0)                    # back in time: a new episode
    _step(source, 0.6, 5.0)
    _step(source, 1.1, 6.0)                    # one step after the new start
    assert _windows(source) == [
        [1.0] * 6,
        [1.0] * 4 + [2.0, 2.0],
        [1.0] * 4 + [2.0, 3.0],
        [4.0] * 6,
        [4.0] * 5 + [5.0],
        [4.0] * 4 + [6.0, 6.0],
    ]
    source.restore()
    _step(source, 2.0, 7.0)
    assert _windows(source)[-1] == [7.0] * 6


def test_strain_sr_estimate_is_the_reconstructed_shape() -> None:
    estimate = _step(_strain_source(), 0.0, 2.0)
    key = np.arange(1.0, 19.0).reshape(6, 3) * 2.0
    np.testing.assert_array_equal(estimate.position_m, key[-1])
    np.testing.assert_array_equal(estimate.quaternion, [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(estimate.shape_m, np.full((11, 3), 2.0))
    np.testing.assert_array_equal(estimate.shape_points_m, np.vstack([np.zeros(3), key]))
    np.testing.assert_array_equal(estimate.details["key_points_m"], key)
    assert sorted(estimate.details) == ["key_points_m"]


def test_strain_sr_calibrates_through_the_cached_reconstruction(monkeypatch) -> None:
    calls = []
    reconstructor = Reconstructor()

    def cached_reconstruction(spec, gauges, config, use_cache=True, progress=False):
        calls.append((spec, gauges, config, use_cache, progress))
        return reconstructor, {"report": 1}

    monkeypatch.setattr(zhao2021_exploration, "cached_reconstruction", cached_reconstruction)
    source = StrainShapeFeedback({"n_free": 30, "history_step_s": 0.5})
    assert source.history_step_s == 0.5 and source.config.n_free == 30
    context = CalibrationContext(spec=ZHAO, settle_s=1.0, make_sensor=lambda name: "gauges")
    source.prepare(context)
    procedures.calibrate(source, context, use_cache=False)
    assert calls == [(ZHAO, "gauges", source.config, False, True)]
    assert source.reconstructor is reconstructor and source.report == {"report": 1}
    _step(source, 0.0, 1.0)
    _step(source, 0.5, 2.0)             # 0.5 s history steps
    assert _windows(source)[-1] == [1.0] * 4 + [2.0, 2.0]
    procedures.calibrate(source, context)
    assert calls[-1][3] is True
    _step(source, 3.0, 3.0)                   # calibration restored the history
    assert _windows(source)[-1] == [3.0] * 6


@pytest.mark.parametrize("value", [0.0, -1.0])
def test_strain_sr_history_step_must_be_positive(value: float) -> None:
    with pytest.raises(ValueError, match=r"^history_step_s must be a finite number > 0"):
        StrainShapeFeedback({"history_step_s": value})
