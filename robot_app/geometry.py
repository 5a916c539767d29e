"""SE(3) and quaternion helpers shared by vision, sim and control.

Homogeneous transforms are 4x4 float arrays named by direction, e.g.
`transform_model_to_camera` maps points in Σ_M to Σ_CR. Quaternions in files, JSON and
pybullet are (x, y, z, w) (`quaternion_xyzw`); pinocchio's constructor takes (w, x, y, z),
so conversions go through this module only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from robot_app.arrays import FloatArray


def make_transform(rotation: npt.ArrayLike, translation: npt.ArrayLike) -> FloatArray:
    """Builds a 4x4 homogeneous transform from a 3x3 rotation and a translation [m]."""
    R = np.asarray(rotation, dtype=float)
    t = np.asarray(translation, dtype=float).reshape(-1)
    if R.shape != (3, 3) or t.shape != (3,):
        raise ValueError(f"make_transform needs a 3x3 rotation and a 3-vector, got {R.shape}, {t.shape}")
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def invert_transform(transform: npt.ArrayLike) -> FloatArray:
    """Inverse of a rigid 4x4 transform (R^T, -R^T t), exact for rotations."""
    T = np.asarray(transform, dtype=float)
    R = T[:3, :3]
    t = T[:3, 3]
    return make_transform(R.T, -R.T @ t)


def is_rotation(rotation: npt.ArrayLike, tol: float = 1e-6) -> bool:
    """True if `rotation` is a proper 3x3 rotation matrix within `tol`."""
    R = np.asarray(rotation, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        return False
    return bool(np.allclose(R.T @ R, np.eye(3), atol=tol) and abs(np.linalg.det(R) - 1.0) < tol)


def quaternion_xyzw_from_matrix(rotation: npt.ArrayLike) -> FloatArray:
    """Unit quaternion (x, y, z, w) with w >= 0 of a rotation matrix."""
    R = np.asarray(rotation, dtype=float)
    q = pin.Quaternion(R)
    xyzw = np.array(q.coeffs(), dtype=float)  # pinocchio's coeffs() is (x, y, z, w)
    xyzw /= np.linalg.norm(xyzw)
    return -xyzw if xyzw[3] < 0 else xyzw


def matrix_from_quaternion_xyzw(quaternion_xyzw: npt.ArrayLike) -> FloatArray:
    """Rotation matrix of a quaternion given as (x, y, z, w); normalised first."""
    x, y, z, w = np.asarray(quaternion_xyzw, dtype=float)
    norm = np.sqrt(x * x + y * y + z * z + w * w)
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"quaternion {quaternion_xyzw!r} has no direction")
    q = pin.Quaternion(w / norm, x / norm, y / norm, z / norm)  # constructor takes (w, x, y, z)
    return np.array(q.toRotationMatrix(), dtype=float)


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> FloatArray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention [rad]."""
    return np.array(pin.rpy.rpyToMatrix(roll, pitch, yaw), dtype=float)


def rotation_about_z(angle: float) -> FloatArray:
    """Rotation by `angle` [rad] about the z axis."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_of(rotation: npt.ArrayLike) -> float:
    """Yaw [rad] of a rotation about its frame's z axis: atan2(R[1,0], R[0,0])."""
    R = np.asarray(rotation, dtype=float)
    return float(np.arctan2(R[1, 0], R[0, 0]))


