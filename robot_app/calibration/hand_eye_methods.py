"""Closed-form solutions of the hand-eye equation A X = X B (eye in hand).

For views i, j of a fixed board, A = H_j⁻¹ H_i is the hand's motion (H: hand in base)
and B = C_j C_i⁻¹ the camera's (C: board in camera); X is the camera in the hand,
`transform_right_camera_to_hand`. Rotation first, translation then by linear least
squares from (R_A - I) t_X = R_X t_B - t_A. The three methods OpenCV's
`calibrateHandEye` offers under these names, written out with numpy because the
OpenCV 5 wheels do not bind that function:

- Tsai & Lenz 1989: modified Rodrigues vectors, a linear system for the rotation;
- Park & Martin 1994: rotation axes α = log R_A = R_X β, Procrustes on α, β;
- Daniilidis 1999: rotation and translation at once from dual quaternions (SVD).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from itertools import combinations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.geometry import invert_transform, make_transform


def motion_pairs(
    transforms_hand_to_base: Sequence[npt.ArrayLike], transforms_board_to_camera: Sequence[npt.ArrayLike]
) -> tuple[FloatArray, FloatArray]:
    """(A, B) motions of every pair of views, each (P, 4, 4), P = n (n - 1) / 2."""
    H = [np.asarray(T, dtype=float) for T in transforms_hand_to_base]
    C = [np.asarray(T, dtype=float) for T in transforms_board_to_camera]
    if len(H) != len(C) or len(H) < 3:
        raise ValueError(f"need >= 3 views with a hand and a board pose each, got {len(H)} and {len(C)}")
    A, B = [], []
    for i, j in combinations(range(len(H)), 2):
        A.append(invert_transform(H[j]) @ H[i])
        B.append(C[j] @ invert_transform(C[i]))
    return np.array(A), np.array(B)


def rotation_log(R: FloatArray) -> FloatArray:
    """Axis-angle vector (3,) of a rotation [rad]."""
    cos_angle = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cos_angle))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * w
    if angle > np.pi - 1e-6:  # near a half turn: axis from the symmetric part
        axis = np.sqrt(np.clip((np.diag(R) + 1.0) / 2.0, 0.0, None))
        k = int(np.argmax(axis))
        for m in range(3):
            if m != k:
                axis[m] = np.copysign(axis[m], R[k, m] + R[m, k])
        if axis @ w < 0:  # short of a half turn, the antisymmetric part still has the sign
            axis = -axis
        return angle * axis / np.linalg.norm(axis)
    return angle / (2.0 * np.sin(angle)) * w


def _skew(v: FloatArray) -> FloatArray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _translation(A: FloatArray, B: FloatArray, R_X: FloatArray) -> FloatArray:
    """Least-squares t_X of (R_A - I) t_X = R_X t_B - t_A."""
    M = np.concatenate([a[:3, :3] - np.eye(3) for a in A])
    rhs = np.concatenate([R_X @ b[:3, 3] - a[:3, 3] for a, b in zip(A, B, strict=True)])
    return np.asarray(np.linalg.lstsq(M, rhs, rcond=None)[0], dtype=float)


def _closest_rotation(M: FloatArray) -> FloatArray:
    U, _, Vt = np.linalg.svd(M)
    return np.asarray(U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt, dtype=float)


def hand_eye_park(A: FloatArray, B: FloatArray) -> FloatArray:
    """Park & Martin: R_X = argmin Σ |α_k - R β_k|² (orthogonal Procrustes)."""
    alpha = np.array([rotation_log(a[:3, :3]) for a in A])
    beta = np.array([rotation_log(b[:3, :3]) for b in B])
    R_X = _closest_rotation(alpha.T @ beta)
    return make_transform(R_X, _translation(A, B, R_X))


def hand_eye_tsai(A: FloatArray, B: FloatArray) -> FloatArray:
    """Tsai & Lenz: skew(P_A + P_B) P' = P_B - P_A with P = 2 sin(θ/2) n."""
    rows, rhs = [], []
    for a, b in zip(A, B, strict=True):
        pa, pb = (_modified_rodrigues(m[:3, :3]) for m in (a, b))
        rows.append(_skew(pa + pb))
        rhs.append(pb - pa)
    P_prime = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)[0]
    P = 2.0 * P_prime / np.sqrt(1.0 + P_prime @ P_prime)
    n2 = float(P @ P)
    R_X = (1.0 - n2 / 2.0) * np.eye(3) + 0.5 * (np.outer(P, P) + np.sqrt(max(0.0, 4.0 - n2)) * _skew(P))
    R_X = _closest_rotation(R_X)
    return make_transform(R_X, _translation(A, B, R_X))


