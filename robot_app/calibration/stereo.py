"""Stereo calibration: both cameras' intrinsics and distortion and their relative pose.

Each camera is calibrated alone first (`cv2.calibrateCamera`, Zhang's method from the
board views), then both together (`cv2.stereoCalibrate` from those intrinsics), which
also gives R, T with X_right = R @ X_left + T, the rig file's convention. Views whose
reprojection error stands out (a misdetected corner, a moving board) are refused with
their error and the calibration is run again without them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.calibration.board import BoardConfig
from robot_app.calibration.detection import DetectionSettings
from robot_app.calibration.views import DetectedView, require_views
from robot_app.config import StrictModel
from robot_app.errors import CalibrationError
from robot_app.geometry import make_transform
from robot_app.vision.camera import PinholeCamera, StereoRig

CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
MAX_ROUNDS = 3


class StereoCalibrationSettings(StrictModel):
    """Limits of `robot-app calibrate stereo`."""

    detection: DetectionSettings = DetectionSettings()
    min_views: int = Field(10, ge=3, description="fewest usable image pairs")
    fit_k3: bool = Field(False, description="fit the 6th-order radial term (wide-angle lenses only)")
    max_view_error_px: float = Field(
        1.0, gt=0.0, description="refuse a view whose RMS error is above this and 3x the median [px]"
    )


@dataclass(frozen=True)
class ViewError:
    """A used view's RMS reprojection error in each camera [px] (None: not used in that camera)."""

    index: int
    left_px: float | None
    right_px: float | None

    @property
    def worst_px(self) -> float:
        return max(e for e in (self.left_px, self.right_px) if e is not None)


@dataclass(frozen=True)
class CameraFit:
    """One camera's intrinsics with their standard deviations.

    Attributes:
        camera: intrinsics and distortion.
        std_fx_fy_cx_cy: 1-σ uncertainty of fx, fy, cx, cy [px] from the lone calibration.
        rms_px: RMS reprojection error of the lone calibration [px].
    """

    camera: PinholeCamera
    std_fx_fy_cx_cy: tuple[float, float, float, float]
    rms_px: float


@dataclass(frozen=True)
class StereoCalibration:
    """The result of `calibrate_stereo`.

    Attributes:
        rig: the calibrated rig (no camera-to-hand transform).
        rms_px: RMS reprojection error over both cameras and all used views [px].
        left, right: each camera's lone calibration.
        view_errors: per used view (a view with the board in one image only is used
            for that camera's intrinsics alone).
        refused: (view number, reason) for each view left out, detection or error.
        views: every view as detected (for the coverage picture).
    """

    rig: StereoRig
    rms_px: float
    left: CameraFit
    right: CameraFit
    view_errors: tuple[ViewError, ...]
    refused: tuple[tuple[int, str], ...]
    views: tuple[DetectedView, ...]

    @property
    def used(self) -> tuple[int, ...]:
        return tuple(v.index for v in self.view_errors)


def calibrate_stereo(
    views: Sequence[DetectedView],
    board: BoardConfig,
    image_size: tuple[int, int],
    settings: StereoCalibrationSettings | None = None,
) -> StereoCalibration:
    """Calibrates the stereo pair from detected board views.

    Each camera is calibrated from every view it saw the board in; the stereo pose
    from the views both saw it in (with the intrinsics held when some views saw it in
    one camera only, so that their coverage is kept, else refined together).

    Args:
        views: every image pair with its detections (`detect_views`).
        board: the board in the images.
        image_size: (width, height) [px] of all images.
        settings: minimum view count, distortion model, outlier limit.

    Raises:
        CalibrationError: too few views with the board in both images, or OpenCV failed.
    """
    s = settings or StereoCalibrationSettings()
    require_views(views, board, s.min_views, "a stereo calibration")
    usable = [v for v in views if v.usable(("left",)) or v.usable(("right",))]
    refused: list[tuple[int, str]] = [(v.pair.index, v.reason()) for v in views if v not in usable]
    flags = 0 if s.fit_k3 else cv2.CALIB_FIX_K3
    for _ in range(MAX_ROUNDS):
        result = _calibrate(usable, board, image_size, flags)
        errors = [e.worst_px for e in result[3]]
        limit = max(s.max_view_error_px, 3.0 * float(np.median(errors)))
        outliers = {e.index: e.worst_px for e in result[3] if e.worst_px > limit}
        if not outliers:
            break
        refused += [(i, f"reprojection error {e:.2f} px (limit {limit:.2f} px)") for i, e in outliers.items()]
        usable = [v for v in usable if v.pair.index not in outliers]
        pairs = sum(v.usable() for v in usable)
        if pairs < s.min_views:
            raise CalibrationError(
                f"too few usable views for a stereo calibration: {pairs} after refusing "
                f"{len(outliers)} with large reprojection errors, need {s.min_views}",
                key="--images",
                value=pairs,
            )
    rig, rms, (left, right), view_errors = result
    return StereoCalibration(rig, rms, left, right, tuple(view_errors), tuple(sorted(refused)), tuple(views))


