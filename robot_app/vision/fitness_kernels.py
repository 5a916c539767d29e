"""Compiled inner loops of the hue fitness (eqs. 9-11): pixel codes, then one gather and one
table look-up per model point.

The fitness of a pose is a sum over model points of a score that depends only on the row
of the point (its model colour, a hue or a tone, or "outside") and on the code of the
image pixel it lands on (its hue, its tone, or "off the image"). `fitness.py` builds that
score table once per model, beside each score a "seen" flag (does the point count towards
the divisor of the fitness); these kernels project the points with a 3x4 matrix per pose
and camera and add up the table entries. Each image is a flat code array framed by pixels
whose code scores 0 in every row: points off the image or behind the camera are clamped
onto the frame, so the projection loop has no data-dependent branches. Numba's
`error_model="numpy"` matters: python's model checks every division for zero and stops
vectorisation. So do unsigned indices in the gathers: numba wraps a negative signed index
around, a test and an add per access that also spill registers (the nearest-pixel sum went
from 2.5 to 1.7 ns per point, the bilinear one from 7.3 to 4.5 ns, on one core of this
machine). Callers go through `FitnessEvaluator` / `KernelFitness`; the GA's and the
refinement's compiled loops call `fitness_of`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def hsv_codes(hsv, min_saturation, min_value, value_split, dark, light, fill):
    """(H, W, 3) HSV_FULL image -> flat pixel codes, framed by `fill` (one pixel left and
    top, two right and bottom; row stride width + 3), as the scoring kernels read them.
    A code is the hue, or where saturation < min_saturation or value < min_value the tone:
    `dark` for value < value_split, else `light` (`hue.colour_codes`, pixel by pixel)."""
    height, width = hsv.shape[0], hsv.shape[1]
    stride = width + 3
    out = np.full((height + 3) * stride, fill, dtype=np.uint16)
    for v in range(height):
        base = (v + 1) * stride + 1
        for u in range(width):
            value = hsv[v, u, 2]
            if hsv[v, u, 1] >= min_saturation and value >= min_value:
                out[base + u] = np.uint16(hsv[v, u, 0])
            else:
                out[base + u] = np.uint16(dark) if value < value_split else np.uint16(light)
    return out


@_jit
def every_colour():
    """(4096, 4096, 3) uint8 BGR image holding each of the 2^24 colours once, colour
    (b, g, r) at flat pixel index b << 16 | g << 8 | r."""
    out = np.empty((4096, 4096, 3), dtype=np.uint8)
    for i in range(1 << 24):
        y, x = i >> 12, i & 4095
        out[y, x, 0] = (i >> 16) & 255
        out[y, x, 1] = (i >> 8) & 255
        out[y, x, 2] = i & 255
    return out


@_jit
def bgr_codes(bgr, table, fill, levels, spans):
    """(H, W, 3) BGR image -> flat pixel codes framed like `hsv_codes`'s, each pixel looked
    up in `table` ((2^24,) code of every colour, index b << 16 | g << 8 | r): one gather per
    pixel instead of an HSV conversion and a pass over it (0.27 against 0.78 ms per
    640 x 480 image; an image's colours are few, so the table's lines stay in cache).
    Each channel value first goes through its row of `levels` ((3, 256) uint8, b, g, r):
    the exposure gains of `exposure.py` as look-up tables (`gain_levels`), which map the
    scene's exposure and white balance onto the model photo's; identity rows change
    nothing. Only pixels inside `spans` ((H, 2) int64: row v from u = spans[v, 0] to
    spans[v, 1] inclusive, clipped to the image; empty where the end is below the start;
    `pixel_codes.box_spans` of a box) get their code, the others `fill` as the frame (a
    tracking frame needs only the region its window can reach)."""
    height, width = bgr.shape[0], bgr.shape[1]
    stride = width + 3
    out = np.full((height + 3) * stride, fill, dtype=np.uint16)
    for v in range(height):
        base = (v + 1) * stride + 1
        for u in range(max(spans[v, 0], 0), min(spans[v, 1], width - 1) + 1):
            b = np.int64(levels[0, bgr[v, u, 0]])
            g = np.int64(levels[1, bgr[v, u, 1]])
            r = np.int64(levels[2, bgr[v, u, 2]])
            out[base + u] = table[(b << 16) | (g << 8) | r]
    return out


@_jit
def bgr_codes_shaded(bgr, table, fill, levels, index, block, spans):
    """`bgr_codes` under uneven light: the channel rows are those of the pixel's block,
    `levels[index[v // block, u // block]]` ((L, 3, 256) uint8: the gains times each shading
    level's factor, `shaded_levels`); blocks past `index`'s last row or column take it."""
    height, width = bgr.shape[0], bgr.shape[1]
    stride = width + 3
    out = np.full((height + 3) * stride, fill, dtype=np.uint16)
    rows, cols = index.shape[0], index.shape[1]
    for v in range(height):
        base = (v + 1) * stride + 1
        i = min(v // block, rows - 1)
        start, u1 = max(spans[v, 0], 0), min(spans[v, 1], width - 1)
        while start <= u1:
            j = min(start // block, cols - 1)
            stop = u1 + 1 if j == cols - 1 else min((j + 1) * block, u1 + 1)
            level = levels[index[i, j]]
            for u in range(start, stop):
                b = np.int64(level[0, bgr[v, u, 0]])
                g = np.int64(level[1, bgr[v, u, 1]])
                r = np.int64(level[2, bgr[v, u, 2]])
                out[base + u] = table[(b << 16) | (g << 8) | r]
            start = stop
    return out


def shaded_levels(gains, factors):
    """(L, 3, 256) uint8: `gain_levels` of the gains times each of the (L,) factors."""
    values = np.arange(256, dtype=np.float64)
    scaled = (
        values[None, None, :]
        * np.asarray(gains, float)[None, :, None]
        * np.asarray(factors, float)[:, None, None]
    )
    return np.minimum(np.floor(scaled + 0.5), 255.0).astype(np.uint8)


def gain_levels(gains):
    """(3, 256) uint8: each channel value v of b, g, r times its gain, rounded and clipped
    to 255 (the rows `bgr_codes` reads)."""
    values = np.arange(256, dtype=np.float64)
    out = np.empty((3, 256), dtype=np.uint8)
    for k in range(3):
        out[k] = np.minimum(np.floor(values * float(gains[k]) + 0.5), 255.0).astype(np.uint8)
    return out


@_jit
def _nearest_sum(M, points, table, codes, width, height, pixel):
    """Sum of the scores of all points in one image at their nearest pixels, branch-free,
    and the sum of `best` over the points that count as seen (the most they could score).

    `table` holds (score, seen) pairs: entry 2 (row offset + code) is the score, the next
    one 1 if the point counts as seen on that pixel, else 0. Pixel j of a row is padded
    column j + 1. A point's coordinate is clamped into the padded frame, so every point
    off the image (or behind the camera) reads frame pixels, whose code scores 0 and is
    not seen, and the loop has no data-dependent branch.
    """
    px, py, pz, weights, best, row_offsets = points
    stride = width + 3
    zero, one, eps, shift = np.float32(0.0), np.float32(1.0), np.float32(1e-6), np.float32(1.5)
    umax, vmax = np.float32(width + 1), np.float32(height + 1)
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in range(px.shape[0]):  # projection first: this loop vectorises
        x, y, z = px[i], py[i], pz[i]
        w = m20 * x + m21 * y + m22 * z + m23
        front = w > eps
        inv = one / (w if front else one)
        u = (m00 * x + m01 * y + m02 * z + m03) * inv + shift
        v = (m10 * x + m11 * y + m12 * z + m13) * inv + shift
        u = min(max(u if front else zero, zero), umax)  # floor(u + 0.5) + 1 below
        v = min(max(v if front else zero, zero), vmax)
        pixel[i] = np.uint32(np.int32(v) * stride + np.int32(u))
    total = np.float32(0.0)
    view = np.float32(0.0)
    two = np.uint64(2)
    for i in range(px.shape[0]):  # then the gathers, by unsigned indices (see the module)
        k = np.uint64(row_offsets[i]) + two * np.uint64(codes[np.uint64(pixel[i])])
        total += weights[i] * table[k]
        view += best[i] * table[k + np.uint64(1)]
    return total, view


@_jit
def _bilinear_sum(M, points, table, codes, width, height, pixel, fraction):
    """Like `_nearest_sum`, with each score (and "seen") interpolated between the four
    neighbouring pixels (scores, not hues: hue has no linear interpolation on a circle).
    `fraction` is (2, N) float32 scratch for the sub-pixel offsets."""
    px, py, pz, weights, best, row_offsets = points
    stride = width + 3
    zero, one, eps = np.float32(0.0), np.float32(1.0), np.float32(1e-6)
    umax, vmax = np.float32(width + 1), np.float32(height + 1)
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in range(px.shape[0]):  # projection first: this loop vectorises
        x, y, z = px[i], py[i], pz[i]
        w = m20 * x + m21 * y + m22 * z + m23
        front = w > eps
        inv = one / (w if front else one)
        u = (m00 * x + m01 * y + m02 * z + m03) * inv + one
        v = (m10 * x + m11 * y + m12 * z + m13) * inv + one
        u = min(max(u if front else zero, zero), umax)
        v = min(max(v if front else zero, zero), vmax)
        iu, iv = np.int32(u), np.int32(v)
        fraction[0, i] = u - np.float32(iu)
        fraction[1, i] = v - np.float32(iv)
        pixel[i] = np.uint32(iv * stride + iu)
    total = np.float32(0.0)
    view = np.float32(0.0)
    one_, two, below = np.uint64(1), np.uint64(2), np.uint64(stride)
    for i in range(px.shape[0]):  # then the gathers, by unsigned indices (see the module)
        k, r = np.uint64(pixel[i]), np.uint64(row_offsets[i])
        fu, fv = fraction[0, i], fraction[1, i]
        ka, kb = r + two * np.uint64(codes[k]), r + two * np.uint64(codes[k + one_])
        kc, kd = r + two * np.uint64(codes[k + below]), r + two * np.uint64(codes[k + below + one_])
        a, b, c, d = table[ka], table[kb], table[kc], table[kd]
        top = a + fu * (b - a)
        total += weights[i] * (top + fv * (c + fu * (d - c) - top))
        a, b, c, d = table[ka + one_], table[kb + one_], table[kc + one_], table[kd + one_]
        top = a + fu * (b - a)
        view += best[i] * (top + fv * (c + fu * (d - c) - top))
    return total, view


@_jit
def _projection(P, pose, out):
    """out (3, 4) float32 = P @ pose, P a (3, 4) camera projection, pose a float64 (4, 4)
    rigid transform (its last row 0 0 0 1). Written out: `@` in a compiled loop is a BLAS
    call and an allocation per pose, about 0.3 µs, a third of a GA generation's cost on
    a one-point model."""
    for r in range(3):
        for c in range(3):
            out[r, c] = P[r, 0] * pose[0, c] + P[r, 1] * pose[1, c] + P[r, 2] * pose[2, c]
        out[r, 3] = P[r, 0] * pose[0, 3] + P[r, 1] * pose[1, 3] + P[r, 2] * pose[2, 3] + P[r, 3]


@_jit
def score_poses(
    transforms,
    K_left,
    K_right,
    left_from_right,
    px,
    py,
    pz,
    weights,
    best,
    row_offsets,
    table,
    codes_left,
    codes_right,
    width,
    height,
    bilinear,
):
    """Sum of the scores of all points in both images, for each pose, and the most the
    points in view could have scored.

    Args:
        transforms: (P, 4, 4) float64 poses ^CR T_M.
        K_left, K_right: (3, 3) camera matrices.
        left_from_right: (4, 4) transform Σ_CR -> Σ_CL.
        px, py, pz: (N,) float32 model point coordinates [m].
        weights: (N,) float32 weight of each point's score.
        best: (N,) float32 weight x the highest score of each point's row.
        row_offsets: (N,) uint32 start of each point's row in the flat table.
        table: flat float32 table of (score, seen) pairs, row by row (see `_nearest_sum`).
        codes_left, codes_right: pixel codes as made by `hsv_codes` (the frame's code
            scores 0 and is not seen in every row).
        width, height: image size [px].
        bilinear: interpolate the scores of the four neighbouring pixels instead of taking
            the nearest one.

    Returns:
        (P,) left sum + right sum, unnormalised; (P,) the sum of `best` over the points
        seen in each image, left + right.
    """
    n_poses = transforms.shape[0]
    out = np.empty(n_poses)
    view = np.empty(n_poses)
    M_left = np.empty((3, 4), np.float32)
    M_right = np.empty((3, 4), np.float32)
    pixel = np.empty(px.shape[0], np.uint32)  # scratch: each point's pixel index
    fraction = np.empty((2, px.shape[0]), np.float32)  # scratch: sub-pixel offsets
    points = (px, py, pz, weights, best, row_offsets)
    P_right = np.zeros((3, 4))
    P_right[:, :3] = K_right
    P_left = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    for p in range(n_poses):
        pose = transforms[p]
        _projection(P_right, pose, M_right)
        _projection(P_left, pose, M_left)
        if bilinear:
            sum_l, view_l = _bilinear_sum(M_left, points, table, codes_left, width, height, pixel, fraction)
            sum_r, view_r = _bilinear_sum(M_right, points, table, codes_right, width, height, pixel, fraction)
        else:
            sum_l, view_l = _nearest_sum(M_left, points, table, codes_left, width, height, pixel)
            sum_r, view_r = _nearest_sum(M_right, points, table, codes_right, width, height, pixel)
        out[p] = sum_l + sum_r
        view[p] = view_l + view_r
    return out, view


@_jit
def normalised(sums, seen, full, view, min_view_fraction, hidden_penalty):
    """Fitness from `score_poses`' sums: divided by `full` (the paper's "model" normalisation)
    or, with `view`, by what the points in view could score (at least `min_view_fraction`
    of `full`), minus `hidden_penalty` times the share of `full` not seen."""
    out = np.empty(sums.shape[0])
    floor = min_view_fraction * full
    for p in range(sums.shape[0]):
        if not view:
            out[p] = sums[p] / full
            continue
        out[p] = sums[p] / max(seen[p], floor)
        if hidden_penalty != 0.0:
            out[p] -= hidden_penalty * min(max(1.0 - seen[p] / full, 0.0), 1.0)
    return out


@_jit
def fitness_of(poses, fitness_arguments, normalisation, bilinear):
    """`score_poses` + `normalised`: the normalised fitness of (P, 4, 4) poses."""
    K_left, K_right, left_from_right, px, py, pz, weights, best, rows, table, codes_l, codes_r, w, h = (
        fitness_arguments
    )
    sums, seen = score_poses(poses, K_left, K_right, left_from_right, px, py, pz, weights, best, rows,
                             table, codes_l, codes_r, w, h, bilinear)  # fmt: skip
    full, view, min_view_fraction, hidden_penalty = normalisation
    return normalised(sums, seen, full, view, min_view_fraction, hidden_penalty)


__all__ = ["bgr_codes", "every_colour", "fitness_of", "gain_levels", "hsv_codes", "normalised", "score_poses"]
