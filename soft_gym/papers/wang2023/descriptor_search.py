"""The vision tracker's descriptor searches, compiled (numba): the nearest and second-nearest
ORB descriptor of each feature among map points projected near it, and among all map points.

Both return, per feature, the Hamming distance (bits of 256) of its nearest map descriptor, that
map point's index and the distance of the nearest among the rest; ``UNSET`` where there is none.
Ties go to the lowest map index.
:class:`~soft_gym.papers.wang2023.vision_pose.VisionPoseEstimator` turns these into matches with
Lowe's ratio test (docs/architecture.md, "Vision pose").

They replace, with the same results bit for bit, a k-d tree pair search with NumPy scatter-minima
(the search by projection) and OpenCV's ``BFMatcher.knnMatch`` with ``k=2`` (the whole local
map): ``tests/soft_gym/papers/wang2023/test_descriptor_search.py`` checks them against both.
Each feature is one pass over the map points of the grid cells its window touches, with no arrays
of pairs between. Over a random-action run's 592 searches by projection a search took 0.7-0.8 ms
instead of 2.6-3.1 ms (three runs; the compiled part of a 6 px one 0.4 ms), and the whole local
map (~4,800 map points) 5 ms instead of 23 ms.
"""

from __future__ import annotations

import numba
import numpy as np

UNSET = np.iinfo(np.int64).max
"""Distance and index where a feature has no (second) nearest map point."""

_M1, _M2, _M4 = 0x5555555555555555, 0x3333333333333333, 0x0F0F0F0F0F0F0F0F
_H01 = 0x0101010101010101


@numba.njit(cache=True, nogil=True, inline="always")
def _bits(x: np.uint64) -> int:
    """Set bits of a 64-bit word (the SWAR population count: one POPCNT where the CPU has it)."""
    x = x - ((x >> np.uint64(1)) & np.uint64(_M1))
    x = (x & np.uint64(_M2)) + ((x >> np.uint64(2)) & np.uint64(_M2))
    x = (x + (x >> np.uint64(4))) & np.uint64(_M4)
    return np.int64((x * np.uint64(_H01)) >> np.uint64(56))


@numba.njit(cache=True, nogil=True, inline="always")
def _distance(w0: np.uint64, w1: np.uint64, w2: np.uint64, w3: np.uint64, table: np.ndarray,
              row: int) -> int:
    """Bits that differ between a descriptor (four 64-bit words) and ``table[row]``."""
    return (_bits(w0 ^ table[row, 0]) + _bits(w1 ^ table[row, 1])
            + _bits(w2 ^ table[row, 2]) + _bits(w3 ^ table[row, 3]))


