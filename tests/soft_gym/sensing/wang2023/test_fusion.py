"""Eq. (18) fusion: limits, continuity, convexity, slerp."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from soft_gym.sensing.wang2023.fusion import PoseFusion, slerp
from soft_gym.sensing.wang2023.pipeline import SensingPipeline
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.fbg import FBGFiber

CAMERA = (np.array([0.01, 0.0, 0.09]), Rotation.from_euler("x", 10, degrees=True).as_quat())
FEMP = (np.array([0.012, 0.002, 0.088]), Rotation.from_euler("y", 20, degrees=True).as_quat())


def test_camera_below_lower_bound_femp_above_upper_bound_or_lost():
    fusion = PoseFusion(1.0, 2.0)
    position, quaternion = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=0.5)
    np.testing.assert_array_equal(position, CAMERA[0])
    np.testing.assert_allclose(quaternion, CAMERA[1], atol=1e-12)
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=3.0)
    np.testing.assert_array_equal(position, FEMP[0])
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=0.1, lost=True)
    np.testing.assert_array_equal(position, FEMP[0])
    position, _ = fusion.fuse(*CAMERA, *FEMP, reprojection_error_px=float("inf"))
    np.testing.assert_array_equal(position, FEMP[0])


def test_blend_is_convex_and_continuous_at_both_bounds():
    fusion = PoseFusion(1.0, 2.0)
    errors = np.linspace(0.9, 2.1, 241)
    positions = np.array([fusion.fuse(*CAMERA, *FEMP, e)[0] for e in errors])
    assert np.abs(np.diff(positions, axis=0)).max() < 1e-4  # no jumps
    mid, _ = fusion.fuse(*CAMERA, *FEMP, 1.5)
    np.testing.assert_allclose(mid, 0.5 * (CAMERA[0] + FEMP[0]))


def test_slerp_matches_scipy():
    rotations = Rotation.from_quat([CAMERA[1], FEMP[1]])
    reference = Slerp([0, 1], rotations)
    for fraction in (0.0, 0.25, 0.5, 0.9, 1.0):
        ours = Rotation.from_quat(slerp(CAMERA[1], FEMP[1], fraction))
        assert (ours.inv() * reference([fraction])[0]).magnitude() < 1e-9


@pytest.mark.parametrize("lower, upper, name", [(-1.0, 2.0, "lower_px"), (2.0, 1.0, "upper_px")])
def test_bad_bounds_raise(lower, upper, name):
    with pytest.raises(ValueError, match=name):
        PoseFusion(lower, upper)


@pytest.mark.parametrize("options, name", [
    ({"n_init": 5}, "n_init"),
    ({"map_steps": -1}, "map_steps"),
    ({"map_steps": 2.5}, "map_steps"),
    ({"femp_prior": 1}, "femp_prior"),
])
def test_bad_sensing_pipeline_options_raise(options, name):
    with pytest.raises(ValueError, match=name):
        SensingPipeline(EyeInHandCamera(), FBGFiber(), **options)
