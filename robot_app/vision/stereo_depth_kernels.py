"""Compiled plane sweep of the stereo depth check: right-image pixels moved onto the left
image through each of several planes, each plane scored by the zero-mean normalised
cross-correlation of the two images' colours."""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def edge_samples(right, box, step, min_gradient):
    """Pixels of `right` ((H, W, C) uint8) on a grid of `step` inside `box` (u0, v0, u1,
    v1, inclusive) whose horizontal gradient (central difference) in any channel is at
    least `min_gradient`: the pixels whose left-image counterpart moves visibly with the
    depth. Returns (N, 2) float64 (u, v) and (N, C) their values."""
    height, width, channels = right.shape
    u0, v0 = max(box[0], 1), max(box[1], 0)
    u1, v1 = min(box[2], width - 2), min(box[3], height - 1)
    rows = max((v1 - v0) // step + 1, 0)
    cols = max((u1 - u0) // step + 1, 0)
    pixels = np.empty((rows * cols, 2))
    values = np.empty((rows * cols, channels))
    k = 0
    for v in range(v0, v1 + 1, step):
        for u in range(u0, u1 + 1, step):
            edge = False
            for c in range(channels):
                edge = (
                    edge
                    or abs(np.float32(right[v, u + 1, c]) - np.float32(right[v, u - 1, c])) >= min_gradient
                )
            if edge:
                pixels[k, 0], pixels[k, 1] = u, v
                for c in range(channels):
                    values[k, c] = right[v, u, c]
                k += 1
    return pixels[:k].copy(), values[:k].copy()


@_jit
def sweep(planes, K_left, K_right, left_from_right, pixels, values, left, left_origin):
    """Zero-mean normalised cross-correlation of the right-image samples with the left image
    through each of several planes (the channels' centred sums pooled).

    A right-image pixel's ray meets the plane n·X = d at X = d / (n·r) r; X's left-image
    pixel is read (bilinear). Scaling a plane about the right camera's centre (d -> k d)
    keeps every right pixel where it is and moves the left ones with the disparity of
    the new depth, as the refinement's depth move does.

    Args:
        planes: (D, 4) unit normal n and distance d [m] of each plane, n·X = d in Σ_CR.
        K_left, K_right: (3, 3) camera matrices.
        left_from_right: (4, 4) Σ_CR -> Σ_CL.
        pixels, values: right-image samples (`edge_samples`).
        left: (H, W, C) uint8 crop of the left image.
        left_origin: (2,) int64 full-image (u, v) of the crop's pixel (0, 0).

    Returns:
        (D,) correlations (-1 to 1; -2 where fewer than 16 samples land in the left crop).
    """
    height, width, channels = left.shape
    n_planes = planes.shape[0]
    out = np.full(n_planes, -2.0)
    fx, fy, cx, cy = K_right[0, 0], K_right[1, 1], K_right[0, 2], K_right[1, 2]
    A = K_left @ np.ascontiguousarray(left_from_right[:3, :3])
    t = K_left @ np.ascontiguousarray(left_from_right[:3, 3])
    sums = np.zeros((n_planes, 1 + 5 * channels))  # count; per channel l, r, l², r², l·r
    for i in range(pixels.shape[0]):
        rx = (pixels[i, 0] - cx) / fx
        ry = (pixels[i, 1] - cy) / fy
        a0 = A[0, 0] * rx + A[0, 1] * ry + A[0, 2]
        a1 = A[1, 0] * rx + A[1, 1] * ry + A[1, 2]
        a2 = A[2, 0] * rx + A[2, 1] * ry + A[2, 2]
        for j in range(n_planes):
            along = planes[j, 0] * rx + planes[j, 1] * ry + planes[j, 2]
            if along <= 1e-9:
                continue
            s = planes[j, 3] / along  # depth of the plane along this ray [m]
            if s <= 0:
                continue
            w = s * a2 + t[2]
            if w <= 1e-6:
                continue
            u = (s * a0 + t[0]) / w - left_origin[0]
            v = (s * a1 + t[1]) / w - left_origin[1]
            if not (0.0 <= u < width - 1.0 and 0.0 <= v < height - 1.0):
                continue
            iu, iv = np.int64(u), np.int64(v)
            fu, fv = u - iu, v - iv
            sums[j, 0] += 1.0
            for c in range(channels):
                p00, p01 = np.float64(left[iv, iu, c]), np.float64(left[iv, iu + 1, c])
                p10, p11 = np.float64(left[iv + 1, iu, c]), np.float64(left[iv + 1, iu + 1, c])
                top = p00 + fu * (p01 - p00)
                low = p10 + fu * (p11 - p10)
                seen = top + fv * (low - top)
                r = values[i, c]
                sums[j, 1 + 5 * c] += seen
                sums[j, 2 + 5 * c] += r
                sums[j, 3 + 5 * c] += seen * seen
                sums[j, 4 + 5 * c] += r * r
                sums[j, 5 + 5 * c] += seen * r
    for j in range(n_planes):
        n = sums[j, 0]
        if n < 16:
            continue
        cov, var_l, var_r = 0.0, 0.0, 0.0
        for c in range(channels):
            ml, mr = sums[j, 1 + 5 * c] / n, sums[j, 2 + 5 * c] / n
            var_l += max(sums[j, 3 + 5 * c] / n - ml * ml, 0.0)
            var_r += max(sums[j, 4 + 5 * c] / n - mr * mr, 0.0)
            cov += sums[j, 5 + 5 * c] / n - ml * mr
        out[j] = cov / np.sqrt(var_l * var_r + 1e-9)
    return out


@_jit
def reached_box(pose, box, K_left, K_right, left_from_right, scale_low, scale_high, width, height):
    """(u0, v0, u1, v1) int64: the left-image box that the right-image `box` reaches
    through the plane of `pose` scaled by any factor in [scale_low, scale_high] about the
    right camera's centre (its corners at both ends), a pixel to spare, inside the image."""
    nx, ny, nz = pose[0, 2], pose[1, 2], pose[2, 2]
    d = nx * pose[0, 3] + ny * pose[1, 3] + nz * pose[2, 3]
    fx, fy, cx, cy = K_right[0, 0], K_right[1, 1], K_right[0, 2], K_right[1, 2]
    P = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    lo_u, lo_v, hi_u, hi_v = np.inf, np.inf, -np.inf, -np.inf
    for corner in range(4):
        u = box[0] if corner % 2 == 0 else box[2]
        v = box[1] if corner < 2 else box[3]
        rx, ry = (u - cx) / fx, (v - cy) / fy
        along = nx * rx + ny * ry + nz
        s0 = d / along if abs(along) > 1e-9 else 0.0
        if s0 <= 0:
            return np.array([0, 0, width - 1, height - 1], dtype=np.int64)
        for scale in (scale_low, scale_high):
            X, Y, Z = scale * s0 * rx, scale * s0 * ry, scale * s0
            w = P[2, 0] * X + P[2, 1] * Y + P[2, 2] * Z + P[2, 3]
            if w <= 1e-6:
                return np.array([0, 0, width - 1, height - 1], dtype=np.int64)
            pu = (P[0, 0] * X + P[0, 1] * Y + P[0, 2] * Z + P[0, 3]) / w
            pv = (P[1, 0] * X + P[1, 1] * Y + P[1, 2] * Z + P[1, 3]) / w
            lo_u, lo_v, hi_u, hi_v = min(lo_u, pu), min(lo_v, pv), max(hi_u, pu), max(hi_v, pv)
    out = np.empty(4, dtype=np.int64)
    out[0] = min(max(np.int64(np.floor(lo_u)) - 2, 0), width - 1)
    out[1] = min(max(np.int64(np.floor(lo_v)) - 2, 0), height - 1)
    out[2] = min(max(np.int64(np.floor(hi_u)) + 3, 0), width - 1)
    out[3] = min(max(np.int64(np.floor(hi_v)) + 3, 0), height - 1)
    return out


__all__ = ["edge_samples", "reached_box", "sweep"]
