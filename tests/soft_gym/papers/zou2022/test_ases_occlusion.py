"""ASES's occlusion check: an occluder hiding the arm's tip end makes the pair lost (zou2022
Section 4.4; ``soft_gym.papers.zou2022.stereo_shape.tip_occlusion``).

References: the simulator's true backbone points under rendered stereo frames of the zou2022 arm,
clean, dimmed and with a grey plate over the bottom 60 % of the pair's view; ASES with the check
turned off (``tip_occlusion_widths=inf``) on the same frames; drawn images of a tube in front of
a white backdrop whose pixels around the tip are known.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from soft_gym.robots.presets import get_preset
from soft_gym.papers.zou2022.shape_dnn import STEREO_INTRINSICS, true_shape_points
from soft_gym.papers.zou2022.stereo_shape import (ASESConfig, arm_mask, estimate_stereo_shape,
                                           tip_occlusion)
from soft_gym.sensors.faults import LowLight, MovingOccluder
from soft_gym.sensors.stereo import StereoCamera
from soft_gym.engines.pybullet.simulator import ArmSimulator

ZOU = get_preset("zou2022")
GREY = (0.45, 0.45, 0.5, 1.0)
"""A neutral plate (the default skin colour lies inside ASES's orange HSV range)."""
ALWAYS = {"mode": "full", "start_s": 0.0, "cover_s": 1e3, "period_s": 1e3 + 1.0, "jitter_s": 0.0}
"""A plate that stays in place for the whole test."""
BOTTOM = 2
"""``MovingOccluder``'s side index of a plate coming up from the bottom of the view."""
HIDDEN = "tip end is hidden by an occluder"
N_POSES = 6


def _camera(sim, faults=None, seed=0) -> StereoCamera:
    camera = StereoCamera(intrinsics=dict(STEREO_INTRINSICS), faults=faults)
    camera.reset(sim, np.random.default_rng(seed))
    return camera


def _bottom_plate_camera(sim, strength: float) -> StereoCamera:
    """A pair with a grey plate over the bottom ``strength`` of its view: the first seed whose
    plate comes up from below."""
    for seed in range(64):
        occluder = MovingOccluder(strength=strength, rgba=GREY, **ALWAYS)
        camera = _camera(sim, occluder, seed)
        if occluder.motion(sim.time_s)[1] == BOTTOM:
            return camera
    raise AssertionError("64 seeds gave no plate from the bottom")


def _ases(reading, config: ASESConfig = ASESConfig()):
    return estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                 reading["P_right"], config)


@pytest.fixture(scope="module")
def poses():
    """Per settled pose of the zou2022 arm: the true points and the clean, dim (50 % and 70 %
    less light) and bottom-plate (60 % of the view) stereo readings. Five random poses with at
    least 1 bar in every muscle (the tip low in the view, behind the plate) and, last, the arm
    at rest (its tip above the plate's edge)."""
    sim = ArmSimulator(ZOU)
    rng = np.random.default_rng(5)
    rows = []
    try:
        cameras = {"clean": _camera(sim), "dim": _camera(sim, LowLight(strength=0.5)),
                   "dark": _camera(sim, LowLight(strength=0.7)),
                   "plate": _bottom_plate_camera(sim, 0.6)}
        for k in range(N_POSES):
            pressures = 1e4 * rng.integers(10, 31, 3) if k < N_POSES - 1 else np.zeros(3)
            sim.set_pressures(pressures.astype(float))
            sim.step_physics(1.5)
            row = {name: camera.sample(sim) for name, camera in cameras.items()}
            row["truth"] = true_shape_points(ZOU, sim.backbone())
            rows.append(row)
    finally:
        sim.close()
    return rows


# ---------------------------------------------------------------------------------- rendered
def test_a_plate_hiding_the_tip_half_makes_the_pair_lost(poses):
    threshold = ASESConfig().tip_occlusion_widths
    errors = []
    for row in poses[:-1]:
        shape = _ases(row["plate"])
        assert shape.lost and HIDDEN in shape.reason, shape.reason
        assert np.all(np.isnan(shape.points_m))
        side = shape.reason.split(":")[0]
        assert shape.tip_occlusion[side] >= threshold
        # a cut across the arm: about one and a half arm widths of occluder edge
        assert shape.tip_occlusion[side] > 1.2
        # without the check the stub passes every other test and is taken for the whole arm
        unchecked = _ases(row["plate"], ASESConfig(tip_occlusion_widths=math.inf))
        assert not unchecked.lost, unchecked.reason
        assert unchecked.tip_occlusion == {}
        errors.append(np.linalg.norm(unchecked.points_m - row["truth"], axis=1).mean() * 1e3)
    assert np.mean(errors) > 20.0, errors


def test_a_plate_below_the_tip_leaves_the_pair_found(poses):
    rest = poses[-1]
    shape = _ases(rest["plate"])
    assert not shape.lost, shape.reason
    assert max(shape.tip_occlusion.values()) < 0.3
    np.testing.assert_allclose(shape.points_m, _ases(rest["clean"]).points_m, atol=1e-3)


