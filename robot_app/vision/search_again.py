"""A second search for models whose first one ended on a cloth already identified.

The GA finds the pose of highest hue fitness in the whole view. Where two cloths look alike
to the fitness (two whites, a grey and a black: no hue to tell them apart), the more
visible one can hold the search of the other: its pose comes back on the first cloth,
found or not, and the second is never seen (bench episode 88, session 23: the white linen
No.18 searched onto the white terry towel No.17 116 mm away; the towel was identified,
the linen never was). A real camera sees what is already explained as well as a program
does: paint it over in a colour the searched model does not have, and the search looks
elsewhere. A foreign colour is what the fitness reads as an occluder (neutral), not the
green sheet (which says "no cloth here"), so a cloth lying under the painted one keeps
its chance of being found where it shows.

Off by default (`identify.search_again`): on two synthetic plain whites it finds the
smaller one in 3 of 3 seeds where the first search ended on the larger one in 2 of 3
(`tests/test_identify_search_again.py`), but in the realistic cell's piles it named no
cloth more (`scripts/bench_survey.py`, episodes 200-223: 70 of 93 either way, +1.8
recognitions per survey): the cloths it finds there are too hidden under the painted ones
to be candidates, and the misses of a realistic pile are in the decision (docs/history.md,
session 23).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.exposure import sheet_gains
from robot_app.vision.hue import colour_codes, colours_match, to_hsv
from robot_app.vision.recognition import Recognition
from robot_app.vision.recognizer import Recognizer
from robot_app.vision.regions import Mask, dilated, explained, image_codes, undistorted

# Saturated colours to paint with, in BGR, the first one foreign to the searched model is
# taken: magenta, blue, orange, red, yellow, cyan (no green: the sheet's).
PAINTS: tuple[tuple[int, int, int], ...] = (
    (255, 0, 255), (255, 0, 0), (0, 128, 255), (0, 0, 255), (0, 255, 255), (255, 255, 0),
)  # fmt: skip


@dataclass(frozen=True)
class Identified:
    """A cloth already identified in the pair.

    Attributes:
        model: its model.
        transform_model_to_camera: (4, 4) its pose in the right camera [m].
        explained: (H, W) the right image's pixels it explains (undistorted image).
    """

    model: ClothModel
    transform_model_to_camera: FloatArray
    explained: Mask


def search_again(
    recognizers: Mapping[str, Recognizer],
    identified: Sequence[Identified],
    image_left_bgr: npt.NDArray[np.uint8],
    image_right_bgr: npt.NDArray[np.uint8],
    *,
    margin: int = 2,
    seed: int = 0,
    on_recognition: Callable[[str, Recognition], None] | None = None,
) -> dict[str, Recognition]:
    """Each model of `recognizers` recognised in the pair with every `identified` cloth
    painted over (its explained pixels, widened by `margin` px, in both images) in the
    first colour of `PAINTS` its model photo does not have.

    Returns:
        model name -> its recognition in the painted pair (a model foreign to no paint
        colour is not searched).
    """
    if not recognizers or not identified:
        return {}
    first = next(iter(recognizers.values()))
    rig = first.rig
    right = dilated(_any(m.explained for m in identified), 2 * margin + 1)
    left = dilated(_left_explained(first, identified, image_left_bgr), 2 * margin + 1)
    right_raw = _to_raw(right, rig.right)
    left_raw = _to_raw(left, rig.left)
    results: dict[str, Recognition] = {}
    for name, recognizer in recognizers.items():
        paint = foreign_paint(recognizer)
        if paint is None:
            continue
        painted_left = image_left_bgr.copy()
        painted_right = image_right_bgr.copy()
        painted_left[left_raw] = paint
        painted_right[right_raw] = paint
        results[name] = recognizer.recognize(painted_left, painted_right, seed=seed)
        if on_recognition is not None:
            on_recognition(name, results[name])
    return results


def foreign_paint(recognizer: Recognizer) -> tuple[int, int, int] | None:
    """The first colour of `PAINTS` none of the model's S_in colour codes matches."""
    fitness = recognizer.settings.fitness
    own = np.unique(np.asarray(recognizer.model.hues_in))
    patch = np.asarray([PAINTS], dtype=np.uint8)
    codes = colour_codes(to_hsv(patch), fitness.min_saturation, fitness.min_value, fitness.value_split)[0]
    for paint, code in zip(PAINTS, codes, strict=True):
        if not np.any(colours_match(np.full(own.shape, code), own, fitness.hue_threshold_in)):
            return paint
    return None


def _left_explained(
    recognizer: Recognizer, identified: Sequence[Identified], image_left_bgr: npt.NDArray[np.uint8]
) -> Mask:
    """The left image's pixels the identified cloths explain, at their poses moved into
    the left camera."""
    rig = recognizer.rig
    camera = rig.left
    image = undistorted(image_left_bgr, camera)
    fitness = recognizer.settings.fitness
    codes = image_codes(image, sheet_gains(image, recognizer.model, recognizer.settings.exposure), fitness)
    right_to_left = np.linalg.inv(np.asarray(rig.transform_left_to_right, dtype=float))
    masks = (
        explained(m.model, camera, right_to_left @ m.transform_model_to_camera, codes, fitness)[1]
        for m in identified
    )
    return _any(masks)


def _any(masks: Iterable[Mask]) -> Mask:
    union: Mask | None = None
    for mask in masks:
        union = mask.copy() if union is None else union | mask
    if union is None:
        raise ValueError("no mask to join")
    return union


def _to_raw(mask: Mask, camera: PinholeCamera) -> Mask:
    """A mask of the undistorted image as a mask of the camera's raw image: each raw pixel
    takes the mask's value where the lens puts it."""
    if not camera.has_distortion:
        return mask
    height, width = mask.shape
    v, u = np.mgrid[0:height, 0:width]
    pixels = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64).reshape(-1, 1, 2)
    K = camera.camera_matrix
    ideal = cv2.undistortPoints(pixels, K, camera.dist_coeffs, P=K).reshape(-1, 2)
    iu = np.rint(ideal[:, 0]).astype(int)
    iv = np.rint(ideal[:, 1]).astype(int)
    inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height)
    raw = np.zeros(height * width, dtype=bool)
    raw[inside] = mask[iv[inside], iu[inside]]
    return raw.reshape(height, width)


__all__ = ["PAINTS", "Identified", "foreign_paint", "search_again"]
