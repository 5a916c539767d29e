"""Hand-eye calibration: where the right camera sits on the hand, from a fixed board.

The arm stops at several poses over a board that does not move; at each, the robot
reports its flange pose H_i (Σ_H in the base) and the right camera sees the board (C_i,
board in the camera, from `cv2.solvePnP` with the calibrated intrinsics). Then
H_i X C_i is the same board pose W for every view, which fixes X = ^H T_CR.

How X is found: the three closed-form methods (Tsai-Lenz, Park-Martin, Daniilidis) are
run on every pair of views and scored by the reprojection error their X gives (board
pose W averaged over the views, then the board's corners projected into every image);
the best one starts a Levenberg-Marquardt refinement of X and W over the pixel errors
of both cameras, which weighs each view by what its image really measured instead of by
its pose's noise. `method` can force one closed form and `refine` switch the last step off.

Checks that make bad input an error rather than a wrong X: the robot's translations and
the camera's must agree in scale (a board file with the wrong square size, poses in
millimetres), and the hand must turn about at least two different axes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig
from robot_app.calibration.detection import DetectionSettings
from robot_app.calibration.files import ImagePair
from robot_app.calibration.hand_eye_methods import HAND_EYE_METHODS, motion_pairs, rotation_log
from robot_app.calibration.views import DetectedView, require_views
from robot_app.config import StrictModel
from robot_app.errors import CalibrationError, InputError
from robot_app.geometry import invert_transform, make_transform, rotation_angle_between
from robot_app.vision.camera import PinholeCamera, StereoRig

HandEyeMethod = Literal["auto", "tsai", "park", "daniilidis"]
MAX_ROUNDS = 3


class HandEyeSettings(StrictModel):
    """Choices and limits of `robot-app calibrate hand-eye`."""

    detection: DetectionSettings = DetectionSettings()
    min_views: int = Field(6, ge=3, description="fewest usable views")
    method: HandEyeMethod = Field("auto", description="closed form to start from; auto = lowest residual")
    refine: bool = Field(True, description="refine X and the board pose over the pixel errors")
    max_scale_error: float = Field(
        0.03, gt=0.0, lt=1.0, description="largest |camera / robot translation scale - 1| accepted"
    )
    min_turn_deg: float = Field(
        5.0, gt=0.0, description="the hand must turn at least this much about a second axis [deg]"
    )
    max_view_error_px: float = Field(
        1.0, gt=0.0, description="leave out images whose RMS error is above this and 5x the median [px]"
    )


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


@dataclass(frozen=True)
class HandEyeCalibration:
    """The result of `calibrate_hand_eye`.

    Attributes:
        transform_right_camera_to_hand: X = ^H T_CR, 4x4 [m].
        transform_board_to_base: the board's pose W in the robot base [m].
        method: how X was obtained, e.g. 'park, refined'.
        methods: every closed form tried, and the refinement.
        residuals: per used view.
        reprojection_rms_px: RMS pixel error of all corners under X and W.
        scale: camera translations / robot translations (1 when the board size is right).
        turn_deg: how far the hand turned about its second axis of rotation [deg].
        refused: (view number, reason) for each view left out.
        left_unused: views whose left image was left out (its corners did not fit).
    """

    transform_right_camera_to_hand: FloatArray
    transform_board_to_base: FloatArray
    method: str
    methods: tuple[MethodResult, ...]
    residuals: tuple[ViewResidual, ...]
    reprojection_rms_px: float
    scale: float
    turn_deg: float
    refused: tuple[tuple[int, str], ...]
    left_unused: tuple[int, ...] = ()


def match_robot_poses(
    pairs: Sequence[ImagePair], poses: Mapping[int, FloatArray], source: str = "--robot-poses"
) -> dict[int, FloatArray]:
    """Pairs each view with its robot pose by number, or says what does not match (exit 2)."""
    views = {p.index for p in pairs}
    if len(poses) != len(views):
        raise InputError(
            f"{source} has {len(poses)} robot poses but the image folder has {len(views)} views: "
            "one pose per image pair is needed",
            key="--robot-poses",
            value=len(poses),
            expected=f"{len(views)} poses",
        )
    missing = sorted(views - set(poses))
    if missing:
        extra = sorted(set(poses) - views)
        raise InputError(
            f"{source}: no robot pose for views {missing[:5]} (poses given for {extra[:5]} instead)",
            key="--robot-poses",
            value=missing,
        )
    return {index: poses[index] for index in sorted(views)}


def calibrate_hand_eye(
    views: Sequence[DetectedView],
    transforms_hand_to_base: Mapping[int, FloatArray],
    rig: StereoRig,
    board: BoardConfig,
    settings: HandEyeSettings | None = None,
) -> HandEyeCalibration:
    """Finds X = ^H T_CR from views of a fixed board and the flange poses they were taken at.

    Args:
        views: detected views (the right image is needed, the left one is used if there).
        transforms_hand_to_base: flange pose per view number [m].
        rig: the calibrated stereo rig (intrinsics, left-right pose).
        board: the board in the images.
        settings: method, refinement, limits.

    Raises:
        CalibrationError: too few views, inconsistent scale, too little rotation.
    """
    s = settings or HandEyeSettings()
    usable = require_views(views, board, s.min_views, "a hand-eye calibration", sides=("right",))
    refused = [(v.pair.index, v.reason(("right",))) for v in views if v not in usable]
    objects = board.object_points()
    skip_left: set[int] = set()
    for _ in range(MAX_ROUNDS):
        H = [np.asarray(transforms_hand_to_base[v.pair.index], dtype=float) for v in usable]
        C = [_board_in_camera(objects[v.right.corner_ids], v.right.image_points, rig.right) for v in usable]
        A, B = motion_pairs(H, C)
        observations = _Observations(usable, objects, rig, H, skip_left)
        candidates = _closed_forms(A, B, s.method, observations)
        best = min(candidates, key=lambda m: m.reprojection_rms_px)
        X = best.transform_right_camera_to_hand
        right, left, limit = observations.outliers(X, observations.board_pose(X), s.max_view_error_px)
        skip_left |= left
        if not right:
            break
        refused += [
            (i, f"right: reprojection error {e:.2f} px (limit {limit:.2f} px)") for i, e in right.items()
        ]
        usable = [v for v in usable if v.pair.index not in right]
        if len(usable) < s.min_views:
            raise CalibrationError(
                f"too few usable views for a hand-eye calibration: {len(usable)} after refusing "
                f"{len(right)} with large reprojection errors, need {s.min_views}",
                key="--images",
                value=len(usable),
            )
    turn = _second_turn_deg(A)
    if turn < s.min_turn_deg:
        raise CalibrationError(
            f"the hand turns only {turn:.1f} deg about a second axis over the views (need "
            f"{s.min_turn_deg:.0f}): tilt and roll the hand in different directions between views",
            key="--robot-poses",
            value=round(turn, 2),
        )
    scale = 1.0 / _translation_scale(A, B, best.transform_right_camera_to_hand[:3, :3])
    if abs(scale - 1.0) > s.max_scale_error:
        raise CalibrationError(
            f"the camera moved {scale:.4g} times as far as the robot between views: the board's "
            "square_size does not match the printed board, or the robot poses are not in metres",
            key="--board",
            value=round(scale, 6),
            expected=f"1 +- {s.max_scale_error}",
        )
    methods = list(candidates)
    final, label = best, best.name
    W = observations.board_pose(best.transform_right_camera_to_hand)
    if s.refine:
        refined, W_refined = observations.refine(best.transform_right_camera_to_hand)
        methods.append(refined)
        if refined.reprojection_rms_px <= best.reprojection_rms_px:
            final, label, W = refined, f"{best.name}, refined", W_refined
    X = final.transform_right_camera_to_hand
    return HandEyeCalibration(
        X,
        W,
        label,
        tuple(methods),
        observations.residuals(X, W),
        final.reprojection_rms_px,
        scale,
        turn,
        tuple(sorted(refused)),
        tuple(sorted(skip_left)),
    )


def _closed_forms(
    A: FloatArray, B: FloatArray, method: HandEyeMethod, observations: _Observations
) -> list[MethodResult]:
    """Every asked closed form's X with its residuals."""
    candidates = []
    for name in list(HAND_EYE_METHODS) if method == "auto" else [method]:
        try:
            X = HAND_EYE_METHODS[name](A, B)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if np.all(np.isfinite(X)):
            candidates.append(observations.score(name, X))
    if not candidates:
        raise CalibrationError("no hand-eye method found a solution for these views", key="--robot-poses")
    return candidates