def wrap_angle(angle: npt.ArrayLike) -> npt.NDArray[np.float64] | float:
    """Wraps angles [rad] into [-pi, pi)."""
    wrapped = (np.asarray(angle, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi
    return float(wrapped) if np.ndim(wrapped) == 0 else wrapped


def yaw_error(yaw_difference: float, symmetry_angles: tuple[float, ...] = ()) -> float:
    """The yaw difference [rad] modulo a shape's symmetry: the smallest |wrap(d - s)|, s in {0, *angles}.

    All angles are tried (not reduced one after another: with 90° symmetry a -90.4° error
    reduced by 180° first would stay at 89.6°).
    """
    candidates = [float(wrap_angle(yaw_difference - s)) for s in (0.0, *symmetry_angles)]
    return min(candidates, key=abs)


@dataclass(frozen=True)
class PoseError:
    """A recognised (or estimated) pose of Σ_M minus the true one, in their common frame.

    Attributes:
        x_mm, y_mm, z_mm: position error [mm].
        yaw_deg: yaw error [deg] about the frame's z axis, the smallest over the cloth's
            symmetric yaws.
        tilt_deg: angle between the recognised and the true z axes (cloth normals) [deg].
    """

    x_mm: float
    y_mm: float
    z_mm: float
    yaw_deg: float
    tilt_deg: float

    @property
    def xy_mm(self) -> float:
        """Position error in the frame's x-y plane [mm]."""
        return float(np.hypot(self.x_mm, self.y_mm))


def pose_error(
    transform_estimate: npt.ArrayLike,
    transform_true: npt.ArrayLike,
    symmetry_angles: tuple[float, ...] = (),
) -> PoseError:
    """Error of an estimated 4x4 pose of Σ_M against the truth, both in one frame.

    The one definition used by the recognition trials, the simulator's checks and the
    pick-and-place loop's log.

    Args:
        transform_estimate: (4, 4) estimated pose (e.g. ^CR T_M or ^W T_M).
        transform_true: (4, 4) true pose in the same frame.
        symmetry_angles: yaws [rad] under which the cloth looks the same; the yaw error
            is the smallest |wrap(d - s)| over s in {0, *symmetry_angles}.
    """
    estimate = np.asarray(transform_estimate, dtype=float)
    truth = np.asarray(transform_true, dtype=float)
    d = 1000.0 * (estimate[:3, 3] - truth[:3, 3])
    yaw = yaw_error(yaw_of(estimate[:3, :3]) - yaw_of(truth[:3, :3]), symmetry_angles)
    cos_tilt = float(np.clip(estimate[:3, 2] @ truth[:3, 2], -1.0, 1.0))
    return PoseError(
        float(d[0]), float(d[1]), float(d[2]), float(np.rad2deg(yaw)), float(np.rad2deg(np.arccos(cos_tilt)))
    )


def rotation_angle_between(rotation_a: npt.ArrayLike, rotation_b: npt.ArrayLike) -> float:
    """Geodesic angle [rad] between two rotations, |log(A^T B)|."""
    A = np.asarray(rotation_a, dtype=float)
    B = np.asarray(rotation_b, dtype=float)
    cos_angle = (np.trace(A.T @ B) - 1.0) / 2.0
    return float(np.arccos(np.clip(cos_angle, -1.0, 1.0)))


def transform_points(transform: npt.ArrayLike, points: npt.ArrayLike) -> FloatArray:
    """Applies a 4x4 transform to an (N, 3) array of points."""
    T = np.asarray(transform, dtype=float)
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    return P @ T[:3, :3].T + T[:3, 3]


def kabsch(source: npt.ArrayLike, target: npt.ArrayLike) -> FloatArray:
    """Rigid transform (4x4) that best maps `source` (N, 3) onto `target` (N, 3).

    Least squares without scale (Kabsch/Umeyama), reflection-corrected.
    """
    S = np.asarray(source, dtype=float).reshape(-1, 3)
    D = np.asarray(target, dtype=float).reshape(-1, 3)
    if S.shape != D.shape or len(S) < 3:
        raise ValueError(f"kabsch needs two (N>=3, 3) arrays of equal shape, got {S.shape}, {D.shape}")
    cs, cd = S.mean(axis=0), D.mean(axis=0)
    H = (S - cs).T @ (D - cd)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return make_transform(R, cd - R @ cs)


__all__ = [
    "PoseError",
    "invert_transform",
    "is_rotation",
    "kabsch",
    "make_transform",
    "matrix_from_quaternion_xyzw",
    "pose_error",
    "quaternion_xyzw_from_matrix",
    "rotation_about_z",
    "rotation_angle_between",
    "rotation_from_rpy",
    "transform_points",
    "wrap_angle",
    "yaw_error",
    "yaw_of",
]
