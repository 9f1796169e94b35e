"""The sensing pipeline ``soft_gym.papers.wang2023.pipeline`` on scripted stand-ins: the checks
that mutation testing found missing (docs/mutation_testing.md).

Each test pins a documented behaviour of the sensing pipeline (wang2023 Fig. 1): the option
checks and defaults, F-emp's update threshold taken from the fusion, the calibration sequence
(the spiral exploration's pressures, ``map_steps`` frames for the map alone, then ``n_init``
frames of which only the well-tracked ones label F-emp) and one ``observe`` step (F-emp
predicts, the camera tracks, F-emp is updated selectively, eq. (18) fuses). The camera, the
fiber, the simulator and the vision tracker are small scripted stand-ins, so the references
(which samples F-emp gets, the pressures commanded, the fused pose) are computed here from the
documented rules with the public ``FEmpEstimator``, ``PoseFusion``, ``spiral_fractions`` and
``pressure_at_fraction``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import soft_gym.papers.wang2023.pipeline as pipeline_module
from soft_gym.robots import get_preset
from soft_gym.robots.actuation import pressure_at_fraction
from soft_gym.papers.wang2023.exploration import spiral_fractions
from soft_gym.papers.wang2023.femp import FEmpEstimator
from soft_gym.papers.wang2023.fusion import PoseFusion
from soft_gym.papers.wang2023.calibration import calibrate_pipeline
from soft_gym.sensors.measurement import Measurement
from soft_gym.papers.wang2023.pipeline import SensingPipeline
from soft_gym.papers.wang2023.vision_pose import VisionEstimate

SPEC = get_preset("wang2023")
K = np.array([[300.0, 0.0, 160.0], [0.0, 300.0, 120.0], [0.0, 0.0, 1.0]])
OFFSET = np.array([0.001, -0.002, 0.004])
N_SHIFTS = 6


def _shifts(k: int) -> np.ndarray:
    return np.random.default_rng(1000 + k).uniform(-1.0, 1.0, N_SHIFTS)


def _position(k: int) -> np.ndarray:
    return np.array([0.01 * np.sin(0.1 * k), 0.01 * np.cos(0.13 * k), 0.1 + 0.0001 * k])


def _quaternion(k: int) -> np.ndarray:
    return Rotation.from_rotvec([0.2 * np.sin(0.1 * k), 0.1, 0.0]).as_quat()


def _error(k: int) -> float:
    """A scripted ``e_S`` (px): some frames exactly at the default trust threshold of 0.94 px,
    every third frame 0.95 px (just above it), every fifth 0.5 px, the rest 0.93 px."""
    if k % 11 == 4:
        return 0.94
    return 0.5 if k % 5 == 0 else (0.95 if k % 3 == 0 else 0.93)


def _lost(k: int) -> bool:
    return k % 7 == 6


class FakeSim:
    def __init__(self, spec=SPEC) -> None:
        self.spec = spec
        self.time_s = 0.0
        self.pressures: list[np.ndarray] = []
        self.steps: list[float] = []

    def set_pressures(self, pressures) -> None:
        self.pressures.append(np.array(pressures, dtype=float))

    def step_physics(self, duration_s: float) -> None:
        self.steps.append(duration_s)
        self.time_s += duration_s


class FakeCamera:
    """Reads the frame index as its "image"; the depth is a constant buffer."""

    offset_m = OFFSET

    def __init__(self) -> None:
        self.resets: list = []
        self.frame = 0
        self.last_depth = np.full((4, 4), 0.2)

    def reset(self, sim, rng) -> None:
        self.resets.append((sim, rng))

    def K(self) -> np.ndarray:
        return K.copy()

    def render_clean(self, sim):
        assert isinstance(sim, FakeSim), sim
        return "rest image", "rest depth"

    def pose_matrix(self, sim) -> np.ndarray:
        assert isinstance(sim, FakeSim), sim
        pose = np.eye(4)
        pose[:3, 3] = [0.0, 0.0, 0.11]
        return pose

    def read(self, sim, time_s: float) -> int:
        self.frame += 1
        return self.frame - 1


class FakeFiber:
    def __init__(self) -> None:
        self.resets: list = []
        self.reads = 0

    def reset(self, sim, rng) -> None:
        self.resets.append((sim, rng))

    def read(self, sim, time_s: float) -> np.ndarray:
        self.reads += 1
        return _shifts(self.reads - 1)


class FakeVision:
    """Stands in for ``VisionPoseEstimator``: frame k (the "image") is tracked at the scripted
    pose, ``e_S`` and lost flag of k."""

    instances: list["FakeVision"] = []

    def __init__(self, camera_matrix, tip_from_camera, **options) -> None:
        self.camera_matrix = camera_matrix
        self.tip_from_camera = tip_from_camera
        self.options = options
        self.calibrated_with = None
        self.updates: list = []
        FakeVision.instances.append(self)

    def calibrate(self, image, depth, world_from_camera) -> int:
        self.calibrated_with = (image, depth, world_from_camera)
        return 100

    def update(self, image, depth_m=None, prior_world_from_tip=None) -> VisionEstimate:
        self.updates.append((image, depth_m, prior_world_from_tip))
        k = int(image)
        lost = _lost(k)
        return VisionEstimate(_position(k), _quaternion(k), np.inf if lost else _error(k),
                              0 if lost else 80, lost, np.eye(4))


@pytest.fixture()
def fake_vision(monkeypatch):
    FakeVision.instances = []
    monkeypatch.setattr(pipeline_module, "VisionPoseEstimator", FakeVision)
    return FakeVision


def _accepted(frames, threshold: float) -> list[int]:
    return [k for k in frames if not _lost(k) and _error(k) < threshold]


# ------------------------------------------------------------------ options
def test_defaults() -> None:
    pipeline = SensingPipeline(FakeCamera(), FakeFiber())
    assert pipeline.n_init == 450 and pipeline.map_steps == 0 and pipeline.femp_prior is False
    assert pipeline.fusion == PoseFusion()
    assert pipeline.femp_options == {"update_threshold_px": PoseFusion().trust_threshold_px}
    assert pipeline.vision_options == {}
    assert pipeline.exploration == {"turn_s": 8.0, "breath_s": 45.0, "low": 0.05, "high": 0.6,
                                    "common": 0.3, "common_s": 11.0}
    assert pipeline.vision is None and pipeline.femp is None
    assert pipeline.calibration_samples == 0 and not pipeline.is_calibrated


def test_options_are_merged_over_the_defaults() -> None:
    """F-emp's threshold is the fusion's trust threshold unless set explicitly; exploration
    keywords replace only the defaults they name; a fusion may be given as a dict of bounds."""
    pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=10, map_steps=3,
                               femp={"n_hidden": 12}, fusion={"lower_px": 1.0, "upper_px": 3.0},
                               vision={"n_features": 200}, exploration={"high": 0.4},
                               femp_prior=np.True_)
    assert pipeline.fusion == PoseFusion(1.0, 3.0)
    assert pipeline.femp_options == {"update_threshold_px": 2.0, "n_hidden": 12}
    assert pipeline.vision_options == {"n_features": 200}
    assert pipeline.exploration["high"] == 0.4 and pipeline.exploration["low"] == 0.05
    assert pipeline.femp_prior is True and pipeline.map_steps == 3 and pipeline.n_init == 10
    explicit = SensingPipeline(FakeCamera(), FakeFiber(), femp={"update_threshold_px": 0.5},
                               fusion=PoseFusion(0.2, 0.4))
    assert explicit.femp_options == {"update_threshold_px": 0.5}
    assert explicit.fusion == PoseFusion(0.2, 0.4)


@pytest.mark.parametrize("options, message", [
    ({"n_init": 9}, r"^n_init must be an integer >= 10, got 9$"),
    ({"n_init": 10.0}, r"^n_init must be an integer >= 10, got 10\.0$"),
    ({"map_steps": True}, r"^map_steps must be an integer >= 0, got True$"),
    ({"map_steps": -1}, r"^map_steps must be an integer >= 0, got -1$"),
    ({"femp_prior": 1}, r"^femp_prior must be True or False, got 1$"),
    ({"fusion": "tight"}, r"^fusion must be None, a PoseFusion or a dict of its bounds "
                          r"\(lower_px, upper_px\), got 'tight'$"),
])
def test_bad_options_are_named_first(options: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SensingPipeline(FakeCamera(), FakeFiber(), **options)


def test_smallest_options_are_accepted() -> None:
    pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=10, map_steps=0)
    assert pipeline.n_init == 10 and pipeline.map_steps == 0


# ------------------------------------------------------------------ calibration
@pytest.mark.parametrize("preset", ["wang2023", "zhao2021"])  # one and two segments
def test_calibration_sequence(fake_vision, preset: str) -> None:
    """The vision map starts at the rest frame from the camera's intrinsics and offset; the arm
    then follows the spiral exploration of all its segments (one control period per frame),
    the first ``map_steps`` frames only feed the map, and of the next ``n_init`` frames those
    tracked with ``e_S`` strictly below F-emp's threshold initialise F-emp."""
    spec = get_preset(preset)
    camera, fiber, sim, rng = FakeCamera(), FakeFiber(), FakeSim(spec), np.random.default_rng(0)
    pipeline = SensingPipeline(camera, fiber, n_init=40, map_steps=5, femp={"n_hidden": 15},
                               vision={"n_features": 300}, exploration={"high": 0.5})
    count = calibrate_pipeline(pipeline, sim, rng)
    assert camera.resets == [(sim, rng)] and fiber.resets == [(sim, rng)]
    vision = fake_vision.instances[-1]
    assert pipeline.vision is vision
    np.testing.assert_array_equal(vision.camera_matrix, K)
    expected_tip_from_camera = np.eye(4)
    expected_tip_from_camera[:3, 3] = OFFSET
    np.testing.assert_array_equal(vision.tip_from_camera, expected_tip_from_camera)
    assert vision.options == {"n_features": 300}
    assert vision.calibrated_with[:2] == ("rest image", "rest depth")
    np.testing.assert_array_equal(vision.calibrated_with[2], camera.pose_matrix(sim))
    # 45 frames, each tracked once, with its depth and no prior
    assert [u[0] for u in vision.updates] == list(range(45))
    assert all(u[1] is camera.last_depth and u[2] is None for u in vision.updates)
    assert sim.steps == [spec.control_period_s] * 45
    exploration = {"turn_s": 8.0, "breath_s": 45.0, "low": 0.05, "high": 0.5, "common": 0.3,
                   "common_s": 11.0}
    assert len(sim.pressures) == 45
    for k, pressures in enumerate(sim.pressures):
        fractions = spiral_fractions(k * spec.control_period_s, spec.n_segments, **exploration)
        assert pressures.shape == (spec.n_chambers,)
        np.testing.assert_allclose(pressures, pressure_at_fraction(spec, fractions), rtol=1e-12)
    accepted = _accepted(range(5, 45), 0.94)
    assert any(_error(k) == 0.94 for k in range(5, 45)), "frames at the threshold are needed"
    assert count == pipeline.calibration_samples == len(accepted)
    assert pipeline.is_calibrated
    reference = FEmpEstimator(n_hidden=15, update_threshold_px=0.94)
    reference.initialize(np.array([_shifts(k) for k in accepted]),
                         np.array([_position(k) for k in accepted]),
                         np.array([_quaternion(k) for k in accepted]))
    assert pipeline.femp.update_threshold_px == pytest.approx(0.94)
    assert pipeline.femp.elm.n_hidden == 15
    for k in (0, 17, 44):
        for ours, theirs in zip(pipeline.femp.predict(_shifts(k)), reference.predict(_shifts(k))):
            np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-15)