def _board_in_camera(objects: FloatArray, pixels: FloatArray, camera: PinholeCamera) -> FloatArray:
    """The board's pose in the camera (4x4) from its corners, by PnP."""
    K, dist = np.array(camera.camera_matrix), np.array(camera.dist_coeffs)
    ok, rvec, tvec = cv2.solvePnP(objects, pixels, K, dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        raise CalibrationError("solvePnP found no board pose in a view")
    rvec, tvec = cv2.solvePnPRefineLM(objects, pixels, K, dist, rvec, tvec)
    return make_transform(cv2.Rodrigues(rvec)[0], tvec.reshape(3))


def _second_turn_deg(A: FloatArray) -> float:
    """The hand's rotation about its second principal axis over all motions (RMS) [deg]."""
    axes = np.array([rotation_log(a[:3, :3]) for a in A])
    eigenvalues = np.linalg.eigvalsh(axes.T @ axes / len(axes))
    return float(np.degrees(np.sqrt(max(eigenvalues[-2], 0.0))))


def _translation_scale(A: FloatArray, B: FloatArray, R_X: FloatArray) -> float:
    """s of (R_A - I) t_X - s R_X t_B = -t_A, least squares: robot translations / camera ones."""
    M = np.concatenate(
        [np.hstack([a[:3, :3] - np.eye(3), -(R_X @ b[:3, 3])[:, None]]) for a, b in zip(A, B, strict=True)]
    )
    rhs = np.concatenate([-a[:3, 3] for a in A])
    return float(np.linalg.lstsq(M, rhs, rcond=None)[0][3])


class _Observations:
    """The used views' corners and flange poses; scores and refines an X against them."""

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
            poses.append(H @ X @ _board_in_camera(objects, pixels, camera))
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

    def refine(self, X0: FloatArray, iterations: int = 50) -> tuple[MethodResult, FloatArray]:
        """Levenberg-Marquardt on (X, W), 12 parameters, over every corner's pixel error."""
        W0 = self.board_pose(X0)
        p = np.r_[_vector(X0), _vector(W0)]

        def residual(q: FloatArray) -> FloatArray:
            return np.concatenate(self.errors(_transform(q[:6]), _transform(q[6:]))).ravel()

        r = residual(p)
        damping = 1e-3
        for _ in range(iterations):
            J = np.empty((r.size, p.size))
            for k in range(p.size):
                step = 1e-6 if k % 6 < 3 else 1e-7  # rotation [rad], translation [m]
                dp = np.zeros_like(p)
                dp[k] = step
                J[:, k] = (residual(p + dp) - residual(p - dp)) / (2 * step)
            g, N = J.T @ r, J.T @ J
            while True:
                delta = -np.linalg.solve(N + damping * np.diag(np.diag(N)), g)
                candidate = residual(p + delta)
                if candidate @ candidate < r @ r:
                    p, r, damping = p + delta, candidate, max(damping / 10, 1e-9)
                    break
                damping *= 10
                if damping > 1e6:
                    break
            if damping > 1e6 or np.linalg.norm(delta) < 1e-12:
                break
        X, W = _transform(p[:6]), _transform(p[6:])
        return self.score("refined", X, W), W


def _vector(T: FloatArray) -> FloatArray:
    return np.r_[cv2.Rodrigues(np.ascontiguousarray(T[:3, :3]))[0].reshape(3), T[:3, 3]]


def _transform(v: FloatArray) -> FloatArray:
    return make_transform(cv2.Rodrigues(np.asarray(v[:3], dtype=float))[0], v[3:])


__all__ = [
    "HandEyeCalibration",
    "HandEyeMethod",
    "HandEyeSettings",
    "MethodResult",
    "ViewResidual",
    "calibrate_hand_eye",
    "match_robot_poses",
]
