"""The compiled descriptor searches against independent references: a k-d tree pair search with
NumPy minima for the window, OpenCV's brute-force matcher for the whole map."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from soft_gym.papers.wang2023.descriptor_search import (UNSET, as_words, nearest_two,
                                                         nearest_two_in_window)


def _hamming_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bits that differ between every row of ``a`` and every row of ``b`` (n, m)."""
    return np.unpackbits(a[:, None, :] ^ b[None, :, :], axis=2).sum(axis=2).astype(np.int64)


def _reference_window(pixels, descriptors, projected, candidates, map_descriptors, radius):
    """Nearest, its index (lowest among equals) and second nearest within the radius, from the
    pairs a k-d tree finds."""
    n = len(pixels)
    best = np.full(n, UNSET, dtype=np.int64)
    best_index = np.full(n, UNSET, dtype=np.int64)
    second = np.full(n, UNSET, dtype=np.int64)
    pairs = cKDTree(pixels).sparse_distance_matrix(cKDTree(projected), radius,
                                                   output_type="ndarray")
    distances = _hamming_matrix(descriptors, map_descriptors)
    for q in range(n):
        near = candidates[pairs["j"][pairs["i"] == q]]
        if len(near) == 0:
            continue
        d = distances[q, near]
        best[q] = d.min()
        best_index[q] = near[d == d.min()].min()
        rest = d[near != best_index[q]]
        if len(rest):
            second[q] = rest.min()
    return best, best_index, second


def _scene(rng: np.random.Generator, n: int, m: int, bits_kept: int):
    """Features and map points on a 160 x 120 image; descriptors drawn from a few bases with
    few random bits, so that equal distances are common."""
    bases = rng.integers(0, 256, (4, 32), dtype=np.uint8)
    def draw(count):
        noise = rng.integers(0, 256, (count, 32), dtype=np.uint8)
        for _ in range(bits_kept):
            noise &= rng.integers(0, 256, (count, 32), dtype=np.uint8)
        return bases[rng.integers(0, 4, count)] ^ noise
    pixels = rng.uniform([0, 0], [160, 120], (n, 2))
    projected = rng.uniform([-6, -6], [166, 126], (m, 2))
    # some projections exactly on a feature, some on integer pixels (windows' edges exactly hit)
    projected[: m // 4] = np.round(projected[: m // 4])
    pixels[: n // 4] = np.round(pixels[: n // 4])
    if m and n:
        projected[-1] = pixels[0] + [3.0, 4.0]   # exactly 5 px away
    map_size = m + 7
    candidates = rng.permutation(map_size)[:m].astype(np.int64)
    return pixels, draw(n), projected, candidates, draw(map_size)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 60), m=st.integers(0, 200),
       radius=st.sampled_from([0.5, 3.0, 5.0, 6.0, 12.0, 40.0]), bits_kept=st.integers(1, 4))
def test_window_search_equals_the_k_d_tree_reference(seed, n, m, radius, bits_kept) -> None:
    pixels, descriptors, projected, candidates, map_descriptors = _scene(
        np.random.default_rng(seed), n, m, bits_kept)
    got = nearest_two_in_window(pixels, as_words(descriptors), projected, candidates,
                                as_words(map_descriptors), radius)
    if m == 0:
        assert all((a == UNSET).all() for a in got)
        return
    expected = _reference_window(pixels, descriptors, projected, candidates, map_descriptors,
                                 radius)
    for name, a, b in zip(("nearest", "index", "second"), got, expected):
        np.testing.assert_array_equal(a, b, err_msg=name)


def test_window_search_counts_a_point_exactly_on_the_radius() -> None:
    """``dx^2 + dy^2 <= r^2``: a projection exactly 5 px away is in a 5 px window, not in a
    4.999 px one."""
    descriptors = np.zeros((1, 32), dtype=np.uint8)
    map_descriptors = np.full((2, 32), 1, dtype=np.uint8)   # 32 bits away
    map_descriptors[1, :2] = 3                              # 34 bits away
    pixels = np.array([[20.0, 30.0]])
    projected = np.array([[23.0, 34.0], [20.0, 30.5]])
    best, index, second = nearest_two_in_window(pixels, as_words(descriptors), projected,
                                                np.array([0, 1]), as_words(map_descriptors), 5.0)
    assert (best[0], index[0], second[0]) == (32, 0, 34)
    best, index, second = nearest_two_in_window(pixels, as_words(descriptors), projected,
                                                np.array([0, 1]), as_words(map_descriptors),
                                                4.999)
    assert (best[0], index[0], second[0]) == (34, 1, UNSET)


@pytest.mark.parametrize("bits_kept", [1, 3, 5])
def test_whole_map_search_equals_opencv_knn_match(bits_kept: int) -> None:
    """The nearest (first of equals) and second nearest of OpenCV's ``knnMatch(k=2)``,
    on descriptors with many equal distances."""
    rng = np.random.default_rng(bits_kept)
    _, descriptors, _, _, map_descriptors = _scene(rng, 300, 500, bits_kept)
    best, index, second = nearest_two(as_words(descriptors), as_words(map_descriptors))
    matches = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(descriptors, map_descriptors, k=2)
    assert len(matches) == 300
    ties = 0
    for q, (first, runner_up) in enumerate(matches):
        assert (best[q], index[q], second[q]) == (first.distance, first.trainIdx,
                                                  runner_up.distance)
        ties += first.distance == runner_up.distance
    assert ties > 10   # the tie-breaking was exercised


def test_whole_map_search_with_one_map_point_has_no_second() -> None:
    descriptors = np.zeros((3, 32), dtype=np.uint8)
    best, index, second = nearest_two(as_words(descriptors), as_words(np.ones((1, 32),
                                                                               np.uint8)))
    assert best.tolist() == [32] * 3 and index.tolist() == [0] * 3
    assert second.tolist() == [UNSET] * 3