def _calibrate(
    views: list[DetectedView], board: BoardConfig, image_size: tuple[int, int], flags: int
) -> tuple[StereoRig, float, tuple[CameraFit, CameraFit], list[ViewError]]:
    objects = board.object_points().astype(np.float32)
    mono_errors: dict[str, dict[int, float]] = {}
    fits = []
    for side in ("left", "right"):
        seen = [v for v in views if v.usable((side,))]
        detections = [v.side(side) for v in seen]
        fit, view_rms = _calibrate_one(
            [objects[d.corner_ids] for d in detections],
            [d.image_points.astype(np.float32).reshape(-1, 1, 2) for d in detections],
            image_size,
            flags,
        )
        fits.append(fit)
        mono_errors[side] = {v.pair.index: e for v, e in zip(seen, view_rms, strict=True)}
    left, right = fits
    pairs = [v for v in views if v.usable()]
    object_points, left_points, right_points = [], [], []
    for view in pairs:
        ids, left_pixels, right_pixels = view.common_corners()
        object_points.append(objects[ids])
        left_points.append(left_pixels.astype(np.float32).reshape(-1, 1, 2))
        right_points.append(right_pixels.astype(np.float32).reshape(-1, 1, 2))
    one_sided = len(pairs) < len(views)
    stereo_flags = flags | (cv2.CALIB_FIX_INTRINSIC if one_sided else cv2.CALIB_USE_INTRINSIC_GUESS)
    try:
        rms, K1, d1, K2, d2, R, T, *_rest, per_view = cv2.stereoCalibrateExtended(
            object_points,
            left_points,
            right_points,
            np.array(left.camera.camera_matrix),
            np.array(left.camera.dist_coeffs),
            np.array(right.camera.camera_matrix),
            np.array(right.camera.dist_coeffs),
            image_size,
            np.eye(3),
            np.zeros((3, 1)),
            flags=stereo_flags,
            criteria=CRITERIA,
        )
    except cv2.error as err:
        raise CalibrationError(f"OpenCV's stereo calibration failed on these views: {err.err}") from err
    R = _nearest_rotation(np.asarray(R, dtype=float))
    rig = StereoRig(
        PinholeCamera(np.asarray(K1, float), image_size, np.asarray(d1, float).reshape(-1)[:5]),
        PinholeCamera(np.asarray(K2, float), image_size, np.asarray(d2, float).reshape(-1)[:5]),
        make_transform(R, np.asarray(T, dtype=float).reshape(3)),
    )
    stereo_errors = {
        v.pair.index: e for v, e in zip(pairs, np.asarray(per_view, float).reshape(-1, 2), strict=True)
    }
    errors = []
    for view in views:
        i = view.pair.index
        if i in stereo_errors:
            errors.append(ViewError(i, float(stereo_errors[i][0]), float(stereo_errors[i][1])))
        else:
            errors.append(ViewError(i, mono_errors["left"].get(i), mono_errors["right"].get(i)))
    return rig, float(rms), (left, right), errors


def _calibrate_one(
    object_points: list[np.ndarray], image_points: list[np.ndarray], image_size: tuple[int, int], flags: int
) -> tuple[CameraFit, list[float]]:
    try:
        rms, K, dist, _, _, std, _, per_view = cv2.calibrateCameraExtended(
            object_points, image_points, image_size, np.eye(3), np.zeros(5), flags=flags, criteria=CRITERIA
        )
    except cv2.error as err:
        raise CalibrationError(f"OpenCV's camera calibration failed on these views: {err.err}") from err
    std = np.asarray(std, dtype=float).reshape(-1)
    camera = PinholeCamera(np.asarray(K, dtype=float), image_size, np.asarray(dist, float).reshape(-1)[:5])
    fit = CameraFit(camera, (float(std[0]), float(std[1]), float(std[2]), float(std[3])), float(rms))
    return fit, [float(e) for e in np.asarray(per_view, dtype=float).reshape(-1)]


def _nearest_rotation(R: FloatArray) -> FloatArray:
    U, _, Vt = np.linalg.svd(R)
    return np.asarray(U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt, dtype=float)


__all__ = ["CameraFit", "StereoCalibration", "StereoCalibrationSettings", "ViewError", "calibrate_stereo"]
