"""The matching fitness of the paper (eq. 11), evaluated for a population of poses at once.

Each model point scores by `fitness_scores.py` (eqs. 9-10) at the pixel it lands on
(`pixel_codes.py`); F = (F_R + F_L) / 2 (eq. 11) is reported divided by its maximum, so
that a perfect match is 1.0. Points that fall outside an image (or behind a camera)
contribute nothing to that image's sum.

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

With `hidden_foreign` (the recognizer's search uses it) a point on a foreign colour is
hidden: it scores 0 and leaves the divisor. A cloth 45 % under a sheet then matches fully
at its true pose, and a smaller (farther) pose that squeezes the model into the visible
part is worse, because its S_out band lands on the cloth. Without it the smaller pose
wins: the fitness counts model points, and a smaller model fits more of them onto the
visible part.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import NamedTuple, cast

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.camera import StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.exposure import Shading
from robot_app.vision.fitness_kernels import normalised, score_poses
from robot_app.vision.fitness_scores import (
    COLUMNS,
    OFF_IMAGE,
    OUTSIDE_ROW,
    FitnessSettings,
    score_table,
    seen_table,
)
from robot_app.vision.pixel_codes import box_spans, checked_image, pixel_codes
from robot_app.vision.poses import AvoidedPoses, as_poses


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
        self._columns = COLUMNS
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
        regions: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None = None,
        shading: tuple[Shading | None, Shading | None] | None = None,
    ) -> None:
        """Takes a new stereo pair (BGR uint8, the rig's image size); undistorts if the rig says so.

        Args:
            image_left_bgr, image_right_bgr: the pair.
            gains: per image, (3,) factors of the b, g, r channels that map the scene's
                exposure and white balance onto the model photo's before the colour codes
                are taken (`exposure.sheet_gains`); None: as they are.
            regions: per image, (H, 2) int64 row spans (first and last column of each row,
                inclusive; `pixel_codes.box_spans` of a box): only pixels there get a code,
                the others count as off the image (a tracking frame's search cannot reach
                them, `tracking_window.reachable_regions`); None: the whole images.
            shading: per image, the light's factor per block on top of `gains`
                (`exposure.scene_exposure`); None: even light.

        Raises:
            InputError: an image is not (H, W, 3) uint8 of the rig's size.
        """
        codes = []
        unit = np.ones(3)
        left_gains, right_gains = (unit, unit) if gains is None else gains
        width, height = self.rig.image_size
        if regions is None:
            whole = box_spans([0, 0, width - 1, height - 1], height)
            regions = (whole, whole)
        left_box, right_box = regions
        left_shading, right_shading = (None, None) if shading is None else shading
        for side, image, camera, gain, box, shade in (
            ("left", image_left_bgr, self.rig.left, left_gains, left_box, left_shading),
            ("right", image_right_bgr, self.rig.right, right_gains, right_box, right_shading),
        ):
            array = checked_image(image, camera, side)
            thresholds = (self.params.min_saturation, self.params.min_value, self.params.value_split)
            codes.append(pixel_codes(array, camera, thresholds, np.asarray(gain, dtype=float), box, shade))
        self._codes = (codes[0], codes[1])

    @property
    def codes(self) -> tuple[npt.NDArray[np.uint16], npt.NDArray[np.uint16]]:
        """The current pair's framed pixel codes (left, right), as the kernels read them
        (row stride width + 3, one frame pixel left and top)."""
        if self._codes is None:
            raise RuntimeError("no stereo pair yet: call update(left, right) first")
        return self._codes

    @contextmanager
    def pixels_hidden(self, masks: tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]) -> Iterator[None]:
        """Within the block, the pixels of (H, W) bool `masks` (left, right) read as off the
        image (`OFF_IMAGE`: hidden to every point, to the search and to the verify stage's
        texture samples); the codes of before come back after it (an occluder read as such,
        `occluder_read.py`).

        Raises:
            RuntimeError: no pair yet.
            ValueError: masks not of the images' size.
        """
        saved = self.codes
        width, height = self.rig.image_size
        hidden = []
        for codes, mask in zip(saved, masks, strict=True):
            if np.shape(mask) != (height, width):
                raise ValueError(f"a pixel mask must be ({height}, {width}), got {np.shape(mask)}")
            framed = codes.reshape(height + 3, width + 3).copy()
            framed[1 : height + 1, 1 : width + 1][np.asarray(mask, dtype=bool)] = OFF_IMAGE
            hidden.append(framed.ravel())
        self._codes = (hidden[0], hidden[1])
        try:
            yield
        finally:
            self._codes = saved

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

    def point_agreement(self, transform_model_to_right: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per S_in point at one pose, by the search scores at the nearest pixels: in how many
        of the two images it matches (scores above 0) and in how many it is seen but does
        not match (a point on the background or on a colour it should not see).

        Returns:
            (N_in,) agreeing and (N_in,) disagreeing counts, each 0-2.
        """
        n_in = len(self.model.points_in)
        points = self._point_set(1)
        table = self._search_table
        agree, disagree = np.zeros(n_in), np.zeros(n_in)
        for codes in self.point_codes(transform_model_to_right):
            k = points.row_offsets[:n_in].astype(np.int64) + 2 * codes
            score, seen = table[k], table[k + 1] > 0
            agree += score > 0
            disagree += seen & (score <= 0)
        return agree, disagree

    def point_codes(self, transform_model_to_right: FloatArray) -> npt.NDArray[np.int64]:
        """(2, N_in) the pixel code each S_in point lands on at one pose, in the left and the
        right image (nearest pixel, as the kernels read it; `OFF_IMAGE` out of view)."""
        T = as_poses(transform_model_to_right)[0]
        width, height = self.rig.image_size
        points = self._point_set(1)
        n_in = len(self.model.points_in)
        xyz = np.stack([points.x[:n_in], points.y[:n_in], points.z[:n_in], np.ones(n_in, np.float32)])
        out = np.empty((2, n_in), dtype=np.int64)
        for side, (K, to_camera, codes) in enumerate(
            (
                (self.rig.left.camera_matrix, self._left_from_right, self.codes[0]),
                (self.rig.right.camera_matrix, np.eye(4), self.codes[1]),
            )
        ):
            projected = np.asarray(K, dtype=float) @ (to_camera @ T)[:3] @ xyz
            w = projected[2]
            front = w > 1e-6
            u = np.where(front, projected[0] / np.where(front, w, 1.0), -10.0) + 1.5
            v = np.where(front, projected[1] / np.where(front, w, 1.0), -10.0) + 1.5
            u = np.clip(u, 0.0, width + 1).astype(np.int64)  # as the kernels: floor(u + 0.5) + 1
            v = np.clip(v, 0.0, height + 1).astype(np.int64)
            out[side] = codes[v * (width + 3) + u]
        return out

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
        hidden: (N_in + N_out,) bool, points taken as hidden whatever they land on (a folded
            corner, `refinement.disagreeing_corner`): they score 0 and leave the divisor;
            only at stride 1. None: none.
        view_floor: (min_view_fraction, hidden_penalty) in place of the parameters' own
            (the tracking GA's, `TrackingSettings.view_floor`); only with "view"
            normalisation. None: the parameters' own.
    """

    def __init__(
        self,
        evaluator: FitnessEvaluator,
        *,
        stride: int = 1,
        search: bool = False,
        subpixel: bool = False,
        avoid: AvoidedPoses | None = None,
        hidden: npt.NDArray[np.bool_] | None = None,
        view_floor: tuple[float, float] | None = None,
    ) -> None:
        if stride < 1:
            raise ValueError(f"stride must be a positive integer, got {stride}")
        if hidden is not None and (stride != 1 or np.shape(hidden) != (evaluator.n_points,)):
            raise ValueError(f"hidden needs stride 1 and {evaluator.n_points} points, got {np.shape(hidden)}")
        self.hidden = None if hidden is None else np.asarray(hidden, dtype=bool)
        self.evaluator = evaluator
        self.stride = stride
        self.search = search
        self.subpixel = subpixel
        self.avoid = avoid if avoid is not None else AvoidedPoses.none()
        self.view_floor = view_floor

    def __call__(self, transforms_model_to_right: npt.ArrayLike) -> FloatArray:
        """(P,) normalised fitness of (P, 4, 4) poses (see `FitnessEvaluator.evaluate`), -1
        where avoided."""
        if self.hidden is None and self.view_floor is None:
            scores = self.evaluator.evaluate(
                transforms_model_to_right, stride=self.stride, subpixel=self.subpixel, search=self.search
            )
        else:
            T = np.ascontiguousarray(as_poses(transforms_model_to_right))
            arguments, normalisation = self.kernel_arguments()
            sums, seen = score_poses(T, *arguments, self.subpixel)  # type: ignore[call-arg]  # numba stub
            self.count(len(T))
            scores = np.asarray(normalised(sums, seen, *normalisation))
        if len(self.avoid.centres):
            scores[self.avoid.mask(transforms_model_to_right)] = -1.0
        return scores

    def kernel_arguments(self) -> tuple[tuple[object, ...], tuple[float, bool, float, float]]:
        """See `FitnessEvaluator.kernel_arguments` (the kernels take `subpixel` and `avoid` apart);
        `hidden` points get weight 0 and count as never seen (the divisor's full maximum
        keeps them, so hiding them costs `hidden_penalty` alike at every pose)."""
        arguments, normalisation = self.evaluator.kernel_arguments(stride=self.stride, search=self.search)
        if self.view_floor is not None:
            normalisation = (normalisation[0], normalisation[1], *self.view_floor)
        if self.hidden is None:
            return arguments, normalisation
        keep = (~self.hidden).astype(np.float32)
        weights, best = (
            cast(npt.NDArray[np.float32], arguments[6]),
            cast(npt.NDArray[np.float32], arguments[7]),
        )
        masked = (*arguments[:6], weights * keep, best * keep, *arguments[8:])
        return masked, normalisation

    def count(self, poses: int) -> None:
        """Adds poses scored inside a compiled loop to the evaluator's `evaluations`."""
        self.evaluator.evaluations += int(poses)


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


__all__ = ["FitnessEvaluator", "KernelFitness"]
