"""Compiled sheet statistics of `exposure.scene_exposure`: which sampled pixels are sheet
and the median of each channel over them, in one pass (a tracking frame takes them of both
images; as numpy calls they cost ~0.2 ms per image with the caches cold), and the even-light
test of its shading.

`sheet_sample` takes the samples' HSV itself, by OpenCV's own integer arithmetic for 8-bit
BGR -> HSV_FULL (`_hsv`, with OpenCV's division tables `_SDIV` / `_HDIV`): equal to
`hue.to_hsv` for every one of the 2^24 colours (tests/test_shading.py checks them all), and
no strided copy and conversion call per image."""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, nogil=True, error_model="numpy")

_HSV_SHIFT = 12  # OpenCV's fixed point of its 8-bit HSV conversion
_LEVELS = np.arange(256, dtype=np.float64)
_SDIV = np.concatenate([[0], np.rint((255 << _HSV_SHIFT) / _LEVELS[1:])]).astype(np.int64)
_HDIV = np.concatenate([[0], np.rint((256 << _HSV_SHIFT) / (6.0 * _LEVELS[1:]))]).astype(np.int64)


@_jit
def _hsv(b, g, r):
    """(hue 0-255, saturation, value) of one 8-bit BGR colour, as OpenCV's COLOR_BGR2HSV_FULL."""
    value = max(b, g, r)
    diff = value - min(b, g, r)
    half = 1 << (_HSV_SHIFT - 1)
    saturation = (diff * _SDIV[value] + half) >> _HSV_SHIFT
    if value == r:
        hue = g - b
    elif value == g:
        hue = b - r + 2 * diff
    else:
        hue = r - g + 4 * diff
    hue = (hue * _HDIV[diff] + half) >> _HSV_SHIFT
    if hue < 0:
        hue += 256
    return min(hue, 255), saturation, value


@_jit
def hsv_image(image):
    """(H, W, 3) uint8 BGR -> HSV_FULL by `_hsv` (the test twin of `hue.to_hsv`)."""
    out = np.empty_like(image)
    for v in range(image.shape[0]):
        for u in range(image.shape[1]):
            h, s, x = _hsv(np.int64(image[v, u, 0]), np.int64(image[v, u, 1]), np.int64(image[v, u, 2]))
            out[v, u, 0], out[v, u, 1], out[v, u, 2] = h, s, x
    return out


@_jit
def sheet_sample(image, step, min_saturation, background_hue, hue_tolerance):
    """The sheet among every `step`-th pixel of the (H, W, 3) uint8 BGR `image` in each
    direction (the sample image[::step, ::step]): saturation >= `min_saturation` and hue
    within `hue_tolerance` of `background_hue` on the 256-step circle; the lower median of
    b, g, r over it (zeros if none); and for the shading: the samples' value (HSV), its
    median over the sheet (as `np.median`: the mean of the two middle ones; nan without
    sheet), the sheet's core (sheet samples whose 3 x 3 neighbours inside the
    sample are all sheet: `cv2.erode` by a 3 x 3 square) and the core's size.

    Returns (sheet mask, count, (3,) b, g, r lower medians, value, value median, core, core size).
    """
    height, width = (image.shape[0] + step - 1) // step, (image.shape[1] + step - 1) // step
    sheet = np.zeros((height, width), dtype=np.bool_)
    value = np.empty((height, width), dtype=np.uint8)
    counts = np.zeros((4, 256), dtype=np.int64)  # b, g, r, value over the sheet
    count = 0
    for v in range(height):
        for u in range(width):
            b = np.int64(image[v * step, u * step, 0])
            g = np.int64(image[v * step, u * step, 1])
            r = np.int64(image[v * step, u * step, 2])
            hue, saturation, level = _hsv(b, g, r)
            value[v, u] = level
            if saturation < min_saturation:
                continue
            d = abs(hue - np.int64(background_hue)) % 256
            if min(d, 256 - d) > hue_tolerance:
                continue
            sheet[v, u] = True
            count += 1
            counts[0, b] += 1
            counts[1, g] += 1
            counts[2, r] += 1
            counts[3, level] += 1
    medians = np.zeros(3)
    for k in range(3):
        medians[k] = _ranked(counts[k], (count + 1) // 2 - 1) if count else 0.0
    median = np.nan
    if count:
        median = (_ranked(counts[3], (count - 1) // 2) + _ranked(counts[3], count // 2)) / 2.0
    # the erosion by rows, then by columns (a 3 x 3 square is both): 4 reads a sample, not 9
    across = np.empty((height, width), dtype=np.bool_)
    for v in range(height):
        for u in range(width):
            across[v, u] = sheet[v, max(u - 1, 0)] & sheet[v, u] & sheet[v, min(u + 1, width - 1)]
    core = np.empty((height, width), dtype=np.bool_)
    size = 0
    for v in range(height):
        above, below = max(v - 1, 0), min(v + 1, height - 1)
        for u in range(width):
            inner = across[above, u] & across[v, u] & across[below, u]
            core[v, u] = inner
            size += inner
    return sheet, count, medians, value, median, core, size


@_jit
def _ranked(counts, rank):
    """The level of 0-based `rank` in a histogram of 256 levels."""
    below = 0
    for level in range(256):
        below += counts[level]
        if below > rank:
            return float(level)
    return 255.0


@_jit
def encoded_deviation(value, core, levels):
    """The encoded log-brightness of `exposure._shading` (`levels[value]` on the core, 128
    elsewhere) and the largest |median - 128| over the core of its 3 x 3 median
    (`cv2.medianBlur`, border replicated): the even-light test, compiled (as numpy and
    OpenCV calls it cost ~0.25 ms an image, every tracking frame)."""
    height, width = value.shape[0], value.shape[1]
    encoded = np.full((height, width), 128, dtype=np.uint8)
    for v in range(height):
        for u in range(width):
            if core[v, u]:
                encoded[v, u] = levels[value[v, u]]
    # the 3 x 3 median as the median of (largest low, median middle, smallest high) of its
    # three columns, each column sorted once a row (not 19 compare-exchanges a sample)
    low = np.empty(width, dtype=np.uint8)
    middle = np.empty(width, dtype=np.uint8)
    high = np.empty(width, dtype=np.uint8)
    deviation = 0
    for v in range(height):
        above, below = max(v - 1, 0), min(v + 1, height - 1)
        for u in range(width):
            a, b, c = encoded[above, u], encoded[v, u], encoded[below, u]
            a, b = min(a, b), max(a, b)
            b, c = min(b, c), max(b, c)
            a, b = min(a, b), max(a, b)
            low[u], middle[u], high[u] = a, b, c
        for u in range(width):
            if not core[v, u]:
                continue
            left, right = max(u - 1, 0), min(u + 1, width - 1)
            largest_low = max(low[left], low[u], low[right])
            smallest_high = min(high[left], high[u], high[right])
            median = _median3(_median3(middle[left], middle[u], middle[right]), largest_low, smallest_high)
            deviation = max(deviation, int(abs(np.int64(median) - 128)))
    return encoded, deviation


@_jit
def _median3(a, b, c):
    """The median of three values."""
    return max(min(a, b), min(max(a, b), c))
