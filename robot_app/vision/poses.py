"""Poses ^CR T_M as the search stages see them: parameters, moves, the allowed set.

A pose is a (4, 4) transform of Σ_M into Σ_CR. The GA's chromosome holds (t, ε), the
position and the vector part of a unit quaternion with ε0 >= 0; the local searches move a
pose along the camera axes, in depth along the ray through the model origin and about the
camera axes through the model origin. `PoseLimits` and `AvoidedPoses` are the allowed set
every stage respects: inside the search bounds, and away from peaks already reported or
rejected.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.pose_kernels import moved_poses, pose_parameters, poses_allowed, poses_avoided

GENES = 6  # (t_x, t_y, t_z, ε1, ε2, ε3)


def as_poses(transforms: npt.ArrayLike) -> FloatArray:
    """(P, 4, 4) float64 C-contiguous poses from (P, 4, 4) or (4, 4)."""
    T = np.asarray(transforms, dtype=float)
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ValueError(f"poses must have shape (P, 4, 4) or (4, 4), got {T.shape}")
    return np.ascontiguousarray(T)


def transforms_from_parameters(parameters: npt.ArrayLike) -> FloatArray:
    """(P, 6) (t, ε) -> (P, 4, 4) ^CR T_M; an ε with |ε| > 1 is normalised (ε0 = 0)."""
    x = np.asarray(parameters, dtype=float).reshape(-1, GENES)
    eps = x[:, 3:].copy()
    norm = np.linalg.norm(eps, axis=1)
    long = norm > 1.0
    eps[long] /= norm[long, None]
    e1, e2, e3 = eps.T
    e0 = np.sqrt(np.clip(1.0 - (e1 * e1 + e2 * e2 + e3 * e3), 0.0, 1.0))
    T = np.zeros((len(x), 4, 4))
    T[:, 0, 0] = 1 - 2 * (e2 * e2 + e3 * e3)
    T[:, 0, 1] = 2 * (e1 * e2 - e0 * e3)
    T[:, 0, 2] = 2 * (e1 * e3 + e0 * e2)
    T[:, 1, 0] = 2 * (e1 * e2 + e0 * e3)
    T[:, 1, 1] = 1 - 2 * (e1 * e1 + e3 * e3)
    T[:, 1, 2] = 2 * (e2 * e3 - e0 * e1)
    T[:, 2, 0] = 2 * (e1 * e3 - e0 * e2)
    T[:, 2, 1] = 2 * (e2 * e3 + e0 * e1)
    T[:, 2, 2] = 1 - 2 * (e1 * e1 + e2 * e2)
    T[:, :3, 3] = x[:, :3]
    T[:, 3, 3] = 1.0
    return T


def parameters_from_transforms(transforms: npt.ArrayLike) -> FloatArray:
    """(P, 4, 4) ^CR T_M -> (P, 6) (t, ε) with ε0 >= 0 (the inverse of `transforms_from_parameters`)."""
    return np.asarray(pose_parameters(as_poses(transforms)))


def neighbours(pose: FloatArray, steps: FloatArray) -> FloatArray:
    """The 12 poses one step away along each of the six coordinates, both ways (+, - pairs).

    Args:
        pose: (4, 4) ^CR T_M.
        steps: (6,) steps along camera x, y, along the ray through the model origin
            (in depth) [m] and about the camera axes through the model origin [rad].
    """
    deltas = np.zeros((12, 6))
    deltas[0::2][np.arange(6), np.arange(6)] = steps
    deltas[1::2][np.arange(6), np.arange(6)] = -steps
    return np.asarray(moved_poses(np.ascontiguousarray(pose, dtype=float), deltas))


def moved(pose: FloatArray, delta: npt.ArrayLike) -> FloatArray:
    """`pose` moved by (dx, dy [m], d_depth [m] along the ray through the model origin,
    rotation vector [rad] about the camera axes through the model origin)."""
    deltas = np.asarray(delta, dtype=float).reshape(1, 6)
    return np.asarray(moved_poses(np.ascontiguousarray(pose, dtype=float), deltas))[0]


class AvoidedPoses(NamedTuple):
    """Poses a search must not visit (peaks already reported, or poor peaks that drew it):
    the model origin within `separation` (x-y) [m] of a centre (x, y [m], yaw [rad]) and,
    unless the centre's yaw is NaN (any yaw), the yaw within `yaw_window` [rad] of it."""

    centres: FloatArray  # (K, 3)
    separation: float
    yaw_window: float

    @classmethod
    def none(cls) -> AvoidedPoses:
        """Nothing avoided."""
        return cls(np.zeros((0, 3)), 0.0, 0.0)

    def kernel_arguments(self) -> tuple[FloatArray, FloatArray, float]:
        """(centres, windows, separation) as `pose_kernels.poses_avoided` takes them: a NaN
        yaw becomes 0 with a window wider than a half turn (the kernels assume no NaN)."""
        centres = np.array(self.centres, dtype=float).reshape(-1, 3)
        any_yaw = np.isnan(centres[:, 2])
        windows = np.where(any_yaw, 4.0, self.yaw_window)
        centres[any_yaw, 2] = 0.0
        return centres, windows, float(self.separation)

    def mask(self, transforms: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """(P,) True where a pose of (P, 4, 4) `transforms` is avoided."""
        return np.asarray(poses_avoided(as_poses(transforms), *self.kernel_arguments()))


class PoseLimits(NamedTuple):
    """The allowed set of `pose_kernels.poses_inside`: position within [low, high] (x, y, z
    [m]), cosine of the tilt at least `min_cos_tilt`, |yaw| at most `max_yaw` [rad] (inf: any)."""

    low: FloatArray
    high: FloatArray
    min_cos_tilt: float
    max_yaw: float

    def allows(self, transforms: npt.ArrayLike, avoid: AvoidedPoses | None = None) -> npt.NDArray[np.bool_]:
        """(P,) True where a pose of (P, 4, 4) `transforms` is within the limits and not avoided."""
        avoided = avoid if avoid is not None else AvoidedPoses.none()
        return np.asarray(poses_allowed(as_poses(transforms), tuple(self), avoided.kernel_arguments()))


__all__ = [
    "GENES",
    "AvoidedPoses",
    "PoseLimits",
    "as_poses",
    "moved",
    "neighbours",
    "parameters_from_transforms",
    "transforms_from_parameters",
]