def _modified_rodrigues(R: FloatArray) -> FloatArray:
    w = rotation_log(R)
    angle = float(np.linalg.norm(w))
    return np.zeros(3) if angle < 1e-12 else 2.0 * np.sin(angle / 2.0) * w / angle


def hand_eye_daniilidis(A: FloatArray, B: FloatArray) -> FloatArray:
    """Daniilidis: rotation and translation together from the dual quaternions' SVD."""
    rows = []
    for a, b in zip(A, B, strict=True):
        qa, qa_dual = _dual_quaternion(a)
        qb, qb_dual = _dual_quaternion(b)
        if qa[0] * qb[0] < 0:  # same scalar part (equal angles): same hemisphere
            qb, qb_dual = -qb, -qb_dual
        S = np.zeros((6, 8))
        S[:3, 0] = qa[1:] - qb[1:]
        S[:3, 1:4] = _skew(qa[1:] + qb[1:])
        S[3:, 0] = qa_dual[1:] - qb_dual[1:]
        S[3:, 1:4] = _skew(qa_dual[1:] + qb_dual[1:])
        S[3:, 4] = qa[1:] - qb[1:]
        S[3:, 5:8] = _skew(qa[1:] + qb[1:])
        rows.append(S)
    _, _, Vt = np.linalg.svd(np.concatenate(rows))
    v7, v8 = Vt[-2], Vt[-1]
    u1, w1, u2, w2 = v7[:4], v7[4:], v8[:4], v8[4:]
    # λ1 v7 + λ2 v8 is a unit dual quaternion: q·q' = 0 and |q| = 1
    a, b, c = u1 @ w1, u1 @ w2 + u2 @ w1, u2 @ w2
    roots = np.roots([a, b, c]) if abs(a) > 1e-15 else np.array([-c / b])
    roots = roots[np.isreal(roots)].real
    if roots.size == 0:
        raise ValueError("Daniilidis: no real solution (motions too small or inconsistent)")
    best = max(roots, key=lambda s: s * s * (u1 @ u1) + 2 * s * (u1 @ u2) + u2 @ u2)
    norm = best * best * (u1 @ u1) + 2 * best * (u1 @ u2) + u2 @ u2
    l2 = 1.0 / np.sqrt(norm)
    l1 = best * l2
    q = l1 * u1 + l2 * u2
    q_dual = l1 * w1 + l2 * w2
    R_X = _matrix_from_quaternion(q)
    t = 2.0 * _quaternion_product(q_dual, _conjugate(q))[1:]
    return make_transform(R_X, t)


def _dual_quaternion(T: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(q, q') with q the rotation (w, x, y, z) and q' = ½ (0, t) q."""
    q = _quaternion_from_matrix(T[:3, :3])
    return q, 0.5 * _quaternion_product(np.r_[0.0, T[:3, 3]], q)


def _quaternion_from_matrix(R: FloatArray) -> FloatArray:
    w = rotation_log(R)
    angle = float(np.linalg.norm(w))
    axis = w / angle if angle > 1e-12 else np.zeros(3)
    return np.r_[np.cos(angle / 2.0), np.sin(angle / 2.0) * axis]


def _matrix_from_quaternion(q: FloatArray) -> FloatArray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _quaternion_product(p: FloatArray, q: FloatArray) -> FloatArray:
    pw, pv, qw, qv = p[0], p[1:], q[0], q[1:]
    return np.r_[pw * qw - pv @ qv, pw * qv + qw * pv + np.cross(pv, qv)]


def _conjugate(q: FloatArray) -> FloatArray:
    return np.r_[q[0], -q[1:]]


HAND_EYE_METHODS: dict[str, Callable[[FloatArray, FloatArray], FloatArray]] = {
    "tsai": hand_eye_tsai,
    "park": hand_eye_park,
    "daniilidis": hand_eye_daniilidis,
}

__all__ = [
    "HAND_EYE_METHODS",
    "hand_eye_daniilidis",
    "hand_eye_park",
    "hand_eye_tsai",
    "motion_pairs",
    "rotation_log",
]
