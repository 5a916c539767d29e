"""Hand-eye calibration: where the right camera sits on the hand, from a fixed board.

The arm stops at several poses over a board that does not move; at each, the robot
reports its flange pose H_i (Σ_H in the base) and the right camera sees the board (C_i,
board in the camera, from `cv2.solvePnP` with the calibrated intrinsics). Then
H_i X C_i is the same board pose W for every view, which fixes X = ^H T_CR.

How X is found: the three closed-form methods (Tsai-Lenz, Park-Martin, Daniilidis) are
run on every pair of views and scored by the reprojection error their X gives (board
pose W averaged over the views, then the board's corners projected into every image);
the best one starts a least-squares refinement of X and W over the pixel errors of both
cameras, which weighs each view by what its image really measured instead of by its
pose's noise. With `refine_rig` (the default) that fit also frees both cameras'
intrinsics and the stereo pose: the flange poses are metric, so views at several depths
measure the focal lengths better than the stereo calibration's board foreshortening did,
and a focal length error no longer lands in X along the optical axis (see
hand_eye_residuals). It is used when the boards' depths differ enough to separate focal
length from depth (`min_depth_ratio`) and the rig moves no further than a calibration's
error (`max_focal_change`); else only X and W are refined, and the result says why.
`method` can force one closed form and `refine` switch the last step off.

Checks that make bad input an error rather than a wrong X: the robot's translations and
the camera's must agree in scale (a board file with the wrong square size, poses in
millimetres), and the hand must turn about at least two different axes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import combinations
from typing import Literal

import numpy as np
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig
from robot_app.calibration.detection import DetectionSettings
from robot_app.calibration.files import ImagePair
from robot_app.calibration.hand_eye_methods import HAND_EYE_METHODS, motion_pairs, rotation_log
from robot_app.calibration.hand_eye_residuals import (
    BoardObservations,
    MethodResult,
    ViewResidual,
    board_in_camera,
)
from robot_app.calibration.views import DetectedView, require_views
from robot_app.config import StrictModel
from robot_app.errors import CalibrationError, InputError
from robot_app.vision.camera import StereoRig

HandEyeMethod = Literal["auto", "tsai", "park", "daniilidis"]
MAX_ROUNDS = 3


class HandEyeSettings(StrictModel):
    """Choices and limits of `robot-app calibrate hand-eye`."""

    detection: DetectionSettings = DetectionSettings()
    min_views: int = Field(6, ge=3, description="fewest usable views")
    method: HandEyeMethod = Field("auto", description="closed form to start from; auto = lowest residual")
    refine: bool = Field(True, description="refine X and the board pose over the pixel errors")
    refine_rig: bool = Field(
        True, description="refine the cameras' intrinsics and the stereo pose with X (robot-aided)"
    )
    min_depth_ratio: float = Field(
        1.2, ge=1.0, description="refine the rig only if the farthest board is this many times the nearest"
    )
    max_focal_change: float = Field(
        0.01, gt=0.0, lt=0.2, description="keep the given rig if the refinement moves a focal length more"
    )
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
        rig: the rig with X: intrinsics and stereo pose refined with X, or as given.
        rig_note: why the rig was (not) refined, one line.
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
    left_unused: tuple[int, ...]
    rig: StereoRig
    rig_note: str


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
    turn = _second_turn_deg([transforms_hand_to_base[v.pair.index] for v in usable])
    if turn < s.min_turn_deg:
        raise CalibrationError(
            f"the hand turns only {turn:.1f} deg about a second axis over the views (need "
            f"{s.min_turn_deg:.0f}): tilt and roll the hand in different directions between views",
            key="--robot-poses",
            value=round(turn, 2),
        )
    skip_left: set[int] = set()
    for _ in range(MAX_ROUNDS):
        H = [np.asarray(transforms_hand_to_base[v.pair.index], dtype=float) for v in usable]
        C = [board_in_camera(objects[v.right.corner_ids], v.right.image_points, rig.right) for v in usable]
        A, B = motion_pairs(H, C)
        observations = BoardObservations(usable, objects, rig, H, skip_left)
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
    calibrated = replace(rig, transform_right_camera_to_hand=best.transform_right_camera_to_hand)
    note = "rig as given (no refinement)"
    if s.refine:
        refined, W_refined, _ = observations.refine(best.transform_right_camera_to_hand)
        methods.append(refined)
        if refined.reprojection_rms_px <= best.reprojection_rms_px:
            final, label, W = refined, f"{best.name}, refined", W_refined
            calibrated = replace(rig, transform_right_camera_to_hand=refined.transform_right_camera_to_hand)
            note = "rig as given (refine_rig off)"
        if s.refine_rig:
            with_rig, W_with_rig, rig_refined = observations.refine(
                final.transform_right_camera_to_hand, with_rig=True
            )
            methods.append(with_rig)
            note = _rig_refinement_note(observations.depth_ratio(), rig, rig_refined, s)
            if not note:
                final, label, W = with_rig, f"{best.name}, refined with the rig", W_with_rig
                calibrated, observations = rig_refined, observations.with_rig(rig_refined)
                note = _rig_change(rig, rig_refined)
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
        calibrated,
        note,
    )


def _rig_refinement_note(depth_ratio: float, rig: StereoRig, refined: StereoRig, s: HandEyeSettings) -> str:
    """Why the refined rig is not used ('' when it is)."""
    if depth_ratio < s.min_depth_ratio:
        return (
            f"rig as given: the boards' depths differ by a factor {depth_ratio:.2f} only "
            f"(min_depth_ratio {s.min_depth_ratio}): too little to tell focal length from depth"
        )
    change = _largest_focal_change(rig, refined)
    if change > s.max_focal_change:
        return (
            f"rig as given: refining it with X moved a focal length by {100 * change:.2f} % "
            f"(max_focal_change {100 * s.max_focal_change:.2f} %): the robot poses and the rig disagree"
        )
    return ""


def _focal_changes(rig: StereoRig, refined: StereoRig) -> dict[str, float]:
    """Relative change of each focal length, e.g. {'left fx': 0.0012}."""
    return {
        f"{side} f{axis}": getattr(refined, side).camera_matrix[i, i] / getattr(rig, side).camera_matrix[i, i]
        - 1
        for side in ("left", "right")
        for i, axis in ((0, "x"), (1, "y"))
    }


def _largest_focal_change(rig: StereoRig, refined: StereoRig) -> float:
    return max(abs(c) for c in _focal_changes(rig, refined).values())


def _rig_change(rig: StereoRig, refined: StereoRig) -> str:
    """One line: how the refinement moved the rig's focal lengths and baseline."""
    focal = ", ".join(f"{name} {100 * c:+.3f} %" for name, c in _focal_changes(rig, refined).items())
    return f"rig refined with X: {focal}; baseline {1000 * (refined.baseline - rig.baseline):+.3f} mm"