@numba.njit(cache=True, nogil=True)
def nearest_two_in_window(pixels: np.ndarray, words: np.ndarray, projected: np.ndarray,
                          candidates: np.ndarray, map_words: np.ndarray,
                          radius_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per feature, the nearest and second-nearest descriptor among the map points projected
    within ``radius_px`` of it (ORB-SLAM2's search by projection).

    :param pixels: the features' pixels (n, 2), px.
    :param words: the features' descriptors as 64-bit words (n, 4).
    :param projected: the candidate map points' projections (m, 2), px.
    :param candidates: each projection's map index (m,).
    :param map_words: every map point's descriptor as 64-bit words (M, 4).
    :param radius_px: the window's radius (px); a point at ``dx^2 + dy^2 <= radius_px^2``
        is in it.
    :return: (nearest distance, its map index, second-nearest distance), each (n,) int64.
    """
    n, m = pixels.shape[0], projected.shape[0]
    best = np.full(n, UNSET, dtype=np.int64)
    best_index = np.full(n, UNSET, dtype=np.int64)
    second = np.full(n, UNSET, dtype=np.int64)
    if m == 0 or n == 0:
        return best, best_index, second
    # the projections sorted into square cells of half the radius, row by row (a counting
    # sort), with their map indices and descriptors beside them: a feature's window is then a
    # few runs of consecutive entries
    x_low, x_high = projected[:, 0].min(), projected[:, 0].max()
    y_low, y_high = projected[:, 1].min(), projected[:, 1].max()
    cell = max(0.5 * radius_px, 1.0)
    columns = int((x_high - x_low) / cell) + 1
    rows = int((y_high - y_low) / cell) + 1
    cell_of = np.empty(m, dtype=np.int64)
    starts = np.zeros(columns * rows + 1, dtype=np.int64)
    for j in range(m):
        column = min(int((projected[j, 0] - x_low) / cell), columns - 1)
        row = min(int((projected[j, 1] - y_low) / cell), rows - 1)
        cell_of[j] = row * columns + column
        starts[cell_of[j] + 1] += 1
    for k in range(columns * rows):
        starts[k + 1] += starts[k]
    filled = starts[:-1].copy()
    sorted_x, sorted_y = np.empty(m), np.empty(m)
    sorted_index = np.empty(m, dtype=np.int64)
    sorted_words = np.empty((m, 4), dtype=np.uint64)
    for j in range(m):
        slot = filled[cell_of[j]]
        filled[cell_of[j]] += 1
        sorted_x[slot], sorted_y[slot] = projected[j, 0], projected[j, 1]
        sorted_index[slot] = candidates[j]
        sorted_words[slot] = map_words[candidates[j]]
    radius2 = radius_px * radius_px
    # a margin on the cells scanned, so that rounding never drops a point on the window's edge
    reach = radius_px * (1.0 + 1e-9) + 1e-9
    for q in range(n):
        x, y = pixels[q, 0], pixels[q, 1]
        w0, w1, w2, w3 = words[q, 0], words[q, 1], words[q, 2], words[q, 3]
        first_column = max(int(np.floor((x - reach - x_low) / cell)), 0)
        last_column = min(int(np.floor((x + reach - x_low) / cell)), columns - 1)
        first_row = max(int(np.floor((y - reach - y_low) / cell)), 0)
        last_row = min(int(np.floor((y + reach - y_low) / cell)), rows - 1)
        if first_column > last_column:
            continue
        b, b_index, s = UNSET, UNSET, UNSET
        for row in range(first_row, last_row + 1):
            for slot in range(starts[row * columns + first_column],
                              starts[row * columns + last_column + 1]):
                dx = x - sorted_x[slot]
                dy = y - sorted_y[slot]
                if dx * dx + dy * dy <= radius2:
                    distance = _distance(w0, w1, w2, w3, sorted_words, slot)
                    index = sorted_index[slot]
                    # ties go to the lowest map index; a displaced nearest becomes the second
                    if distance < b or (distance == b and index < b_index):
                        b, b_index, s = distance, index, b
                    elif distance < s:
                        s = distance
        best[q], best_index[q], second[q] = b, b_index, s
    return best, best_index, second


@numba.njit(cache=True, nogil=True)
def nearest_two(words: np.ndarray, map_words: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per feature, the nearest and second-nearest descriptor among all map points (brute force,
    as OpenCV's ``BFMatcher(NORM_HAMMING).knnMatch(k=2)``: the second nearest may be as near as
    the nearest).

    :param words: the features' descriptors as 64-bit words (n, 4).
    :param map_words: the map points' descriptors as 64-bit words (M, 4).
    :return: (nearest distance, its map index, second-nearest distance), each (n,) int64.
    """
    n, m = words.shape[0], map_words.shape[0]
    best = np.full(n, UNSET, dtype=np.int64)
    best_index = np.full(n, UNSET, dtype=np.int64)
    second = np.full(n, UNSET, dtype=np.int64)
    for q in range(n):
        b, b_index, s = UNSET, UNSET, UNSET
        w0, w1, w2, w3 = words[q, 0], words[q, 1], words[q, 2], words[q, 3]
        for j in range(m):
            distance = _distance(w0, w1, w2, w3, map_words, j)
            if distance < b:
                b, b_index, s = distance, j, b
            elif distance < s:
                s = distance
        best[q], best_index[q], second[q] = b, b_index, s
    return best, best_index, second


def as_words(descriptors: np.ndarray) -> np.ndarray:
    """32-byte ORB descriptors (n, 32) uint8 as four 64-bit words each (n, 4), C-contiguous."""
    return np.ascontiguousarray(descriptors).view(np.uint64)
