"""Compiled sheet statistics of `exposure.scene_exposure`: which sampled pixels are sheet
and the median of each channel over them, in one pass (a tracking frame takes them of both
images; as numpy calls they cost ~0.2 ms per image with the caches cold)."""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, nogil=True, error_model="numpy")


@_jit
def sheet_statistics(sample, hsv, min_saturation, background_hue, hue_tolerance):
    """Sheet pixels of the (h, w, 3) uint8 BGR `sample` and its HSV_FULL `hsv`: saturation
    >= `min_saturation` and hue within `hue_tolerance` of `background_hue` on the 256-step
    circle. Returns ((h, w) bool sheet mask, their count, (3,) float64 lower median of
    b, g, r over them; zeros if none)."""
    height, width = sample.shape[0], sample.shape[1]
    sheet = np.zeros((height, width), dtype=np.bool_)
    counts = np.zeros((3, 256), dtype=np.int64)
    count = 0
    for v in range(height):
        for u in range(width):
            if hsv[v, u, 1] < min_saturation:
                continue
            d = abs(np.int64(hsv[v, u, 0]) - np.int64(background_hue)) % 256
            if min(d, 256 - d) > hue_tolerance:
                continue
            sheet[v, u] = True
            count += 1
            for k in range(3):
                counts[k, sample[v, u, k]] += 1
    medians = np.zeros(3)
    half = (count + 1) // 2
    for k in range(3):
        below = 0
        for level in range(256):
            below += counts[k, level]
            if below >= half:
                medians[k] = level
                break
    return sheet, count, medians
