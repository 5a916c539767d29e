"""The matching fitness of the paper (eqs. 9-11), evaluated for a population of poses at once.

For a pose ^CR T_M the model points are projected into both images (eq. 8) and each one
scores by the hue of the pixel it lands on (nearest pixel, as in the paper):

- S_in point with model hue H_M (eq. 9): `score_in_match` (2) if the image hue is within
  `hue_threshold_in` (30) of H_M, else `score_in_background` (-0.005) if it is within 30
  of the background hue H̄_B, else `score_in_other` (0);
- S_out point (eq. 10): `score_out_background` (0.1) if the image hue is within
  `hue_threshold_out` (20) of H̄_B, else `score_out_other` (-0.5).

Hue differences are taken on the circle (HSV_FULL, 256 steps per turn). Beyond the paper,
a pixel without hue (`min_saturation`, `min_value`) has a tone, DARK or LIGHT
(`robot_app.vision.hue`), and so may an S_in point (`ModelSettings.tones`): a tone point
matches a pixel of its tone as a hue point matches its hue; a hue point on a toned
pixel, or a tone point on another tone, scores `score_in_other`; an S_out point on a
toned pixel `score_out_other`. With the defaults (`min_saturation` 0) every pixel has
its hue, as in the paper. F = (F_R + F_L) / 2
(eq. 11) is reported divided by its maximum, so that a perfect match is 1.0. Points that
fall outside an image (or behind a camera) contribute nothing to that image's sum.

Which maximum (`FitnessSettings.normalisation`):
- "model" (the paper): 2·N_in + 0.1·N_out with the default scores, over all points in
  both images. A pose that shows only part of the model can then at most reach the
  fraction of the maximum in view, so a cloth that reaches past the edge of one image
  scores below 1 at its true pose, and a smaller (farther, tilted) pose that squeezes
  more points into that image can beat the truth.
- "view" (default): the most that the points which land on the images could score,
  but not less than `min_view_fraction` of the model's maximum. A perfect match of a
  cloth partly out of view is 1.0; a pose with less than that fraction in view scores
  in proportion to the points in view.

With `hidden_foreign` (the recognizer's search uses it), a point on a pixel of a foreign
hue (neither the background's nor near any of the model's hues: a blue sheet over the
cloth, a cloth of other colours) is taken as hidden, like a point off the image: it
scores 0 and leaves the divisor. A cloth 45 % under a sheet then matches fully at its
true pose, and a smaller (farther) pose that squeezes the model into the visible part
is worse, because its S_out band lands on the cloth. Without it the smaller pose wins:
the fitness counts model points, and a smaller model fits more of them onto the visible
part.
"""

from __future__ import annotations

import functools
from typing import Literal, NamedTuple

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.errors import InputError
from robot_app.vision.camera import PinholeCamera, StereoRig
from robot_app.vision.fitness_kernels import (
    bgr_codes,
    every_colour,
    gain_levels,
    hsv_codes,
    normalised,
    score_poses,
)
from robot_app.vision.hue import COLOUR_CODES, DARK, HUE_RANGE, LIGHT, colours_match, to_hsv
from robot_app.vision.photo_model import ClothModel
from robot_app.vision.poses import AvoidedPoses, as_poses

OFF_IMAGE = COLOUR_CODES  # code of the frame around each image that off-image points read: scores 0
OUTSIDE_ROW = COLOUR_CODES  # table row of S_out points; rows 0-257 are S_in points by colour code
_COLUMNS = COLOUR_CODES + 1  # pixel codes: hues 0-255, DARK, LIGHT, OFF_IMAGE


