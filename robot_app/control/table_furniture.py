"""The cell's furniture in a clear-table survey image: the collection boxes and the bare
table beyond the green sheet. `vision.identify` reports every foreground pixel no cloth
model explains as unknown; these are known, not cloths, and are taken out of the unknown
regions before the job looks for a lost cloth there (`TableClearer._survey`). `graspable`
keeps of a lost cloth's region the part a blind grasp may aim at: on the table top, clear
of the boxes' walls (`table_lost.pick_lost`).
"""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import BoxPlace, OffSheetSettings, TableArea
from robot_app.control.table_survey import TablePlane
from robot_app.geometry import invert_transform
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.identify import UnknownRegion
from robot_app.vision.regions import undistorted


def fill_box_hull(
    mask: npt.NDArray[np.uint8], capture: StereoCapture, camera: PinholeCamera, box: BoxPlace, half: float
) -> None:
    """Sets to 1 the pixels of `mask` (the right image's) inside the hull of the square of
    half side `half` [m] around `box`'s centre, from its floor to its walls' top, seen from
    the capture's camera pose (nothing where fewer than three corners lie in front of it)."""
    to_camera = invert_transform(capture.transform_right_camera_to_world)
    c = np.asarray(box.centre, dtype=float)
    corners = np.array(
        [[c[0] + sx * half, c[1] + sy * half, c[2] + z]
         for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, box.wall_height)]
    )  # fmt: skip
    pixels = camera.project(corners @ to_camera[:3, :3].T + to_camera[:3, 3])
    pixels = pixels[np.all(np.isfinite(pixels), axis=1)]
    if len(pixels) >= 3:
        hull = cv2.convexHull(np.clip(pixels, -1e5, 1e5).astype(np.float32)).astype(np.int32)
        cv2.fillConvexPoly(mask, hull, 1)


def furniture_mask(
    capture: StereoCapture,
    camera: PinholeCamera,
    boxes: Iterable[BoxPlace],
    shape: tuple[int, int],
    margin_px: int = 3,
) -> npt.NDArray[np.bool_]:
    """(H, W) the pixels of the right image (undistorted, as `vision.identify` sees it)
    where a collection box stands: the convex hull of each box's outer walls, from their
    footprint on the table to their tops (`BoxPlace`: the cell's known geometry, laid into
    the image with the capture's camera pose), grown by `margin_px` for the walls' edges
    and shading. A box wholly behind the camera adds nothing."""
    mask = np.zeros(shape, np.uint8)
    for box in boxes:
        fill_box_hull(mask, capture, camera, box, box.outer_half)
    if margin_px > 0:
        mask = np.asarray(cv2.dilate(mask, np.ones((2 * margin_px + 1,) * 2, np.uint8)), dtype=np.uint8)
    return mask.astype(bool)


OPENING = 5  # px: as `vision.identify` opens the unexplained foreground


def without_furniture(
    regions: Iterable[UnknownRegion], furniture: npt.NDArray[np.bool_], smallest: float
) -> tuple[UnknownRegion, ...]:
    """The unknown regions with the `furniture` pixels taken out: each remaining connected
    piece of at least `smallest` pixels is a region of its own (a cloth beside a box's wall
    and the box's inside are two things), largest first. A region that lost pixels is
    opened by `OPENING` px square, as `identify` opens its foreground: the furniture's
    edges (blurred, of mixed colour) would join its pieces by thin seams."""
    kept: list[UnknownRegion] = []
    square = np.ones((OPENING, OPENING), np.uint8)
    for region in regions:
        whole = np.asarray(region.mask, dtype=bool)
        rest = (whole & ~furniture).astype(np.uint8)
        if np.any(whole & furniture):
            rest = np.asarray(cv2.morphologyEx(rest, cv2.MORPH_OPEN, square), dtype=np.uint8)
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(rest, connectivity=8)
        kept.extend(
            UnknownRegion(
                (float(centroids[k][0]), float(centroids[k][1])), int(stats[k, cv2.CC_STAT_AREA]), labels == k
            )
            for k in range(1, count)
            if stats[k, cv2.CC_STAT_AREA] >= smallest
        )
    return tuple(sorted(kept, key=lambda region: -region.area))


MODE_WINDOW = 2  # the table's hue: the peak of the hue histogram summed over ±this [HSV_FULL steps]
SMOOTHING = 5  # the hues are read off the image averaged over this many pixels square


def off_sheet(
    capture: StereoCapture, table: TablePlane, sheet: TableArea, shape: tuple[int, int]
) -> npt.NDArray[np.bool_]:
    """(H, W) the right-image pixels whose ray meets the table plane outside the green
    `sheet` (or never meets it): there, not-sheet is not yet cloth."""
    h, w = shape
    v, u = np.mgrid[0:h, 0:w]
    on = sheet.contains(table.pixels(capture, u, v)) & table.ahead(capture, u, v)
    return np.asarray(~on.reshape(h, w), dtype=bool)


