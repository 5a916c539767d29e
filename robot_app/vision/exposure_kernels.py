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
    core = np.zeros((height, width), dtype=np.bool_)
    size = 0
    for v in range(height):
        for u in range(width):
            if not sheet[v, u]:
                continue
            inner = True
            for y in range(max(v - 1, 0), min(v + 2, height)):
                for x in range(max(u - 1, 0), min(u + 2, width)):
                    inner = inner and sheet[y, x]
            if inner:
                core[v, u] = True
                size += 1
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
    deviation = 0
    for v in range(height):
        above, below = max(v - 1, 0), min(v + 1, height - 1)
        for u in range(width):
            if not core[v, u]:
                continue
            left, right = max(u - 1, 0), min(u + 1, width - 1)
            median = _median9(
                encoded[above, left], encoded[above, u], encoded[above, right],
                encoded[v, left], encoded[v, u], encoded[v, right],
                encoded[below, left], encoded[below, u], encoded[below, right],
            )  # fmt: skip
            deviation = max(deviation, int(abs(np.int64(median) - 128)))
    return encoded, deviation


@_jit
def _median9(p0, p1, p2, p3, p4, p5, p6, p7, p8):
    """The median of nine values by the classic 19 compare-exchanges network."""
    p1, p2 = min(p1, p2), max(p1, p2)
    p4, p5 = min(p4, p5), max(p4, p5)
    p7, p8 = min(p7, p8), max(p7, p8)
    p0, p1 = min(p0, p1), max(p0, p1)
    p3, p4 = min(p3, p4), max(p3, p4)
    p6, p7 = min(p6, p7), max(p6, p7)
    p1, p2 = min(p1, p2), max(p1, p2)
    p4, p5 = min(p4, p5), max(p4, p5)
    p7, p8 = min(p7, p8), max(p7, p8)
    p0, p3 = min(p0, p3), max(p0, p3)
    p5, p8 = min(p5, p8), max(p5, p8)
    p4, p7 = min(p4, p7), max(p4, p7)
    p3, p6 = min(p3, p6), max(p3, p6)
    p1, p4 = min(p1, p4), max(p1, p4)
    p2, p5 = min(p2, p5), max(p2, p5)
    p4, p7 = min(p4, p7), max(p4, p7)
    p4, p2 = min(p4, p2), max(p4, p2)
    p6, p4 = min(p6, p4), max(p6, p4)
    p4, p2 = min(p4, p2), max(p4, p2)
    return p4