class FitnessSettings(StrictModel):
    """Constants of eqs. 9-10; the defaults are the paper's.

    Attributes:
        score_in_match: S_in point on a pixel of its own hue.
        score_in_background: S_in point on a background-hued pixel.
        score_in_other: S_in point on any other pixel.
        score_out_background: S_out point on a background-hued pixel.
        score_out_other: S_out point on any other pixel.
        hue_threshold_in: hue tolerance of eq. 9 [HSV_FULL steps, 0-128].
        hue_threshold_out: hue tolerance of eq. 10 [HSV_FULL steps, 0-128].
        min_saturation: pixels with saturation below this (0-255) have no hue but a tone
            (DARK / LIGHT): they match neither a model hue nor the background, only model
            points of their tone. 0 (the paper) gives every pixel a hue.
        min_value: pixels with value below this (0-255) have no hue either (the
            saturation of a dark pixel is mostly noise). 0: the paper.
        value_split: a pixel without hue is DARK below this value, else LIGHT; the model's
            (`ModelSettings.value_split`) should be the same.
        score_out_foreign: S_out point on a pixel whose hue is neither background nor
            within `hue_threshold_in` of any of the model's hues (a blue sheet over a red
            cloth, a cloth of another colour). None (the paper): `score_out_other`. The
            paper's -0.5 there makes an occluder push the model away from it; the
            recognizer searches with 0 (RecognitionSettings.search_out_foreign).
        normalisation: "model" divides by the maximum of all points (the paper), "view" by
            the maximum of the points that land on the images (see the module docstring).
        min_view_fraction: with "view", the divisor is at least this fraction of the
            model's maximum.
        hidden_foreign: with "view", points on a foreign hue score 0 and leave the
            divisor (hidden, see the module docstring); `score_out_foreign` is then unused.
        model_hue_min_share: for the foreign-hue test, a model hue counts if at least this
            share of the S_in points have it.
        hidden_penalty: with "view", subtracted times the share of the model's maximum
            that is not seen (off the images or hidden). Hiding then costs a little, so a
            cloth in full view beats the same model laid over another cloth that shares
            some of its hues (whose other hues would be "hidden"); 45 % hidden under a
            sheet still beats a smaller pose squeezed onto the visible part.
    """

    score_in_match: float = Field(default=2.0, gt=0)
    score_in_background: float = -0.005
    score_in_other: float = 0.0
    score_out_background: float = Field(default=0.1, ge=0)
    score_out_other: float = -0.5
    hue_threshold_in: int = Field(default=30, ge=0, le=128)
    hue_threshold_out: int = Field(default=20, ge=0, le=128)
    min_saturation: int = Field(default=0, ge=0, le=255)
    min_value: int = Field(default=0, ge=0, le=255)
    value_split: int = Field(default=128, ge=1, le=255)
    score_out_foreign: float | None = None
    normalisation: Literal["model", "view"] = "view"
    min_view_fraction: float = Field(default=0.5, gt=0.0, le=1.0)
    hidden_foreign: bool = False
    model_hue_min_share: float = Field(default=0.01, ge=0.0, le=1.0)
    hidden_penalty: float = Field(default=0.0, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _scores_ordered(self) -> FitnessSettings:
        if self.score_in_match < max(self.score_in_background, self.score_in_other):
            raise ValueError("score_in_match must be the largest S_in score")
        if self.score_out_background < self.score_out_other:
            raise ValueError("score_out_background must be at least score_out_other")
        if self.hidden_foreign and self.normalisation != "view":
            raise ValueError('hidden_foreign needs normalisation "view"')
        return self


def score_table(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike | None = None
) -> npt.NDArray[np.float32]:
    """(259, 259) table of eqs. 9-10: row = model colour code 0-257 (hue, DARK, LIGHT) or 258
    (S_out), column = pixel code.

    Pixel codes are hues 0-255, `DARK`, `LIGHT` and `OFF_IMAGE` (always 0).

    Args:
        background_hue: H̄_B [HSV_FULL, 0-256).
        params: scores and thresholds.
        model_hues: the model's S_in colour codes; needed only for `params.score_out_foreign`
            and `params.hidden_foreign`.
    """
    codes = np.arange(COLOUR_CODES)
    d_background = _background_distance(background_hue)  # tones: never the background
    match = colours_match(codes[:, None], codes[None, :], params.hue_threshold_in)  # (model, pixel)
    table = np.zeros((COLOUR_CODES + 1, _COLUMNS), dtype=np.float32)
    inside = np.where(
        d_background <= params.hue_threshold_in, params.score_in_background, params.score_in_other
    )
    table[:COLOUR_CODES, :COLOUR_CODES] = np.where(match, params.score_in_match, inside[None, :])
    table[OUTSIDE_ROW, :COLOUR_CODES] = np.where(
        d_background <= params.hue_threshold_out, params.score_out_background, params.score_out_other
    )
    if params.score_out_foreign is not None and model_hues is not None:
        foreign = _foreign_hues(background_hue, params, model_hues, params.hue_threshold_out)
        table[OUTSIDE_ROW, :COLOUR_CODES][foreign] = params.score_out_foreign
    if params.hidden_foreign and model_hues is not None:
        table[~seen_table(background_hue, params, model_hues)] = 0.0
    return table


def seen_table(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike | None = None
) -> npt.NDArray[np.bool_]:
    """(259, 259) like `score_table`: does a point of that row on that pixel code count as seen?

    Not seen: `OFF_IMAGE`, and with `params.hidden_foreign` a foreign colour, i.e. a hue
    farther than `hue_threshold_in` from every model hue and, from the background's,
    farther than `hue_threshold_in` (S_in rows) or `hue_threshold_out` (the S_out row), or
    a tone the model does not have.

    Args:
        background_hue: H̄_B [HSV_FULL, 0-256).
        params: thresholds.
        model_hues: the model's S_in colour codes; needed for `params.hidden_foreign`.
    """
    seen = np.ones((COLOUR_CODES + 1, _COLUMNS), dtype=bool)
    seen[:, OFF_IMAGE] = False
    if params.hidden_foreign and model_hues is not None:
        seen[:COLOUR_CODES, :COLOUR_CODES] = ~_foreign_hues(
            background_hue, params, model_hues, params.hue_threshold_in
        )
        seen[OUTSIDE_ROW, :COLOUR_CODES] = ~_foreign_hues(
            background_hue, params, model_hues, params.hue_threshold_out
        )
    return seen


def _background_distance(background_hue: float) -> FloatArray:
    """(258,) distance of each colour code from H̄_B: on the circle for a hue (H̄_B may lie
    between two hues), infinite for a tone."""
    d = np.abs(np.arange(HUE_RANGE) - background_hue) % HUE_RANGE
    return np.concatenate([np.minimum(d, HUE_RANGE - d), [np.inf, np.inf]])


def _foreign_hues(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike, background_threshold: int
) -> npt.NDArray[np.bool_]:
    """(258,) colour codes neither within `background_threshold` of H̄_B nor near a model colour."""
    far_from_background = _background_distance(background_hue) > background_threshold
    return np.asarray(far_from_background & ~_near_model_hues(model_hues, params))


def foreign_codes(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """(259,) per pixel code: is it a foreign colour for an S_in point (neither within
    `hue_threshold_in` of H̄_B nor near a colour the model has; `OFF_IMAGE` counts as
    foreign)? What the verification takes as hidden."""
    return np.append(_foreign_hues(background_hue, params, model_hues, params.hue_threshold_in), True)


def _near_model_hues(model_hues: npt.ArrayLike, params: FitnessSettings) -> npt.NDArray[np.bool_]:
    """(258,) colour codes that match one the model really has: one that at least
    `model_hue_min_share` of its S_in points have (a few mixed pixels along colour edges
    would otherwise make a blue sheet "near" a cyan cloth)."""
    counts = np.bincount(np.asarray(model_hues, dtype=int).ravel(), minlength=COLOUR_CODES)[:COLOUR_CODES]
    colours = np.flatnonzero(counts >= params.model_hue_min_share * max(int(counts.sum()), 1))
    if not len(colours):  # a spread-out model: every colour it has
        colours = np.flatnonzero(counts)
    codes = np.arange(COLOUR_CODES)
    return np.asarray(colours_match(codes[:, None], colours[None, :], params.hue_threshold_in).any(axis=1))


class FitnessEvaluator:
    """Eqs. 9-11 for one model on one stereo pair; `update` swaps the pair.

    `params` define the reported fitness; `search_params` (default: the same) the one
    `evaluate(..., search=True)` scores, e.g. with `hidden_foreign` for occlusions; each
    is divided by the maximum its own `normalisation` says.

    Attributes:
        evaluations: number of poses evaluated since construction (each pose scores all
            model points in both images).
    """

    def __init__(
        self,
        model: ClothModel,
        rig: StereoRig,
        params: FitnessSettings | None = None,
        search_params: FitnessSettings | None = None,
    ) -> None:
        self.model = model
        self.rig = rig
        self.params = params if params is not None else FitnessSettings()
        self.search_params = search_params if search_params is not None else self.params
        self._table = _paired_table(model, self.params)
        self._search_table = _paired_table(model, self.search_params)
        self._columns = _COLUMNS
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

    def update(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        gains: tuple[FloatArray, FloatArray] | None = None,
    ) -> None:
        """Takes a new stereo pair (BGR uint8, the rig's image size); undistorts if the rig says so.

        Args:
            image_left_bgr, image_right_bgr: the pair.
            gains: per image, (3,) factors of the b, g, r channels that map the scene's
                exposure and white balance onto the model photo's before the colour codes
                are taken (`exposure.sheet_gains`); None: as they are.

        Raises:
            InputError: an image is not (H, W, 3) uint8 of the rig's size.
        """
        codes = []
        unit = np.ones(3)
        left_gains, right_gains = (unit, unit) if gains is None else gains
        for side, image, camera, gain in (
            ("left", image_left_bgr, self.rig.left, left_gains),
            ("right", image_right_bgr, self.rig.right, right_gains),
        ):
            array = checked_image(image, camera, side)
            codes.append(self._pixel_codes(array, camera, np.asarray(gain, dtype=float)))
        self._codes = (codes[0], codes[1])

    @property
    def codes(self) -> tuple[npt.NDArray[np.uint16], npt.NDArray[np.uint16]]:
        """The current pair's framed pixel codes (left, right), as the kernels read them
        (row stride width + 3, one frame pixel left and top)."""
        if self._codes is None:
            raise RuntimeError("no stereo pair yet: call update(left, right) first")
        return self._codes

    def _pixel_codes(
        self, image: npt.NDArray[np.uint8], camera: PinholeCamera, gains: FloatArray
    ) -> npt.NDArray[np.uint16]:
        if camera.has_distortion:
            K = camera.camera_matrix
            image = np.asarray(cv2.undistort(image, K, camera.dist_coeffs, None, K), dtype=np.uint8)
        p = self.params  # framed by OFF_IMAGE:
        table = colour_table(p.min_saturation, p.min_value, p.value_split)
        return bgr_codes(np.ascontiguousarray(image), table, OFF_IMAGE, gain_levels(gains))

    def _point_set(self, stride: int) -> _PointSet:
        """Every `stride`-th S_in and S_out point (all of them for 1), cached."""
        if stride not in self._subsets:
            m, p = self.model, self.params
            inside, outside = m.points_in[::stride], m.points_out[::stride]
            points = np.vstack([inside, outside]).astype(np.float32)
            rows = np.concatenate(
                [m.hues_in[::stride].astype(np.int32), np.full(len(outside), OUTSIDE_ROW, np.int32)]
            )
            w_in, w_out = np.asarray(m.weights_in)[::stride], np.asarray(m.weights_out)[::stride]
            best = np.concatenate([p.score_in_match * w_in, p.score_out_background * w_out])
            self._subsets[stride] = _PointSet(
                np.ascontiguousarray(points[:, 0]),
                np.ascontiguousarray(points[:, 1]),
                np.ascontiguousarray(points[:, 2]),
                np.concatenate([w_in, w_out]).astype(np.float32),
                best.astype(np.float32),
                np.ascontiguousarray(rows * np.int32(2 * self._columns), dtype=np.uint32),
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
            (P,) fitness, F(^C φ_M) / its maximum (see `FitnessSettings.normalisation`; with
            "model" that is score_in_match·N_in + score_out_background·N_out), each
            point's score weighted by the area it stands for (`ClothModel.weights_in`,
            `weights_out`; all 1 for the paper's uniform grid, which gives eqs. 9-11 exactly).

        Raises:
            InputError: no images yet (call `update`), poses of the wrong shape or a stride
                below 1.
        """
        T = np.ascontiguousarray(as_poses(transforms_model_to_right))
        arguments, normalisation = self.kernel_arguments(stride=stride, search=search)
        sums, seen = score_poses(T, *arguments, subpixel)  # type: ignore[call-arg]  # numba stub
        self.evaluations += len(sums)
        return np.asarray(normalised(sums, seen, *normalisation))

    def seen_fraction(self, transforms_model_to_right: npt.ArrayLike, *, search: bool = True) -> FloatArray:
        """(P,) share of the model's maximum score that the points seen could score at each
        pose (in view and, with `hidden_foreign`, not on a foreign colour), both images."""
        T = as_poses(transforms_model_to_right)
        arguments, normalisation = self.kernel_arguments(search=search)
        _, seen = score_poses(T, *arguments, False)  # type: ignore[call-arg]  # numba stub
        self.evaluations += len(T)
        return np.asarray(seen) / normalisation[0]

    def kernel_arguments(
        self, *, stride: int = 1, search: bool = False
    ) -> tuple[tuple[object, ...], tuple[float, bool, float, float]]:
        """What the compiled kernels need to score poses on the current pair: the arguments
        of `score_poses` after the poses (K_left ... height) and the normalisation
        (full, view, min_view_fraction, hidden_penalty) of `normalised`.

        Raises:
            InputError: no images yet (call `update`) or a stride below 1.
        """
        if self._codes is None:
            raise RuntimeError("no stereo pair to evaluate on: call update(left, right) first")
        if stride < 1:
            raise ValueError(f"stride must be a positive integer, got {stride}")
        width, height = self.rig.image_size
        points = self._point_set(int(stride))
        params = self.search_params if search else self.params
        arguments = (
            self.rig.left.camera_matrix,
            self.rig.right.camera_matrix,
            self._left_from_right,
            points.x,
            points.y,
            points.z,
            points.weights,
            points.best,
            points.row_offsets,
            self._search_table if search else self._table,
            self._codes[0],
            self._codes[1],
            width,
            height,
        )
        view = params.normalisation == "view"
        return arguments, (2.0 * points.maximum, view, params.min_view_fraction, params.hidden_penalty)


class KernelFitness:
    """The fitness of one evaluator at one stride as a function of poses: what the search
    stages optimise. The compiled loops (the GA's `ga_kernels.evolve`, the refinement's
    `cma_run` and `compass_run`) run it inside from its `kernel_arguments` instead of
    calling it once per step: same scores, bit for bit, without the Python overhead.

    Args:
        evaluator: the evaluator (its current stereo pair is read at each call).
        stride: score every `stride`-th model point.
        search: score with the evaluator's search parameters.
        subpixel: the bilinear-score fitness (see `FitnessEvaluator.evaluate`).
        avoid: poses that score -1 (and that the refinement does not visit); None: none.
    """

    def __init__(
        self,
        evaluator: FitnessEvaluator,
        *,
        stride: int = 1,
        search: bool = False,
        subpixel: bool = False,
        avoid: AvoidedPoses | None = None,
    ) -> None:
        if stride < 1:
            raise ValueError(f"stride must be a positive integer, got {stride}")
        self.evaluator = evaluator
        self.stride = stride
        self.search = search
        self.subpixel = subpixel
        self.avoid = avoid if avoid is not None else AvoidedPoses.none()

    def __call__(self, transforms_model_to_right: npt.ArrayLike) -> FloatArray:
        """(P,) normalised fitness of (P, 4, 4) poses (see `FitnessEvaluator.evaluate`), -1
        where avoided."""
        scores = self.evaluator.evaluate(
            transforms_model_to_right, stride=self.stride, subpixel=self.subpixel, search=self.search
        )
        if len(self.avoid.centres):
            scores[self.avoid.mask(transforms_model_to_right)] = -1.0
        return scores

    def kernel_arguments(self) -> tuple[tuple[object, ...], tuple[float, bool, float, float]]:
        """See `FitnessEvaluator.kernel_arguments` (the kernels take `subpixel` and `avoid` apart)."""
        return self.evaluator.kernel_arguments(stride=self.stride, search=self.search)

    def count(self, poses: int) -> None:
        """Adds poses scored inside a compiled loop to the evaluator's `evaluations`."""
        self.evaluator.evaluations += int(poses)


@functools.lru_cache(maxsize=4)
def colour_table(min_saturation: int, min_value: int, value_split: int) -> npt.NDArray[np.uint16]:
    """(2^24,) read-only: the pixel code (`hue.colour_codes` of `hue.to_hsv`) of every BGR
    colour, at index b << 16 | g << 8 | r; built once per process and thresholds (about
    0.2 s, 32 MB) from OpenCV's own conversion of an image of all colours."""
    hsv = to_hsv(every_colour())
    framed = hsv_codes(hsv, min_saturation, min_value, value_split, DARK, LIGHT, OFF_IMAGE)
    table = np.ascontiguousarray(framed.reshape(4096 + 3, 4096 + 3)[1:-2, 1:-2]).ravel()
    table.setflags(write=False)
    return table


def checked_image(image: npt.ArrayLike, camera: PinholeCamera, side: str) -> npt.NDArray[np.uint8]:
    """`image` as an (H, W, 3) uint8 array of `camera`'s size.

    Raises:
        InputError: another type or size (the message names `side` and both sizes).
    """
    array = np.asarray(image)
    width, height = camera.image_size
    if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
        raise InputError(
            f"{side} image must be an (H, W, 3) uint8 BGR image, got {array.shape} {array.dtype}"
        )
    if array.shape[:2] != (height, width):
        raise InputError(
            f"{side} image is {array.shape[1]}x{array.shape[0]} px but the rig expects {width}x{height} px"
        )
    return array


def _paired_table(model: ClothModel, params: FitnessSettings) -> npt.NDArray[np.float32]:
    """The flat (score, seen) table the kernels read: entry 2 (row · columns + code) is the score."""
    scores = score_table(model.background_hue, params, model.hues_in)
    seen = seen_table(model.background_hue, params, model.hues_in)
    return np.ascontiguousarray(np.stack([scores, seen.astype(np.float32)], axis=-1).ravel())


class _PointSet(NamedTuple):
    x: npt.NDArray[np.float32]
    y: npt.NDArray[np.float32]
    z: npt.NDArray[np.float32]
    weights: npt.NDArray[np.float32]
    best: npt.NDArray[np.float32]  # weight x the highest score of the point's row
    row_offsets: npt.NDArray[np.uint32]
    maximum: float  # score of a perfect match in one image


__all__ = [
    "OFF_IMAGE",
    "OUTSIDE_ROW",
    "FitnessEvaluator",
    "FitnessSettings",
    "KernelFitness",
    "checked_image",
    "colour_table",
    "foreign_codes",
    "score_table",
    "seen_table",
]