def graspable(
    mask: npt.NDArray[np.bool_],
    capture: StereoCapture,
    table: TablePlane,
    top: TableArea | None,
    boxes: Iterable[BoxPlace],
    edge_inset: float,
    wall_clearance: float,
) -> npt.NDArray[np.bool_]:
    """(H, W) the pixels of `mask` (right image, as `vision.identify` sees it) a hand can
    grasp at from above: their ray meets the table plane at least `edge_inset` [m] inside
    the table `top` (None: the top's extent unknown, any point of the plane) and at least
    `wall_clearance` [m] outside every box's outer walls (`BoxPlace`). A cloth hanging past
    the table's edge or against a wall shows pixels whose ray meets the plane where no hand
    can close on it."""
    keep = np.zeros(mask.shape, bool)
    v, u = np.nonzero(mask)
    if not len(u):
        return keep
    xy = table.pixels(capture, u, v)
    ok = table.ahead(capture, u, v)
    if top is not None:
        ok &= top.contains(xy, edge_inset)
    ok &= clear_of_walls(xy, boxes, wall_clearance)
    keep[v[ok], u[ok]] = True
    return keep


def clear_of_walls(
    xy: npt.ArrayLike, boxes: Iterable[BoxPlace], wall_clearance: float
) -> npt.NDArray[np.bool_]:
    """(N,) which table points `xy` ((N, 2) [m]) lie at least `wall_clearance` [m] outside
    every box's outer walls: where the open hand (half span about 5 cm) comes down without
    touching a wall."""
    points = np.asarray(xy, dtype=float).reshape(-1, 2)
    ok = np.ones(len(points), dtype=bool)
    for box in boxes:
        c = np.asarray(box.centre, dtype=float)
        ok &= np.max(np.abs(points - c[:2]), axis=1) > box.outer_half + wall_clearance
    return ok


def table_coloured(
    image_bgr: npt.NDArray[np.uint8],
    beyond: npt.NDArray[np.bool_],
    settings: OffSheetSettings,
    known: npt.NDArray[np.bool_] | None = None,
) -> npt.NDArray[np.bool_]:
    """(H, W) the `beyond` pixels of `image_bgr` that show the bare table: saturated at
    least `min_saturation` and within `hue_tolerance` of the table's hue, which is the
    most frequent hue (HSV_FULL, circular, summed over ±`MODE_WINDOW`) of the saturated
    `beyond` pixels not `known` (other furniture: a box's orange walls are a large
    saturated surface too); or washed out: brighter than `clipped` in a channel and less
    saturated than `min_saturation` (the exposure clipped the table's colour away). Hues
    and brightness are read off the image averaged over `SMOOTHING` px square, and the
    mask is closed by as much (a dark shade's hue is noise pixel by pixel). Shade keeps a
    surface's hue, so the table's shadows are table too; a white or grey cloth (no hue)
    that is not clipped and a cloth of another hue are not."""
    smooth = cv2.blur(image_bgr, (SMOOTHING, SMOOTHING))
    hsv = cv2.cvtColor(smooth, cv2.COLOR_BGR2HSV_FULL)
    hue = hsv[..., 0].astype(np.int32)
    saturated = hsv[..., 1] >= settings.min_saturation
    washed_out = beyond & ~saturated & (smooth.max(axis=2) >= settings.clipped)
    sample = beyond & saturated
    if known is not None:
        sample &= ~known
    table = washed_out.copy()
    if np.count_nonzero(sample) >= settings.min_pixels:
        histogram = np.bincount(hue[sample], minlength=256).astype(float)
        summed = sum(np.roll(histogram, shift) for shift in range(-MODE_WINDOW, MODE_WINDOW + 1))
        table_hue = int(np.argmax(summed))
        apart = np.abs((hue - table_hue + 128) % 256 - 128)
        table |= beyond & saturated & (apart <= settings.hue_tolerance)
    square = np.ones((SMOOTHING, SMOOTHING), np.uint8)
    closed = cv2.morphologyEx(table.astype(np.uint8), cv2.MORPH_CLOSE, square)
    return np.asarray(closed.astype(bool) & beyond, dtype=bool)


def table_beyond_sheet(
    capture: StereoCapture,
    camera: PinholeCamera,
    table: TablePlane,
    sheet: TableArea,
    settings: OffSheetSettings,
    known: npt.NDArray[np.bool_] | None = None,
) -> npt.NDArray[np.bool_]:
    """(H, W) the pixels of the undistorted right image that show the bare table beyond
    the green sheet (`off_sheet` and `table_coloured`, `known`: other furniture's pixels):
    known furniture, not a cloth."""
    image = undistorted(capture.right_bgr, camera)
    return table_coloured(image, off_sheet(capture, table, sheet, image.shape[:2]), settings, known)


__all__ = [
    "clear_of_walls",
    "fill_box_hull",
    "furniture_mask",
    "graspable",
    "off_sheet",
    "table_beyond_sheet",
    "table_coloured",
    "without_furniture",
]
