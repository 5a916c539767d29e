"""Did a pick move a cloth nobody identified? The sheet bared where an unknown region lay.

A cloth the survey could not identify (crumpled, mostly hidden) lies as an *unknown*
region. When the next pick lifts a cloth beside or on it, it may come along a little way,
held by nothing (a fold caught under the lifted cloth, friction) and fall back crumpled
elsewhere: the load cell reads too little of it to tell (session 14's bench, episodes 19
and 22: +6.4 g and +7.3 g, inside the spread of single lifts, up to +8.3 g), and since
no model explained it before, none finds it after. The job then stops with that cloth on
the table, reported as unknown (episode 22: the white No.18, dragged by No.8's lift).

What shows it: the survey after the pick, from the same camera pose, sees the green sheet
where the unknown region's pixels were, outside where the picked cloth itself lay (its
footprint at the survey's pose, grown by `grow_px`: removing it bares its own pixels and
the fold of it that `identify` left unexplained). A region with at least `min_bared` of
its remaining pixels bared moved (`moved_regions`); the job books it as a cloth that came
along unnamed (`TableLedger.unnamed`, as a double pick's companion that was laid back),
so that its colours and weight may name it later (`table_lost`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.config import StrictModel
from robot_app.vision.identify import UnknownRegion

Mask = npt.NDArray[np.bool_]


class MovedSettings(StrictModel):
    """Noticing an unknown region a pick moved (the `clear.moved` section).

    Attributes:
        enabled: compare the surveys before and after each placed pick.
        min_bared: share of the region's pixels (outside the picked cloth's grown
            footprint) that must show the sheet after the pick [-].
        grow_px: the picked cloth's footprint grown by this [px].
        min_pixels: a region with fewer pixels left outside that footprint is not judged [px].
    """

    enabled: bool = True
    min_bared: float = Field(0.3, gt=0.0, le=1.0)
    grow_px: int = Field(6, ge=0, le=50)
    min_pixels: int = Field(60, ge=1)


@dataclass(frozen=True)
class MovedRegion:
    """An unknown region of the survey before a pick whose place the sheet now shows.

    Attributes:
        region: the region as the survey before the pick saw it.
        bared: share of its pixels (outside the picked cloth's footprint) now sheet [-].
    """

    region: UnknownRegion
    bared: float


def grown(mask: Mask, px: int, shrink: bool = False) -> Mask:
    """`mask` grown (or, with `shrink`, shrunk) by a disk of radius `px` [px]."""
    image = np.asarray(mask, dtype=np.uint8)
    if px > 0:
        disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * px + 1, 2 * px + 1))
        image = np.asarray((cv2.erode if shrink else cv2.dilate)(image, disk), dtype=np.uint8)
    return image.astype(bool)


def moved_regions(
    before: tuple[UnknownRegion, ...],
    picked_footprint: Mask,
    sheet_after: Mask,
    settings: MovedSettings,
) -> list[MovedRegion]:
    """The regions of `before` (the survey before a pick) that the pick moved: at least
    `min_bared` of their pixels outside `picked_footprint` (grown by `grow_px`) show the
    sheet in `sheet_after` (the survey after it, from the same camera pose)."""
    outside = ~grown(picked_footprint, settings.grow_px)
    moved = []
    for region in before:
        judged = region.mask & outside
        count = int(np.count_nonzero(judged))
        if count < settings.min_pixels:
            continue
        bared = float(np.count_nonzero(judged & sheet_after)) / count
        if bared >= settings.min_bared:
            moved.append(MovedRegion(region, bared))
    return moved


def bared_from_elsewhere(
    region_points: list[npt.NDArray[np.float64]],
    transform_camera_to_world: npt.NDArray[np.float64],
    camera_matrix: npt.NDArray[np.float64],
    sheet: Mask,
    min_pixels: int,
) -> list[float | None]:
    """Per region, the share of its table points ((N, 3) [m] each: where a survey saw it)
    that an image from another camera pose shows as sheet (`sheet`: that image's
    undistorted sheet pixels; `camera_matrix`, `transform_camera_to_world`); None where
    fewer than `min_pixels` of them fall inside that image. A cloth seen there by the
    survey and gone bares the sheet; one still lying there, or hidden from this view (by
    what the hand holds), does not."""
    world_to_camera = np.linalg.inv(np.asarray(transform_camera_to_world, dtype=float))
    K = np.asarray(camera_matrix, dtype=float)
    height, width = sheet.shape
    shares: list[float | None] = []
    for points in region_points:
        p = (
            np.asarray(points, dtype=float).reshape(-1, 3) @ world_to_camera[:3, :3].T
            + world_to_camera[:3, 3]
        )
        ahead = p[:, 2] > 1e-6
        uv = (p[ahead] @ K.T)[:, :2] / p[ahead, 2:3]
        u, v = np.round(uv[:, 0]).astype(int), np.round(uv[:, 1]).astype(int)
        inside = (u >= 0) & (u < width) & (v >= 0) & (v < height)
        count = int(np.count_nonzero(inside))
        shares.append(float(np.mean(sheet[v[inside], u[inside]])) if count >= min_pixels else None)
    return shares


__all__ = ["MovedRegion", "MovedSettings", "bared_from_elsewhere", "grown", "moved_regions"]