def _closed_forms(
    A: FloatArray, B: FloatArray, method: HandEyeMethod, observations: BoardObservations
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


def _second_turn_deg(transforms_hand_to_base: Sequence[FloatArray]) -> float:
    """How far the hand turned about its second principal axis between views (RMS) [deg]."""
    H = [np.asarray(T, dtype=float) for T in transforms_hand_to_base]
    axes = np.array([rotation_log(H[j][:3, :3].T @ H[i][:3, :3]) for i, j in combinations(range(len(H)), 2)])
    eigenvalues = np.linalg.eigvalsh(axes.T @ axes / len(axes))
    return float(np.degrees(np.sqrt(max(eigenvalues[-2], 0.0))))


def _translation_scale(A: FloatArray, B: FloatArray, R_X: FloatArray) -> float:
    """s of (R_A - I) t_X - s R_X t_B = -t_A, least squares: robot translations / camera ones."""
    M = np.concatenate(
        [np.hstack([a[:3, :3] - np.eye(3), -(R_X @ b[:3, 3])[:, None]]) for a, b in zip(A, B, strict=True)]
    )
    rhs = np.concatenate([-a[:3, 3] for a in A])
    return float(np.linalg.lstsq(M, rhs, rcond=None)[0][3])


__all__ = [
    "HandEyeCalibration",
    "HandEyeMethod",
    "HandEyeSettings",
    "calibrate_hand_eye",
    "match_robot_poses",
]
