"""The matching fitness of the paper (eqs. 9-11), evaluated for a population of poses at once.

For a pose ^CR T_M the model points are projected into both images (eq. 8) and each one
scores by the hue of the pixel it lands on (nearest pixel, as in the paper):

- S_in point with model hue H_M (eq. 9): `score_in_match` (2) if the image hue is within
  `hue_threshold_in` (30) of H_M, else `score_in_background` (-0.005) if it is within 30
  of the background hue H̄_B, else `score_in_other` (0);
- S_out point (eq. 10): `score_out_background` (0.1) if the image hue is within
  `hue_threshold_out` (20) of H̄_B, else `score_out_other` (-0.5).

Hue differences are taken on the circle (HSV_FULL, 256 steps per turn). F = (F_R + F_L) / 2
(eq. 11) is reported divided by its maximum, 2·N_in + 0.1·N_out with the default scores,
so a perfect match is 1.0. Points that fall outside an image (or behind a camera)
contribute nothing to that image's sum, so a pose that shows only part of the model can
at most reach the fraction of the maximum that is in view.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field, model_validator

from robot_app.config import StrictModel
from robot_app.errors import InputError
from robot_app.geometry import FloatArray
from robot_app.vision._kernels import hsv_codes, score_poses
from robot_app.vision.camera import PinholeCamera, StereoRig
from robot_app.vision.hue import HUE_RANGE, hue_distance, to_hsv
from robot_app.vision.photo_model import ClothModel

NO_HUE = HUE_RANGE  # pixel code of a pixel too grey to have a hue (see min_saturation)
OFF_IMAGE = HUE_RANGE + 1  # code of the frame around each image that off-image points read: scores 0
_OUTSIDE_ROW = HUE_RANGE  # table row of S_out points; rows 0-255 are S_in points by model hue


class FitnessParams(StrictModel):
    """Constants of eqs. 9-10; the defaults are the paper's.

    Attributes:
        score_in_match: S_in point on a pixel of its own hue.
        score_in_background: S_in point on a background-hued pixel.
        score_in_other: S_in point on any other pixel.
        score_out_background: S_out point on a background-hued pixel.
        score_out_other: S_out point on any other pixel.
        hue_threshold_in: hue tolerance of eq. 9 [HSV_FULL steps, 0-128].
        hue_threshold_out: hue tolerance of eq. 10 [HSV_FULL steps, 0-128].
        min_saturation: pixels with saturation below this (0-255) have no hue: they match
            neither a model hue nor the background. 0 (the paper) gives every pixel a hue.
        score_out_foreign: S_out point on a pixel whose hue is neither background nor
            within `hue_threshold_in` of any of the model's hues (a blue sheet over a red
            cloth, a cloth of another colour). None (the paper): `score_out_other`. The
            paper's -0.5 there makes an occluder push the model away from it; the
            recognizer searches with 0 (RecognitionSettings.search_out_foreign).
    """

    score_in_match: float = Field(default=2.0, gt=0)
    score_in_background: float = -0.005
    score_in_other: float = 0.0
    score_out_background: float = Field(default=0.1, ge=0)
    score_out_other: float = -0.5
    hue_threshold_in: int = Field(default=30, ge=0, le=128)
    hue_threshold_out: int = Field(default=20, ge=0, le=128)
    min_saturation: int = Field(default=0, ge=0, le=255)
    score_out_foreign: float | None = None

    @model_validator(mode="after")
    def _scores_ordered(self) -> FitnessParams:
        if self.score_in_match < max(self.score_in_background, self.score_in_other):
            raise ValueError("score_in_match must be the largest S_in score")
        if self.score_out_background < self.score_out_other:
            raise ValueError("score_out_background must be at least score_out_other")
        return self


def score_table(
    background_hue: float, params: FitnessParams, model_hues: npt.ArrayLike | None = None
) -> npt.NDArray[np.float32]:
    """(257, 258) table of eqs. 9-10: row = model hue 0-255 or 256 (S_out), column = pixel code.

    Pixel codes are hues 0-255, `NO_HUE` and `OFF_IMAGE` (always 0).

    Args:
        background_hue: H̄_B [HSV_FULL, 0-256).
        params: scores and thresholds.
        model_hues: the model's S_in hues; needed only for `params.score_out_foreign`.
    """
    codes = np.arange(HUE_RANGE)
    d_background = np.abs(codes - background_hue) % HUE_RANGE
    d_background = np.minimum(d_background, HUE_RANGE - d_background)
    d_model = hue_distance(codes[:, None], codes[None, :])  # (model hue, pixel hue)
    table = np.zeros((HUE_RANGE + 1, HUE_RANGE + 2), dtype=np.float32)
    inside = np.where(
        d_background <= params.hue_threshold_in, params.score_in_background, params.score_in_other
    )
    table[:HUE_RANGE, :HUE_RANGE] = np.where(
        d_model <= params.hue_threshold_in, params.score_in_match, inside[None, :]
    )
    table[:HUE_RANGE, NO_HUE] = params.score_in_other
    table[_OUTSIDE_ROW, :HUE_RANGE] = np.where(
        d_background <= params.hue_threshold_out, params.score_out_background, params.score_out_other
    )
    table[_OUTSIDE_ROW, NO_HUE] = params.score_out_other
    if params.score_out_foreign is not None and model_hues is not None:
        hues = np.unique(np.asarray(model_hues, dtype=int))
        near_model = (hue_distance(codes[:, None], hues[None, :]) <= params.hue_threshold_in).any(axis=1)
        foreign = (d_background > params.hue_threshold_out) & ~near_model
        table[_OUTSIDE_ROW, :HUE_RANGE][foreign] = params.score_out_foreign
    return table


class FitnessEvaluator:
    """Eqs. 9-11 for one model on one stereo pair; `update` swaps the pair.

    `params` define the reported fitness; `search_params` (default: the same) the one
    `evaluate(..., search=True)` scores, e.g. with `score_out_foreign` for occlusions.
    The normalisation is the same for both.

    Attributes:
        evaluations: number of poses evaluated since construction (each pose scores all
            model points in both images).
    """

    def __init__(
        self,
        model: ClothModel,
        rig: StereoRig,
        params: FitnessParams | None = None,
        search_params: FitnessParams | None = None,
    ) -> None:
        self.model = model
        self.rig = rig
        self.params = params if params is not None else FitnessParams()
        self.search_params = search_params if search_params is not None else self.params
        table = score_table(model.background_hue, self.params, model.hues_in)
        self._table = np.ascontiguousarray(table.ravel())
        search_table = score_table(model.background_hue, self.search_params, model.hues_in)
        self._search_table = np.ascontiguousarray(search_table.ravel())
        self._columns = table.shape[1]
        self._subsets: dict[int, _PointSet] = {}
        self._full = self._point_set(1)
        self._left_from_right = np.ascontiguousarray(rig.transform_right_to_left)
        self._codes: tuple[npt.NDArray[np.uint16], npt.NDArray[np.uint16]] | None = None
        self.evaluations = 0

    @property
    def n_points(self) -> int:
        """Model points scored per image and pose (N_in + N_out)."""
        return len(self._full.x)

    @property
    def point_evaluations(self) -> int:
        """Point projections and look-ups done so far (poses x points x 2 images)."""
        return self.evaluations * self.n_points * 2

    def update(self, image_left_bgr: npt.NDArray[np.uint8], image_right_bgr: npt.NDArray[np.uint8]) -> None:
        """Takes a new stereo pair (BGR uint8, the rig's image size); undistorts if the rig says so.

        Raises:
            InputError: an image is not (H, W, 3) uint8 of the rig's size.
        """
        codes = []
        for side, image, camera in (
            ("left", image_left_bgr, self.rig.left),
            ("right", image_right_bgr, self.rig.right),
        ):
            array = np.asarray(image)
            width, height = camera.image_size
            if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
                raise InputError(
                    f"{side} image must be an (H, W, 3) uint8 BGR image, got {array.shape} {array.dtype}"
                )
            if array.shape[:2] != (height, width):
                raise InputError(
                    f"{side} image is {array.shape[1]}x{array.shape[0]} px but the rig expects "
                    f"{width}x{height} px"
                )
            codes.append(self._pixel_codes(array, camera))
        self._codes = (codes[0], codes[1])

    def _pixel_codes(self, image: npt.NDArray[np.uint8], camera: PinholeCamera) -> npt.NDArray[np.uint16]:
        if camera.has_distortion:
            K = camera.camera_matrix
            image = np.asarray(cv2.undistort(image, K, camera.dist_coeffs, None, K), dtype=np.uint8)
        hsv = to_hsv(image)
        return hsv_codes(hsv, self.params.min_saturation, NO_HUE, OFF_IMAGE)  # framed by OFF_IMAGE

    def _point_set(self, stride: int) -> _PointSet:
        """Every `stride`-th S_in and S_out point (all of them for 1), cached."""
        if stride not in self._subsets:
            m, p = self.model, self.params
            inside, outside = m.points_in[::stride], m.points_out[::stride]
            points = np.vstack([inside, outside]).astype(np.float32)
            rows = np.concatenate(
                [m.hues_in[::stride].astype(np.int32), np.full(len(outside), _OUTSIDE_ROW, np.int32)]
            )
            w_in, w_out = np.asarray(m.weights_in)[::stride], np.asarray(m.weights_out)[::stride]
            self._subsets[stride] = _PointSet(
                np.ascontiguousarray(points[:, 0]),
                np.ascontiguousarray(points[:, 1]),
                np.ascontiguousarray(points[:, 2]),
                np.concatenate([w_in, w_out]).astype(np.float32),
                np.ascontiguousarray(rows * np.int32(self._columns)),
                p.score_in_match * float(w_in.sum()) + p.score_out_background * float(w_out.sum()),
            )
        return self._subsets[stride]

    def evaluate(
        self,
        transforms_model_to_right: npt.ArrayLike,
        *,
        subpixel: bool = False,
        stride: int = 1,
        search: bool = False,
    ) -> FloatArray:
        """Normalised fitness of each pose (1.0 = perfect match).

        Args:
            transforms_model_to_right: (P, 4, 4) or (4, 4) poses ^CR T_M [m].
            subpixel: interpolate each point's score between its four neighbouring pixels
                (smooth in the pose, for refinement) instead of the paper's nearest pixel.
            stride: score only every `stride`-th S_in and S_out point (a cheaper, noisier
                estimate of the same normalised fitness, for early GA generations).
            search: score with `search_params` instead of `params`.

        Returns:
            (P,) fitness, F(^C φ_M) / (score_in_match·N_in + score_out_background·N_out),
            each point's score weighted by the area it stands for (`ClothModel.weights_in`,
            `weights_out`; all 1 for the paper's uniform grid, which gives eqs. 9-11 exactly).

        Raises:
            InputError: no images yet (call `update`) or poses of the wrong shape.
        """
        if self._codes is None:
            raise InputError("no stereo pair to evaluate on: call update(left, right) first")
        T = np.ascontiguousarray(_as_poses(transforms_model_to_right))
        width, height = self.rig.image_size
        if stride < 1:
            raise InputError(f"stride must be a positive integer, got {stride}")
        points = self._point_set(int(stride))
        codes_left, codes_right = self._codes
        sums = score_poses(
            T,
            self.rig.left.camera_matrix,
            self.rig.right.camera_matrix,
            self._left_from_right,
            points.x,
            points.y,
            points.z,
            points.weights,
            points.row_offsets,
            self._search_table if search else self._table,
            codes_left,
            codes_right,
            width,
            height,
            subpixel,
        )
        self.evaluations += len(sums)
        return sums / (2.0 * points.maximum)


class _PointSet(NamedTuple):
    x: npt.NDArray[np.float32]
    y: npt.NDArray[np.float32]
    z: npt.NDArray[np.float32]
    weights: npt.NDArray[np.float32]
    row_offsets: npt.NDArray[np.int32]
    maximum: float  # score of a perfect match in one image


def _as_poses(transforms: npt.ArrayLike) -> FloatArray:
    T = np.asarray(transforms, dtype=float)
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"poses must have shape (P, 4, 4) or (4, 4), got {T.shape}")
    return T


__all__ = ["NO_HUE", "OFF_IMAGE", "FitnessEvaluator", "FitnessParams", "score_table"]
