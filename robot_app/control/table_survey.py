"""What a clear-table survey saw, on the table: poses in Σ_W, image pixels laid onto the
table plane, the cloth to pick next (the order) and the other cloths as obstacles.

Pure functions of one survey's capture and identification (`vision.identify`); the job
(`TableClearer`) takes the capture and keeps the records.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import BoxPlace, OffSheetSettings, SheetArea
from robot_app.geometry import invert_transform, transform_points
from robot_app.vision import Recognizer
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.identify import Detection, Identification, UnknownRegion
from robot_app.vision.regions import undistorted


def to_world(capture: StereoCapture, transform_model_to_camera: FloatArray) -> FloatArray:
    """(4, 4) a pose seen by the right camera of `capture`, in Σ_W."""
    return np.asarray(capture.transform_right_camera_to_world @ transform_model_to_camera, dtype=float)


@dataclass(frozen=True)
class TablePlane:
    """The table top as the right camera sees it.

    Attributes:
        camera_matrix: (3, 3) the right camera's intrinsics [px].
        table_z: height of the table top in Σ_W [m].
    """

    camera_matrix: FloatArray
    table_z: float

    def _rays(
        self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The rays through right-image pixels (u, v) in Σ_W: origin (3, 1), directions (3, N)."""
        u, v = np.asarray(u, dtype=float).ravel(), np.asarray(v, dtype=float).ravel()
        rays = np.linalg.solve(self.camera_matrix, np.stack([u, v, np.ones_like(u)]))
        T = capture.transform_right_camera_to_world
        return T[:3, 3:4], T[:3, :3] @ rays

    def pixels(self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike) -> FloatArray:
        """(N, 2) where the rays through right-image pixels (u, v) meet the table plane [m]."""
        origin, directions = self._rays(capture, u, v)
        dz = directions[2]
        scale = np.where(np.abs(dz) > 1e-9, (self.table_z - origin[2]) / np.where(dz == 0, 1.0, dz), 0.0)
        return np.asarray((origin + scale * directions)[:2].T, dtype=float)

    def ahead(self, capture: StereoCapture, u: npt.ArrayLike, v: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """(N,) True where the ray through right-image pixel (u, v) goes down to the table
        plane (the others never meet it: `pixels` gives no point of the table for them)."""
        origin, directions = self._rays(capture, u, v)
        return np.asarray((origin[2] > self.table_z) & (directions[2] < -1e-9), dtype=bool)

    def point(self, capture: StereoCapture, pixel: tuple[float, float]) -> tuple[float, float]:
        """Where the ray through a right-image pixel meets the table plane, (x, y) [m]."""
        x, y = self.pixels(capture, np.array([pixel[0]]), np.array([pixel[1]]))[0]
        return float(x), float(y)


def choose_target(
    ident: Identification, records: Mapping[str, Mapping[str, object]], max_attempts: int
) -> Detection | None:
    """The cloth to pick next: the most confident one nothing lies on, among those with
    attempts left (`max_attempts`); else the most visible one with attempts left.

    Args:
        ident: the survey's identification.
        records: cloth name -> the job's record ("attempts", "unconfirmed", ...).
        max_attempts: pick attempts per cloth.
    """

    def eligible(d: Detection) -> bool:
        tried = int(records.get(d.name, {}).get("attempts", 0))  # type: ignore[call-overload]
        if tried >= max_attempts:
            return False
        # a candidate below the recogniser's threshold gets one closer look by the loop
        unconfirmed = bool(records.get(d.name, {}).get("unconfirmed", False))
        return d.found or not unconfirmed

    free = [d for d in ident.free() if eligible(d)]
    if free:
        return free[0]
    rest = [d for d in ident.detections if eligible(d)]
    return max(rest, key=lambda d: d.recognition.visible_fraction) if rest else None


def obstacles_on_table(
    target: Detection,
    ident: Identification,
    capture: StereoCapture,
    recognizers: Mapping[str, Recognizer],
    table: TablePlane,
    step: int,
) -> FloatArray:
    """(M, 2) table points [m] of every cloth the survey saw but `target`: identified
    ones (their whole footprint, hidden parts included) and unknown regions (every
    `step`-th pixel [px])."""
    xy = [
        transform_points(to_world(capture, d.transform_model_to_camera), recognizers[d.name].model.points_in)[
            :, :2
        ]
        for d in ident.detections
        if d.name != target.name
    ]
    for region in ident.unknown:
        v, u = np.nonzero(region.mask[::step, ::step])
        if len(u):
            xy.append(table.pixels(capture, u * step, v * step))
    return np.concatenate(xy) if xy else np.empty((0, 2))


def disk_points(centre_xy: npt.ArrayLike, radius: float, step: float = 0.01) -> FloatArray:
    """(M, 2) points [m] on a grid of `step` [m] filling the disk of `radius` [m] around
    `centre_xy` (the centre alone for radius 0): a cloth known to lie there, unseen."""
    centre = np.asarray(centre_xy, dtype=float).reshape(2)
    n = int(np.floor(radius / step))
    offsets = np.arange(-n, n + 1) * step
    grid = np.stack(np.meshgrid(offsets, offsets), axis=-1).reshape(-1, 2)
    grid = grid[np.hypot(grid[:, 0], grid[:, 1]) <= radius + 1e-12]
    return centre + grid


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
    to_camera = invert_transform(capture.transform_right_camera_to_world)
    for box in boxes:
        c = np.asarray(box.centre, dtype=float)
        half = box.inner_size / 2 + box.wall_thickness
        corners = np.array(
            [[c[0] + sx * half, c[1] + sy * half, c[2] + z]
             for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, box.wall_height)]
        )  # fmt: skip
        pixels = camera.project(corners @ to_camera[:3, :3].T + to_camera[:3, 3])
        pixels = pixels[np.all(np.isfinite(pixels), axis=1)]
        if len(pixels) < 3:
            continue
        hull = cv2.convexHull(np.clip(pixels, -1e5, 1e5).astype(np.float32)).astype(np.int32)
        cv2.fillConvexPoly(mask, hull, 1)
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
    capture: StereoCapture, table: TablePlane, sheet: SheetArea, shape: tuple[int, int]
) -> npt.NDArray[np.bool_]:
    """(H, W) the right-image pixels whose ray meets the table plane outside the green
    `sheet` (or never meets it): there, not-sheet is not yet cloth."""
    h, w = shape
    v, u = np.mgrid[0:h, 0:w]
    xy = table.pixels(capture, u, v)
    on = (
        (xy[:, 0] >= sheet.x_range[0])
        & (xy[:, 0] <= sheet.x_range[1])
        & (xy[:, 1] >= sheet.y_range[0])
        & (xy[:, 1] <= sheet.y_range[1])
        & table.ahead(capture, u, v)
    )
    return np.asarray(~on.reshape(h, w), dtype=bool)


