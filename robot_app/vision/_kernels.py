"""Compiled inner loops of the fitness (eqs. 9-11): one gather and one table look-up per point.

The fitness of a pose is a sum over model points of a score that depends only on the row
of the point (its model hue, or "outside") and on the code of the image pixel it lands on
(its hue, "no hue", or "off the image"). `fitness.py` builds that score table once per
model; these kernels project the points with a 3x4 matrix per pose and camera and add up
the table entries. Each image is a flat code array with one extra element, the sentinel,
whose code scores 0 in every row: points off the image or behind the camera look it up,
so the projection loop has no branches and vectorises. Numba's `error_model="numpy"`
matters: python's model checks every division for zero and stops vectorisation.
Everything here is internal: callers go through `FitnessEvaluator`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def _pixel_indices(M, px, py, pz, width, height, out):
    """Nearest-pixel flat index of each point, or width*height (the sentinel)."""
    sentinel = width * height
    wf, hf = np.float32(width), np.float32(height)
    zero, half = np.float32(0.0), np.float32(0.5)
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in range(px.shape[0]):
        x, y, z = px[i], py[i], pz[i]
        w = m20 * x + m21 * y + m22 * z + m23
        inv = np.float32(1.0) / w
        u = (m00 * x + m01 * y + m02 * z + m03) * inv + half
        v = (m10 * x + m11 * y + m12 * z + m13) * inv + half
        ok = (w > zero) & (u >= zero) & (v >= zero) & (u < wf) & (v < hf)
        iu = np.int32(u if ok else zero)
        iv = np.int32(v if ok else zero)
        out[i] = iv * width + iu if ok else sentinel


@_jit
def _gather_sum(indices, row_offsets, table, codes):
    total = np.float32(0.0)
    for i in range(indices.shape[0]):
        total += table[row_offsets[i] + codes[indices[i]]]
    return total


@_jit
def _bilinear_sum(M, px, py, pz, row_offsets, table, codes, width, height):
    """Scores (not hues: hue has no linear interpolation on a circle) of the 4 neighbours."""
    total = 0.0
    for i in range(px.shape[0]):
        x, y, z = px[i], py[i], pz[i]
        w = M[2, 0] * x + M[2, 1] * y + M[2, 2] * z + M[2, 3]
        if w <= 0.0:
            continue
        u = (M[0, 0] * x + M[0, 1] * y + M[0, 2] * z + M[0, 3]) / w
        v = (M[1, 0] * x + M[1, 1] * y + M[1, 2] * z + M[1, 3]) / w
        if u < 0.0 or v < 0.0 or u >= width - 1 or v >= height - 1:
            continue
        iu, iv = int(u), int(v)
        fu, fv = u - iu, v - iv
        k, r = iv * width + iu, row_offsets[i]
        top = (1.0 - fu) * table[r + codes[k]] + fu * table[r + codes[k + 1]]
        bottom = (1.0 - fu) * table[r + codes[k + width]] + fu * table[r + codes[k + width + 1]]
        total += (1.0 - fv) * top + fv * bottom
    return total


@_jit
def score_poses(
    projections_left,
    projections_right,
    px,
    py,
    pz,
    row_offsets,
    table,
    codes_left,
    codes_right,
    width,
    height,
    bilinear,
):
    """Sum of the scores of all points in both images, for each pose.

    Args:
        projections_left, projections_right: (P, 3, 4) float32 matrices K [R | t] of Σ_M
            into each image.
        px, py, pz: (N,) float32 model point coordinates [m].
        row_offsets: (N,) int32 start of each point's row in the flat table.
        table: flat float32 score table, rows of `width*height`-independent codes.
        codes_left, codes_right: (H*W + 1,) uint16 pixel codes, row-major, then the sentinel.
        width, height: image size [px].
        bilinear: interpolate the scores of the four neighbouring pixels instead of taking
            the nearest one.

    Returns:
        (P,) left sum + right sum, unnormalised.
    """
    n_poses = projections_left.shape[0]
    out = np.empty(n_poses)
    indices = np.empty(px.shape[0], np.int32)
    for p in range(n_poses):
        if bilinear:
            out[p] = _bilinear_sum(
                projections_left[p], px, py, pz, row_offsets, table, codes_left, width, height
            ) + _bilinear_sum(
                projections_right[p], px, py, pz, row_offsets, table, codes_right, width, height
            )
            continue
        _pixel_indices(projections_left[p], px, py, pz, width, height, indices)
        total = _gather_sum(indices, row_offsets, table, codes_left)
        _pixel_indices(projections_right[p], px, py, pz, width, height, indices)
        out[p] = total + _gather_sum(indices, row_offsets, table, codes_right)
    return out


__all__ = ["score_poses"]