def test_calibration_threshold_follows_an_explicit_femp_threshold(fake_vision) -> None:
    """With F-emp's threshold set to 1.0 px the 0.95 px frames label F-emp too."""
    pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=30,
                               femp={"n_hidden": 10, "update_threshold_px": 1.0})
    count = calibrate_pipeline(pipeline, FakeSim(), np.random.default_rng(0))
    assert count == len(_accepted(range(30), 1.0)) > len(_accepted(range(30), 0.94))


def test_calibration_needs_ten_labelled_samples(fake_vision) -> None:
    """Ten well-tracked frames are enough; nine are refused, with the counts in the message."""
    n_init = next(n for n in range(10, 100) if len(_accepted(range(n), 0.94)) == 10)
    assert len(_accepted(range(n_init - 1), 0.94)) == 9
    with pytest.raises(ValueError, match=rf"^calibration gave 9 camera-labelled samples out of "
                                         rf"n_init={n_init - 1}: the camera could not track"):
        calibrate_pipeline(SensingPipeline(FakeCamera(), FakeFiber(), n_init=n_init - 1),
                           FakeSim(), np.random.default_rng(0))
    pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=n_init, femp={"n_hidden": 5})
    assert calibrate_pipeline(pipeline, FakeSim(), np.random.default_rng(0)) == 10


