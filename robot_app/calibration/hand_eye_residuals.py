"""How well a camera-to-hand transform explains the board images, and its refinement.

With X (the right camera in the hand) and W (the fixed board in the robot base), view i
predicts the board in the right camera as X⁻¹ H_i⁻¹ W and in the left one through the
rig; the pixel errors of every detected corner score an X, and a least-squares fit
(`scipy.optimize.least_squares`) minimises them over X and W, and optionally over the
rig too: both cameras' fx, fy, cx, cy, k1, k2, p1, p2 and the left-to-right pose.

Why the rig too: with the intrinsics held, a focal length off by ε puts every board ε
too far or too near and X absorbs it along the optical axis (ε of 0.2 % at 0.6 m: 1.2
mm, what 320x240 images give `cv2.calibrateCamera`). The robot's flange poses are
metric: views at different depths fix the focal length far better than the board's
foreshortening alone, so one fit over every corner of every view, with one board pose
W instead of one per view, corrects the focal lengths and X together (a robot-aided
bundle adjustment).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from robot_app.arrays import FloatArray
from robot_app.calibration.views import DetectedView
from robot_app.errors import CalibrationError
from robot_app.geometry import invert_transform, make_transform, rotation_angle_between
from robot_app.vision.camera import PinholeCamera, StereoRig

INTRINSICS = 8  # fx, fy, cx, cy, k1, k2, p1, p2 per camera (k3 stays as calibrated)


@dataclass(frozen=True)
class MethodResult:
    """One way of solving for X and how well its X explains the images.

    Attributes:
        name: 'tsai', 'park', 'daniilidis' or 'refined'.
        transform_right_camera_to_hand: its X (4x4) [m].
        reprojection_rms_px: RMS pixel error of the board's corners over all views.
        board_spread_mm, board_spread_deg: RMS of the per-view board poses H_i X C_i
            around their mean (0 for perfect data) [mm, deg].
    """

    name: str
    transform_right_camera_to_hand: FloatArray
    reprojection_rms_px: float
    board_spread_mm: float
    board_spread_deg: float


@dataclass(frozen=True)
class ViewResidual:
    """A used view under the final X: its pixel error and its board pose's offset."""

    index: int
    reprojection_px: float
    board_offset_mm: float
    board_angle_deg: float