def table_coloured(
    image_bgr: npt.NDArray[np.uint8], beyond: npt.NDArray[np.bool_], settings: OffSheetSettings
) -> npt.NDArray[np.bool_]:
    """(H, W) the `beyond` pixels of `image_bgr` that show the bare table: saturated at
    least `min_saturation` and within `hue_tolerance` of the table's hue, which is the
    most frequent hue (HSV_FULL, circular, summed over ±`MODE_WINDOW`) of the saturated
    `beyond` pixels. Hues are read off the image averaged over `SMOOTHING` px square,
    and the mask is closed by as much (a dark shade's hue is noise pixel by pixel). Shade
    keeps a surface's hue, so the table's shadows are table too; a white or grey cloth
    (no hue) and a cloth of another hue are not."""
    smooth = cv2.blur(image_bgr, (SMOOTHING, SMOOTHING))
    hsv = cv2.cvtColor(smooth, cv2.COLOR_BGR2HSV_FULL)
    hue = hsv[..., 0].astype(np.int32)
    sample = beyond & (hsv[..., 1] >= settings.min_saturation)
    if np.count_nonzero(sample) < settings.min_pixels:
        return np.zeros(beyond.shape, bool)
    histogram = np.bincount(hue[sample], minlength=256).astype(float)
    summed = sum(np.roll(histogram, shift) for shift in range(-MODE_WINDOW, MODE_WINDOW + 1))
    table_hue = int(np.argmax(summed))
    apart = np.abs((hue - table_hue + 128) % 256 - 128)
    table = (sample & (apart <= settings.hue_tolerance)).astype(np.uint8)
    square = np.ones((SMOOTHING, SMOOTHING), np.uint8)
    closed = cv2.morphologyEx(table, cv2.MORPH_CLOSE, square)
    return np.asarray(closed.astype(bool) & beyond, dtype=bool)


def table_beyond_sheet(
    capture: StereoCapture,
    camera: PinholeCamera,
    table: TablePlane,
    sheet: SheetArea,
    settings: OffSheetSettings,
) -> npt.NDArray[np.bool_]:
    """(H, W) the pixels of the undistorted right image that show the bare table beyond
    the green sheet (`off_sheet` and `table_coloured`): known furniture, not a cloth."""
    image = undistorted(capture.right_bgr, camera)
    return table_coloured(image, off_sheet(capture, table, sheet, image.shape[:2]), settings)


__all__ = [
    "TablePlane",
    "choose_target",
    "disk_points",
    "furniture_mask",
    "obstacles_on_table",
    "off_sheet",
    "table_beyond_sheet",
    "table_coloured",
    "to_world",
    "without_furniture",
]