def test_a_calibration_longer_than_its_delay_shows_a_progress_bar(fake_vision, monkeypatch,
                                                                  capsys) -> None:
    """The spiral calibration shows a tqdm bar on stderr once it has run longer than
    PROGRESS_DELAY_S (here 0 s, so at once); progress=False keeps it silent; the result is the
    same either way."""
    import soft_gym.papers.wang2023.calibration as calibration

    def calibrated(**kwargs) -> int:
        pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=30, femp={"n_hidden": 5})
        return calibrate_pipeline(pipeline, FakeSim(), np.random.default_rng(0), **kwargs)

    monkeypatch.setattr(calibration, "PROGRESS_DELAY_S", 0.0)
    count = calibrated()
    err = capsys.readouterr().err
    assert "wang2023 sensing calibration" in err
    assert calibrated(progress=False) == count and capsys.readouterr().err == ""


# ------------------------------------------------------------------ one step
def _calibrated(fake_vision, **options) -> SensingPipeline:
    pipeline = SensingPipeline(FakeCamera(), FakeFiber(), n_init=40, femp={"n_hidden": 15},
                               **options)
    calibrate_pipeline(pipeline, FakeSim(), np.random.default_rng(0))
    return pipeline


def _measurement(k: int) -> Measurement:
    return Measurement(time_s=0.0, readings={"image": k, "fbg": _shifts(k)},
                       depth_m={"image": "depth"})


