"""Looking into a collection box: did the cloth land in it?

The hand camera's image of a box is mapped onto the box floor's plane (a top view of its
inside, `BoxCheckSettings.view_px` square, walls cut off), which makes two looks from
different hand poses comparable. A cloth counts as put into the box when, against the
box's previous top view, enough of the floor changed (`min_changed`) and enough of what
changed has the model's colours (`min_model_share`: colour codes of the model's S_in, the
fitness's hue threshold). The same cloth put onto a cloth of the same colour still
changes the view (shading, outline, texture), if less.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.config import StrictModel
from robot_app.control.cell import StereoCapture
from robot_app.geometry import invert_transform
from robot_app.vision import ClothModel, FitnessSettings, StereoRig, colour_codes, colours_match, to_hsv

ImageBGR = npt.NDArray[np.uint8]


class BoxCheckSettings(StrictModel):
    """The look into a box.

    Attributes:
        view_px: side of the top view of the box's inside [px].
        inset: cut this share of the inner side off each edge (the walls' foot) [-].
        change_threshold: a top-view pixel changed if its colour moved this far [grey levels].
        min_changed: share of the floor that must change [-].
        min_model_share: share of the changed pixels with the model's colours [-].
        min_in_view: share of the floor the camera must see for a verdict [-].
    """

    view_px: int = Field(96, ge=16, le=512)
    inset: float = Field(0.05, ge=0.0, lt=0.4)
    change_threshold: float = Field(40.0, gt=0.0)
    min_changed: float = Field(0.08, ge=0.0, le=1.0)
    min_model_share: float = Field(0.3, ge=0.0, le=1.0)
    min_in_view: float = Field(0.5, gt=0.0, le=1.0)


@dataclass(frozen=True)
class BoxView:
    """A top view of a box's inside.

    Attributes:
        image: (n, n, 3) uint8 BGR; in_view: (n, n) bool, pixels the camera saw.
    """

    image: ImageBGR
    in_view: npt.NDArray[np.bool_]


@dataclass(frozen=True)
class BoxCheck:
    """The verdict of one look into a box.

    Attributes:
        confirmed: the cloth lies in the box.
        changed: share of the seen floor that changed [-].
        model_share: share of the changed pixels with the model's colours [-].
        in_view: share of the floor seen [-].
    """

    confirmed: bool
    changed: float
    model_share: float
    in_view: float


def box_view(
    capture: StereoCapture,
    rig: StereoRig,
    centre: npt.ArrayLike,
    inner_size: float,
    settings: BoxCheckSettings,
) -> BoxView:
    """The top view of the box whose floor centre is `centre` [m] (Σ_W) in the right image."""
    n = settings.view_px
    half = inner_size * (0.5 - settings.inset)
    c = np.asarray(centre, dtype=float)
    # floor corners in Σ_W, in the top view's pixel order (u along world y, v along world x)
    corners_world = np.array(
        [[c[0] - half, c[1] - half, c[2]], [c[0] - half, c[1] + half, c[2]],
         [c[0] + half, c[1] + half, c[2]], [c[0] + half, c[1] - half, c[2]]]
    )  # fmt: skip
    to_camera = invert_transform(capture.transform_right_camera_to_world)
    points = corners_world @ to_camera[:3, :3].T + to_camera[:3, 3]
    pixels = rig.right.project(points)
    target = np.array([[0, 0], [n - 1, 0], [n - 1, n - 1], [0, n - 1]], dtype=np.float32)
    image = np.ascontiguousarray(capture.right_bgr)
    if rig.right.has_distortion:
        K = rig.right.camera_matrix
        image = np.asarray(cv2.undistort(image, K, rig.right.dist_coeffs, None, K), dtype=np.uint8)
    if not np.all(np.isfinite(pixels)) or np.any(points[:, 2] <= 0):
        return BoxView(np.zeros((n, n, 3), np.uint8), np.zeros((n, n), bool))
    H = cv2.getPerspectiveTransform(np.asarray(pixels, dtype=np.float32), target)
    view = cv2.warpPerspective(image, H, (n, n), flags=cv2.INTER_AREA, borderValue=(0, 0, 0))
    seen = cv2.warpPerspective(np.full(image.shape[:2], 255, np.uint8), H, (n, n), flags=cv2.INTER_NEAREST)
    return BoxView(np.asarray(view, dtype=np.uint8), np.asarray(seen > 0, dtype=bool))


def check_box(
    before: BoxView | None,
    after: BoxView,
    model: ClothModel,
    fitness: FitnessSettings,
    settings: BoxCheckSettings,
) -> BoxCheck:
    """Did the cloth of `model` land in the box between the looks `before` and `after`?

    `before` None: the box as the job first saw it was not looked at; every seen pixel
    counts as changed (only the model's colours decide).
    """
    seen = after.in_view & (before.in_view if before is not None else True)
    in_view = float(np.mean(seen))
    if in_view < settings.min_in_view:
        return BoxCheck(False, 0.0, 0.0, in_view)
    if before is None:
        changed = seen
    else:
        difference = np.abs(after.image.astype(np.int16) - before.image.astype(np.int16)).max(axis=2)
        changed = seen & (difference >= settings.change_threshold)
    changed_share = float(np.count_nonzero(changed) / max(int(np.count_nonzero(seen)), 1))
    codes = colour_codes(to_hsv(after.image), fitness.min_saturation, fitness.min_value, fitness.value_split)
    palette = _palette(model)
    matches = np.zeros(codes.shape, bool)
    for code in palette:
        matches |= colours_match(codes, code, fitness.hue_threshold_in)
    model_share = float(np.count_nonzero(matches & changed) / max(int(np.count_nonzero(changed)), 1))
    confirmed = changed_share >= settings.min_changed and model_share >= settings.min_model_share
    return BoxCheck(bool(confirmed), changed_share, model_share, in_view)


def _palette(model: ClothModel, coverage: float = 0.9) -> npt.NDArray[np.uint16]:
    """The model's colour codes that cover `coverage` of its S_in points, most frequent first."""
    codes, counts = np.unique(np.asarray(model.hues_in), return_counts=True)
    order = np.argsort(-counts)
    cumulative = np.cumsum(counts[order]) / counts.sum()
    return codes[order][: int(np.searchsorted(cumulative, coverage)) + 1]


__all__ = ["BoxCheck", "BoxCheckSettings", "BoxView", "box_view", "check_box"]
