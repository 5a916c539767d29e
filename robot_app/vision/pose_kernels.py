"""Compiled pose helpers shared by the search stages: genes to poses, poses to parameters,
moves about the model origin, and the allowed set (bounds, avoided peaks)."""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def transforms_from_genes(genes, lows, spans, gray_code):
    """(P, 6) 12-bit genes -> (P, 4, 4) poses; |ε| > 1 is normalised to 1 (see ga.py)."""
    n = genes.shape[0]
    T = np.zeros((n, 4, 4))
    x = np.empty(6)
    for p in range(n):
        for g in range(6):
            v = np.int64(genes[p, g])
            if gray_code:
                v ^= v >> 1
                v ^= v >> 2
                v ^= v >> 4
                v ^= v >> 8
            x[g] = lows[g] + v / 4095.0 * spans[g]
        e1, e2, e3 = x[3], x[4], x[5]
        norm2 = e1 * e1 + e2 * e2 + e3 * e3
        if norm2 > 1.0:
            scale = 1.0 / np.sqrt(norm2)
            e1, e2, e3 = e1 * scale, e2 * scale, e3 * scale
            norm2 = 1.0
        e0 = np.sqrt(1.0 - norm2)
        T[p, 0, 0] = 1 - 2 * (e2 * e2 + e3 * e3)
        T[p, 0, 1] = 2 * (e1 * e2 - e0 * e3)
        T[p, 0, 2] = 2 * (e1 * e3 + e0 * e2)
        T[p, 1, 0] = 2 * (e1 * e2 + e0 * e3)
        T[p, 1, 1] = 1 - 2 * (e1 * e1 + e3 * e3)
        T[p, 1, 2] = 2 * (e2 * e3 - e0 * e1)
        T[p, 2, 0] = 2 * (e1 * e3 - e0 * e2)
        T[p, 2, 1] = 2 * (e2 * e3 + e0 * e1)
        T[p, 2, 2] = 1 - 2 * (e1 * e1 + e2 * e2)
        T[p, 0, 3], T[p, 1, 3], T[p, 2, 3] = x[0], x[1], x[2]
        T[p, 3, 3] = 1.0
    return T


@_jit
def moved_poses(pose, deltas):
    """(K, 4, 4) copies of `pose` each moved by a row of `deltas` (K, 6): dx, dy [m], depth
    change along the ray through the model origin [m], rotation vector about the camera
    axes through the model origin [rad] (see refinement.moved)."""
    out = np.empty((deltas.shape[0], 4, 4))
    depth = pose[2, 3]
    for k in range(deltas.shape[0]):
        out[k] = pose
        out[k, 0, 3] += deltas[k, 0]
        out[k, 1, 3] += deltas[k, 1]
        if depth > 0:
            scale = (depth + deltas[k, 2]) / depth
            for r in range(3):
                out[k, r, 3] *= scale
        else:
            out[k, 2, 3] += deltas[k, 2]
        wx, wy, wz = deltas[k, 3], deltas[k, 4], deltas[k, 5]
        angle = np.sqrt(wx * wx + wy * wy + wz * wz)
        if angle > 0:
            x, y, z = wx / angle, wy / angle, wz / angle
            c, s_, t = np.cos(angle), np.sin(angle), 1.0 - np.cos(angle)
            R = np.array(
                [
                    [c + x * x * t, x * y * t - z * s_, x * z * t + y * s_],
                    [y * x * t + z * s_, c + y * y * t, y * z * t - x * s_],
                    [z * x * t - y * s_, z * y * t + x * s_, c + z * z * t],
                ]
            )
            for r in range(3):
                for c in range(3):
                    out[k, r, c] = R[r, 0] * pose[0, c] + R[r, 1] * pose[1, c] + R[r, 2] * pose[2, c]
    return out


@_jit
def pose_parameters(transforms):
    """(P, 4, 4) ^CR T_M -> (P, 6) (t, ε1, ε2, ε3), the unit quaternion's vector part with
    ε0 >= 0 (Shepperd: the largest of the four squared components gives a stable division)."""
    out = np.empty((transforms.shape[0], 6))
    q = np.empty(4)
    for p in range(transforms.shape[0]):
        R = transforms[p]
        r00, r11, r22 = R[0, 0], R[1, 1], R[2, 2]
        squares = (1 + r00 + r11 + r22, 1 + r00 - r11 - r22, 1 - r00 + r11 - r22, 1 - r00 - r11 + r22)
        pick = 0
        for k in range(1, 4):
            if squares[k] > squares[pick]:
                pick = k
        s = np.sqrt(max(squares[pick], 1e-300)) * 2.0
        d21, d02, d10 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
        a01, a02, a12 = R[0, 1] + R[1, 0], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1]
        if pick == 0:
            q[0], q[1], q[2], q[3] = s / 4, d21 / s, d02 / s, d10 / s
        elif pick == 1:
            q[0], q[1], q[2], q[3] = d21 / s, s / 4, a01 / s, a02 / s
        elif pick == 2:
            q[0], q[1], q[2], q[3] = d02 / s, a01 / s, s / 4, a12 / s
        else:
            q[0], q[1], q[2], q[3] = d10 / s, a02 / s, a12 / s, s / 4
        sign = -1.0 if q[0] < 0 else 1.0
        norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        for k in range(3):
            out[p, k] = R[k, 3]
            out[p, 3 + k] = sign * q[1 + k] / norm
    return out


@_jit
def poses_inside(transforms, low, high, min_cos_tilt, max_yaw):
    """(P,) bool: position within [low, high] (each of x, y, z), the model normal's cosine
    to the camera axis at least `min_cos_tilt`, |yaw| at most `max_yaw` (inf: any)."""
    n = transforms.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        ok = transforms[i, 2, 2] >= min_cos_tilt
        for k in range(3):
            t = transforms[i, k, 3]
            ok = ok and low[k] <= t <= high[k]
        if ok and max_yaw < np.inf:
            ok = abs(np.arctan2(transforms[i, 1, 0], transforms[i, 0, 0])) <= max_yaw
        out[i] = ok
    return out


@_jit
def poses_avoided(transforms, centres, windows, separation):
    """(P,) bool: the model origin within `separation` (x-y) of a centre (x, y, yaw) of
    (K, 3) `centres` and the yaw within that centre's `windows` [rad] of its yaw (a window
    above pi: any yaw; NaN cannot say so here, as fastmath assumes there is none)."""
    n = transforms.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        yaw = np.arctan2(transforms[i, 1, 0], transforms[i, 0, 0])
        for c in range(centres.shape[0]):
            dx, dy = transforms[i, 0, 3] - centres[c, 0], transforms[i, 1, 3] - centres[c, 1]
            if np.sqrt(dx * dx + dy * dy) >= separation:
                continue
            turn = (yaw - centres[c, 2] + np.pi) % (2.0 * np.pi) - np.pi
            if abs(turn) < windows[c]:
                out[i] = True
                break
    return out


@_jit
def poses_allowed(transforms, limits, avoided):
    """(P,) bool: `poses_inside(transforms, *limits)` and not `poses_avoided(transforms, *avoided)`."""
    out = poses_inside(transforms, *limits)
    if avoided[0].shape[0] > 0:
        out &= ~poses_avoided(transforms, *avoided)
    return out


__all__ = [
    "moved_poses",
    "pose_parameters",
    "poses_allowed",
    "poses_avoided",
    "poses_inside",
    "transforms_from_genes",
]