@pytest.mark.parametrize("k", [52, 51, 55, 62])  # e_S 0.93, 0.95, 0.5, lost
def test_observe_predicts_tracks_updates_selectively_and_fuses(fake_vision, k: int) -> None:
    pipeline = _calibrated(fake_vision)
    twin = _calibrated(fake_vision)  # the same pipeline, stepped by hand below
    estimates = pipeline.observe(_measurement(k))
    femp_position, femp_quaternion = twin.femp.predict(_shifts(k))
    camera_position, camera_quaternion = _position(k), _quaternion(k)
    error = np.inf if _lost(k) else _error(k)
    np.testing.assert_allclose(estimates.femp[0], femp_position, rtol=1e-12)
    np.testing.assert_allclose(estimates.femp[1], femp_quaternion, rtol=1e-12)
    np.testing.assert_array_equal(estimates.camera[0], camera_position)
    np.testing.assert_array_equal(estimates.camera[1], camera_quaternion)
    fused = PoseFusion().fuse(camera_position, camera_quaternion, femp_position,
                              femp_quaternion, error, _lost(k))
    np.testing.assert_allclose(estimates.fused[0], fused[0], rtol=1e-12)
    np.testing.assert_allclose(estimates.fused[1], fused[1], rtol=1e-12)
    assert estimates.reprojection_error_px == error
    assert estimates.inliers == (0 if _lost(k) else 80) and estimates.lost == _lost(k)
    should_update = (not _lost(k)) and error < 0.94
    assert estimates.femp_updated == should_update
    assert pipeline.femp.updates == int(should_update)
    if should_update:
        assert twin.femp.update(_shifts(k), camera_position, camera_quaternion, error)
    np.testing.assert_allclose(pipeline.femp.elm.beta, twin.femp.elm.beta, rtol=1e-12)
    image, depth, prior = pipeline.vision.updates[-1]
    assert (image, depth, prior) == (k, "depth", None)


def test_observe_with_the_femp_prior_passes_femp_pose_to_the_tracker(fake_vision) -> None:
    pipeline = _calibrated(fake_vision, femp_prior=True)
    femp_position, femp_quaternion = pipeline.femp.predict(_shifts(52))
    pipeline.observe(_measurement(52))
    prior = pipeline.vision.updates[-1][2]
    expected = np.eye(4)
    expected[:3, :3] = Rotation.from_quat(femp_quaternion).as_matrix()
    expected[:3, 3] = femp_position
    np.testing.assert_allclose(prior, expected, rtol=1e-12, atol=1e-15)


def test_observe_before_calibration_is_refused() -> None:
    with pytest.raises(ValueError, match=r"^the sensing pipeline is not calibrated"):
        SensingPipeline(FakeCamera(), FakeFiber()).observe(_measurement(0))