@pytest.mark.parametrize("name", ["clean", "dim", "dark"])
def test_frames_without_an_occluder_are_not_lost(poses, name):
    errors = []
    for row in poses:
        shape = _ases(row[name])
        assert not shape.lost, shape.reason
        # the tip's surroundings are backdrop: far below the 0.75 arm widths that make it lost
        assert max(shape.tip_occlusion.values()) < 0.3, shape.tip_occlusion
        errors.append(np.linalg.norm(shape.points_m - row["truth"], axis=1).mean() * 1e3)
    # the extended poses (the short straight arm at rest is ASES's worst case: ~13 mm, its
    # depth rests on a pixel or two of disparity)
    assert np.mean(errors[:-1]) < 5.0, errors


# ---------------------------------------------------------------------------------- drawn
ORANGE = (230, 120, 40)
WHITE = (255, 255, 255)
GREY_PX = (105, 105, 118)


def _tube(bar_from_row: int | None = None, bar_colour=GREY_PX, gain: float = 1.0,
          extension=None) -> np.ndarray:
    """A 15 px wide orange tube from row 10 to row 100 (tip end) in a white 160 x 120 frame; an
    optional bar of ``bar_colour`` from ``bar_from_row`` down, an optional ``(colour, rows)``
    strip continuing the tube, and the whole frame scaled by ``gain`` (dim light)."""
    image = np.full((120, 160, 3), WHITE, np.uint8)
    image[10:101, 73:88] = ORANGE
    if extension is not None:
        colour, rows = extension
        image[101:101 + rows, 73:88] = colour
    if bar_from_row is not None:
        image[bar_from_row:] = bar_colour
    return np.clip(np.rint(image * gain), 0, 255).astype(np.uint8)


def _score(image: np.ndarray, config: ASESConfig = ASESConfig()) -> float:
    blurred = cv2.GaussianBlur(image, (config.blur_kernel_px, config.blur_kernel_px),
                               config.blur_sigma_px)
    hsv = cv2.cvtColor(blurred, cv2.COLOR_RGB2HSV)
    thresholded = cv2.inRange(hsv, np.array(config.hsv_low, np.uint8),
                              np.array(config.hsv_high, np.uint8))
    silhouette = arm_mask(image, config)
    rows, cols = np.nonzero(silhouette)
    top, bottom = rows.min(), rows.max()
    x = 0.5 * (cols.min() + cols.max())
    chain = np.c_[np.full(9, x), np.linspace(top, bottom, 9)]
    return tip_occlusion(blurred, thresholded, silhouette, chain, config)


def test_tip_occlusion_measures_the_occluder_edge_at_the_tip_in_arm_widths():
    assert _score(_tube()) == 0.0                              # a clean tip: backdrop all round
    cut = _score(_tube(bar_from_row=101))                      # a plate right below the tip end
    assert 1.0 < cut < 2.0                                     # the cut, plus the ring's corners
    # dim light scales the backdrop and the plate alike: the same verdict
    assert _score(_tube(gain=0.3)) == 0.0
    assert _score(_tube(bar_from_row=101, gain=0.3)) == pytest.approx(cut, abs=0.2)
    # a plate that the tip does not touch (8 px below it) is no occluder of the tip
    assert _score(_tube(bar_from_row=109)) == 0.0
    # a plate of the backdrop's colour cannot be seen (a limit of the test)
    assert _score(_tube(bar_from_row=101, bar_colour=(250, 250, 250))) == 0.0


def test_tip_occlusion_counts_washed_out_arm_but_not_dark_arm_colour():
    # glare washing out the tip: pale, neither arm nor backdrop
    washed = _score(_tube(extension=((255, 240, 170), 15)))
    assert washed >= ASESConfig().tip_occlusion_widths
    # the arm's colour too dark for the mask (V below hsv_low) but arm-coloured after the filter
    # at the mask's rim: a thin shaded rim does not count as an occluder
    assert _score(_tube(extension=((120, 60, 20), 2))) < 0.3


def test_the_occlusion_settings_are_validated_by_name():
    for name, value in (("occlusion_gap_px", 0), ("occlusion_gap_px", 2.5),
                        ("backdrop_tolerance", 0.0), ("backdrop_tolerance", math.nan),
                        ("tip_occlusion_widths", 0.0), ("tip_occlusion_widths", -math.inf),
                        ("tip_occlusion_widths", math.nan), ("tip_occlusion_widths", "1")):
        with pytest.raises(ValueError, match=name):
            ASESConfig(**{name: value})
    assert ASESConfig(tip_occlusion_widths=math.inf).tip_occlusion_widths == math.inf
    config = ASESConfig.from_options({"tip_occlusion_widths": 1.0, "backdrop_tolerance": 0.2})
    assert (config.tip_occlusion_widths, config.backdrop_tolerance) == (1.0, 0.2)
    assert config.describe()["occlusion_gap_px"] == 3