def board_in_camera(objects: FloatArray, pixels: FloatArray, camera: PinholeCamera) -> FloatArray:
    """The board's pose in the camera (4x4) from its corners, by PnP."""
    K, dist = np.array(camera.camera_matrix), np.array(camera.dist_coeffs)
    ok, rvec, tvec = cv2.solvePnP(objects, pixels, K, dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        raise CalibrationError("solvePnP found no board pose in a view")
    rvec, tvec = cv2.solvePnPRefineLM(objects, pixels, K, dist, rvec, tvec)
    return make_transform(cv2.Rodrigues(rvec)[0], tvec.reshape(3))


class BoardObservations:
    """The used views' corners and flange poses; scores and refines a camera-to-hand X against them.

    Args:
        views: the views used (the right image must hold the board).
        objects: the board's corners in Σ_B [m].
        rig: intrinsics of both cameras and their relative pose.
        H: each view's flange pose in the base [m].
        skip_left: views whose left image is left out.
    """

    def __init__(
        self,
        views: list[DetectedView],
        objects: FloatArray,
        rig: StereoRig,
        H: list[FloatArray],
        skip_left: set[int],
    ) -> None:
        self.indices = [v.pair.index for v in views]
        self.H = H
        self.rig = rig
        self.right_to_left = rig.transform_right_to_left
        self.sides: list[list[tuple[FloatArray, FloatArray, PinholeCamera, bool]]] = []
        for view in views:
            sides = [(objects[view.right.corner_ids], view.right.image_points, rig.right, False)]
            if view.left.usable and view.pair.index not in skip_left:
                sides.append((objects[view.left.corner_ids], view.left.image_points, rig.left, True))
            self.sides.append(sides)

    def with_rig(self, rig: StereoRig) -> BoardObservations:
        """The same observations seen through another rig (e.g. a refined one)."""
        other = copy.copy(self)
        other.rig = rig
        other.right_to_left = rig.transform_right_to_left
        other.sides = [
            [(o, p, rig.left if is_left else rig.right, is_left) for o, p, _, is_left in sides]
            for sides in self.sides
        ]
        return other

    def depth_ratio(self) -> float:
        """Farthest over nearest board (its corners' mean depth in the right camera, PnP)."""
        depths = []
        for sides in self.sides:
            objects, pixels, camera, _ = sides[0]
            T = board_in_camera(objects, pixels, camera)
            depths.append(float((T[:3, :3] @ objects.mean(axis=0) + T[:3, 3])[2]))
        return max(depths) / min(depths)

    def board_pose(self, X: FloatArray) -> FloatArray:
        """W: the mean of the per-view board poses H_i X C_i (C_i from the right image's PnP)."""
        poses = self._board_poses(X)
        R = np.sum([p[:3, :3] for p in poses], axis=0)
        U, _, Vt = np.linalg.svd(R)
        R_mean = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
        return make_transform(R_mean, np.mean([p[:3, 3] for p in poses], axis=0))

    def _board_poses(self, X: FloatArray) -> list[FloatArray]:
        poses = []
        for H, sides in zip(self.H, self.sides, strict=True):
            objects, pixels, camera, _ = sides[0]
            poses.append(H @ X @ board_in_camera(objects, pixels, camera))
        return poses

    def errors(self, X: FloatArray, W: FloatArray) -> list[FloatArray]:
        """Per view, the (N, 2) pixel errors of all its corners (right, then left)."""
        return [np.concatenate(sides) for sides in self.side_errors(X, W)]

    def side_errors(self, X: FloatArray, W: FloatArray) -> list[list[FloatArray]]:
        """Per view, the (N, 2) pixel errors in the right image and (if used) the left one."""
        X_inverse = invert_transform(X)
        out = []
        for H, sides in zip(self.H, self.sides, strict=True):
            board_in_right = X_inverse @ invert_transform(H) @ W
            parts = []
            for objects, pixels, camera, is_left in sides:
                T = self.right_to_left @ board_in_right if is_left else board_in_right
                rvec = cv2.Rodrigues(T[:3, :3])[0]
                projected, _ = cv2.projectPoints(
                    objects, rvec, T[:3, 3], np.array(camera.camera_matrix), np.array(camera.dist_coeffs)
                )
                parts.append(projected.reshape(-1, 2) - pixels)
            out.append(parts)
        return out

    def outliers(
        self, X: FloatArray, W: FloatArray, max_error_px: float
    ) -> tuple[dict[int, float], set[int], float]:
        """Views whose right image, and views whose left image, do not fit X and W.

        An image fits when its corners' RMS error is within max(max_error_px, 5 x the
        median over all images) [px]. Returns (right misfits by view with their error,
        left misfits, the limit).
        """
        rms = [
            [float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) for e in sides] for sides in self.side_errors(X, W)
        ]
        limit = max(max_error_px, 5.0 * float(np.median([e for sides in rms for e in sides])))
        right = {i: sides[0] for i, sides in zip(self.indices, rms, strict=True) if sides[0] > limit}
        left = {i for i, sides in zip(self.indices, rms, strict=True) if len(sides) > 1 and sides[1] > limit}
        return right, left, limit

    def score(self, name: str, X: FloatArray, W: FloatArray | None = None) -> MethodResult:
        """X's residuals; W defaults to the mean board pose under X."""
        W = self.board_pose(X) if W is None else W
        errors = np.concatenate(self.errors(X, W))
        poses = self._board_poses(X)
        offsets = [1000.0 * np.linalg.norm(p[:3, 3] - W[:3, 3]) for p in poses]
        angles = [np.degrees(rotation_angle_between(p[:3, :3], W[:3, :3])) for p in poses]
        return MethodResult(
            name,
            X,
            float(np.sqrt(np.mean(np.sum(errors**2, axis=1)))),
            float(np.sqrt(np.mean(np.square(offsets)))),
            float(np.sqrt(np.mean(np.square(angles)))),
        )

    def residuals(self, X: FloatArray, W: FloatArray) -> tuple[ViewResidual, ...]:
        poses = self._board_poses(X)
        out = []
        for index, error, pose in zip(self.indices, self.errors(X, W), poses, strict=True):
            out.append(
                ViewResidual(
                    index,
                    float(np.sqrt(np.mean(np.sum(error**2, axis=1)))),
                    float(1000.0 * np.linalg.norm(pose[:3, 3] - W[:3, 3])),
                    float(np.degrees(rotation_angle_between(pose[:3, :3], W[:3, :3]))),
                )
            )
        return tuple(out)

    def refine(self, X0: FloatArray, with_rig: bool = False) -> tuple[MethodResult, FloatArray, StereoRig]:
        """Least squares over every corner's pixel error: X and W, and the rig if `with_rig`.

        Returns the refined X's result, W and the rig (the given one unless `with_rig`;
        its transform_right_camera_to_hand is X).
        """
        W0 = self.board_pose(X0)
        p0 = [_vector(X0), _vector(W0)]
        if with_rig:
            p0 += [
                _intrinsics(self.rig.left),
                _intrinsics(self.rig.right),
                _vector(self.rig.transform_left_to_right),
            ]
        observations = [
            (k, is_left, objects, pixels)
            for k, sides in enumerate(self.sides)
            for objects, pixels, _, is_left in sides
        ]
        hand_inverse = [invert_transform(H) for H in self.H]
        k3s = (float(self.rig.left.dist_coeffs[4]), float(self.rig.right.dist_coeffs[4]))

        def unpack(q: FloatArray) -> tuple[FloatArray, FloatArray, StereoRig]:
            X, W = _transform(q[:6]), _transform(q[6:12])
            if not with_rig:
                return X, W, self.rig
            left = _camera(self.rig.left, q[12 : 12 + INTRINSICS])
            right = _camera(self.rig.right, q[12 + INTRINSICS : 12 + 2 * INTRINSICS])
            return X, W, StereoRig(left, right, _transform(q[12 + 2 * INTRINSICS :]))

        def residual(q: FloatArray) -> FloatArray:
            X, W = _transform(q[:6]), _transform(q[6:12])
            if with_rig:
                cameras = (q[12 : 12 + INTRINSICS], q[12 + INTRINSICS : 12 + 2 * INTRINSICS])
                right_to_left = invert_transform(_transform(q[12 + 2 * INTRINSICS :]))
            else:
                cameras = (_intrinsics(self.rig.left), _intrinsics(self.rig.right))
                right_to_left = self.right_to_left
            left, right = (_matrices(c, k3) for c, k3 in zip(cameras, k3s, strict=True))
            X_inverse = invert_transform(X)
            out = []
            for k, is_left, objects, pixels in observations:
                T = X_inverse @ hand_inverse[k] @ W
                if is_left:
                    T = right_to_left @ T
                K, dist = left if is_left else right
                projected, _ = cv2.projectPoints(objects, cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], K, dist)
                out.append((projected.reshape(-1, 2) - pixels).ravel())
            return np.concatenate(out)

        solution = least_squares(residual, np.concatenate(p0), method="lm", x_scale="jac")
        X, W, rig = unpack(solution.x)
        rig = StereoRig(rig.left, rig.right, rig.transform_left_to_right, X)
        scored = self.with_rig(rig) if with_rig else self
        name = "refined with the rig" if with_rig else "refined"
        return scored.score(name, X, W), W, rig


def _intrinsics(camera: PinholeCamera) -> FloatArray:
    K, d = camera.camera_matrix, camera.dist_coeffs
    return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2], d[0], d[1], d[2], d[3]])


def _matrices(q: FloatArray, k3: float) -> tuple[FloatArray, FloatArray]:
    K = np.array([[q[0], 0.0, q[2]], [0.0, q[1], q[3]], [0.0, 0.0, 1.0]])
    return K, np.array([q[4], q[5], q[6], q[7], k3])


def _camera(camera: PinholeCamera, q: FloatArray) -> PinholeCamera:
    K, dist = _matrices(q, float(camera.dist_coeffs[4]))
    return PinholeCamera(K, camera.image_size, dist)


def _vector(T: FloatArray) -> FloatArray:
    return np.r_[cv2.Rodrigues(np.ascontiguousarray(T[:3, :3]))[0].reshape(3), T[:3, 3]]


def _transform(v: FloatArray) -> FloatArray:
    return make_transform(cv2.Rodrigues(np.asarray(v[:3], dtype=float))[0], v[3:])


__all__ = ["BoardObservations", "MethodResult", "ViewResidual", "board_in_camera"]
