"""Bad input to zou2022's shape estimators is refused with a ValueError naming the parameter:
ASES's frames and projection matrices, the DNN's and RSES's chamber lengths.

References: hand-made frames (a uint8 RGB pair of the right size) and a pair of parallel
pinhole projection matrices; the messages' parameter names.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.sensing.zou2022.cc_shape import cc_shape, cc_shape_points
from soft_gym.sensing.zou2022.shape_dnn import ShapeDNN
from soft_gym.sensing.zou2022.stereo_shape import estimate_stereo_shape, tip_occlusion

D = 0.010
"""Chamber distance from the axis (m), the zou2022 arm's."""
LENGTHS = np.array([0.10, 0.11, 0.12])
"""Three chamber lengths (m)."""


def _pair() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A white 180 x 320 pair and two parallel cameras 12 cm apart (world to pixels)."""
    image = np.full((180, 320, 3), 255, np.uint8)
    K = np.array([[228.5, 0.0, 160.0], [0.0, 228.5, 90.0], [0.0, 0.0, 1.0]])
    left = K @ np.hstack([np.eye(3), [[0.06], [0.0], [0.5]]])
    right = K @ np.hstack([np.eye(3), [[-0.06], [0.0], [0.5]]])
    return image, image.copy(), left, right


# ---------------------------------------------------------------------------------- ASES
@pytest.mark.parametrize("name, frame", [
    ("left", np.full((180, 320, 3), 1.0)),                         # float image
    ("left", np.full((180, 320, 3), 255, np.uint16)),              # 16-bit
    ("left", np.full((180, 320), 255, np.uint8)),                  # 2-D grey
    ("left", np.full((180, 320, 4), 255, np.uint8)),               # RGBA
    ("left", np.full((4, 320, 3), 255, np.uint8)),                 # too small
    ("left", "frame.png"),
])
def test_ases_refuses_frames_of_the_wrong_shape_or_dtype(name, frame):
    left, right, P_left, P_right = _pair()
    with pytest.raises(ValueError, match=rf"^{name} must be a uint8 RGB image"):
        estimate_stereo_shape(frame, right, P_left, P_right)
    with pytest.raises(ValueError, match=r"^right must be a uint8 RGB image"):
        estimate_stereo_shape(left, frame, P_left, P_right)


def test_ases_refuses_a_pair_of_different_sizes():
    left, _, P_left, P_right = _pair()
    with pytest.raises(ValueError, match=r"^right must have the left image's shape"):
        estimate_stereo_shape(left, np.full((240, 320, 3), 255, np.uint8), P_left, P_right)


@pytest.mark.parametrize("matrix, message", [
    (np.eye(3), "shape"),
    (np.ones(12), "shape"),
    (np.full((3, 4), np.nan), "finite"),
    (np.r_[np.eye(3, 4)[:2], [[0.0, 0.0, math.inf, 1.0]]], "finite"),
    (np.zeros((3, 4)), "invertible"),
    ([["a"] * 4] * 3, "numeric"),
    (np.eye(3, 4) * (1 + 1j), "real"),
])
def test_ases_refuses_bad_projection_matrices(matrix, message):
    left, right, P_left, P_right = _pair()
    with pytest.raises(ValueError, match=rf"^P_left must .*{message}"):
        estimate_stereo_shape(left, right, matrix, P_right)
    with pytest.raises(ValueError, match=rf"^P_right must .*{message}"):
        estimate_stereo_shape(left, right, P_left, matrix)


def test_ases_refuses_a_bad_base_or_config():
    left, right, P_left, P_right = _pair()
    with pytest.raises(ValueError, match=r"^base_m must"):
        estimate_stereo_shape(left, right, P_left, P_right, base_m=(0.0, math.nan, 0.0))
    with pytest.raises(ValueError, match=r"^base_m must"):
        estimate_stereo_shape(left, right, P_left, P_right, base_m=(0.0, 0.0))
    with pytest.raises(ValueError, match=r"^config must be an ASESConfig"):
        estimate_stereo_shape(left, right, P_left, P_right, {"seed": 0})
    # a valid pair without an arm is no error: it is lost
    shape = estimate_stereo_shape(left, right, P_left, P_right)
    assert shape.lost and "arm pixels" in shape.reason


def test_tip_occlusion_refuses_bad_images_and_chains():
    image = np.full((60, 80, 3), 255, np.uint8)
    mask = np.zeros((60, 80), np.uint8)
    chain = np.array([[40.0, 10.0], [40.0, 50.0]])
    assert tip_occlusion(image, mask, mask, chain) == 0.0
    with pytest.raises(ValueError, match=r"^blurred must be a uint8 RGB image"):
        tip_occlusion(image.astype(float), mask, mask, chain)
    with pytest.raises(ValueError, match=r"^thresholded must be a uint8 mask"):
        tip_occlusion(image, mask[:, :40], mask, chain)
    with pytest.raises(ValueError, match=r"^silhouette must be a uint8 mask"):
        tip_occlusion(image, mask, mask > 0, chain)
    with pytest.raises(ValueError, match=r"^chain_px must have shape"):
        tip_occlusion(image, mask, mask, chain[:1])
    with pytest.raises(ValueError, match=r"^chain_px must be finite"):
        tip_occlusion(image, mask, mask, np.full((3, 2), math.nan))


# ---------------------------------------------------------------------------------- DNN
@pytest.fixture(scope="module")
def dnn() -> ShapeDNN:
    """A Table 2 network fitted for one epoch on CC shapes (the checks do not depend on the
    weights)."""
    rng = np.random.default_rng(0)
    lengths = LENGTHS * rng.uniform(0.8, 1.2, (24, 3))
    model = ShapeDNN(3)
    index = np.arange(len(lengths))
    model.fit(lengths, cc_shape_points(lengths, D), index, index, epochs=1, progress=False)
    return model


@pytest.mark.parametrize("lengths, message", [
    ([math.nan, 0.1, 0.1], "finite chamber lengths > 0"),
    ([0.1, math.inf, 0.1], "finite chamber lengths > 0"),
    ([[0.1, 0.1, 0.1], [0.1, 0.1, -math.inf]], "finite chamber lengths > 0"),
    ([0.1, 0.0, 0.1], "finite chamber lengths > 0"),
    ([0.1, -0.1, 0.1], "finite chamber lengths > 0"),
    ([0.1, 0.1], "shape"),
    ([[[0.1, 0.1, 0.1]]], "shape"),
    (0.1, "shape"),
    (["a", "b", "c"], "numbers"),
    ([0.1 + 1j, 0.1, 0.1], "real"),
    (None, "real"),
])
def test_dnn_refuses_bad_chamber_lengths(dnn, lengths, message):
    with pytest.raises(ValueError, match=rf"^lengths_m must .*{message}"):
        dnn.predict(lengths)


def test_dnn_names_the_bad_entry(dnn):
    with pytest.raises(ValueError, match=r"got nan at index \(1, 2\)"):
        dnn.predict([[0.1, 0.1, 0.1], [0.1, 0.1, math.nan]])
    assert dnn.predict(LENGTHS).shape == (7, 3)
    assert dnn.predict(np.stack([LENGTHS, LENGTHS])).shape == (2, 7, 3)


# ---------------------------------------------------------------------------------- RSES
@pytest.mark.parametrize("lengths, message", [
    ([math.nan, 0.1, 0.1], "finite chamber lengths > 0"),
    ([0.1, 0.1, math.inf], "finite chamber lengths > 0"),
    ([0.1, 0.0, 0.1], "finite chamber lengths > 0"),
    ([0.1, 0.1], "shape"),
    (0.1, "shape"),
    ("lengths", "numbers"),
    ([0.1j, 0.1, 0.1], "real"),
    (None, "real"),
])
def test_rses_refuses_bad_chamber_lengths(lengths, message):
    with pytest.raises(ValueError, match=rf"^lengths_m must .*{message}"):
        cc_shape_points(lengths, D)
    with pytest.raises(ValueError, match=rf"^lengths_m must .*{message}"):
        cc_shape(lengths, D)


@pytest.mark.parametrize("d, message", [
    (math.nan, "finite distances > 0"),
    (0.0, "finite distances > 0"),
    (-D, "finite distances > 0"),
    ([D, D], "one per segment"),
    ("d", "numbers"),
    (None, "real"),
])
def test_rses_refuses_a_bad_chamber_distance(d, message):
    with pytest.raises(ValueError, match=rf"^d_m must .*{message}"):
        cc_shape_points(LENGTHS, d)


def test_rses_names_the_bad_entry_and_accepts_batches():
    batch = np.stack([LENGTHS, LENGTHS])
    batch[1, 2] = math.nan
    with pytest.raises(ValueError, match=r"got nan at index \(1, 2\)"):
        cc_shape_points(batch, D)
    assert cc_shape_points(np.stack([LENGTHS, LENGTHS]), D).shape == (2, 7, 3)
    two_segments = np.r_[LENGTHS, LENGTHS]
    assert cc_shape_points(two_segments, [D, D]).shape == (7, 3)
