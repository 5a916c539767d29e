"""Looking into a collection box: did the cloth land in it?

The hand camera's image of a box is mapped onto the box floor's plane (a top view of its
inside, `BoxCheckSettings.view_px` square, walls cut off), which makes two looks from
different hand poses comparable. A cloth counts as put into the box when, against the
box's previous top view, enough of the floor changed (`min_changed`) and enough of what
changed has the model's colours (`min_model_share`: colour codes of the model's S_in, the
fitness's hue threshold). The same cloth put onto a cloth of the same colour still
changes the view (shading, outline, texture), if less. The first check into a box
compares with a look into it before the first pick, from the same pose (the job's
`look_at_boxes`); without one, the empty box is taken to look like the table seen around
it (`BoxView.surround_bgr`, a ring `surround` outside), a poor stand-in where the box's
floor differs from the table or lies in the walls' shadow.

The same look reads the box's rim (`rim_view`: points along the middle of each wall's top,
in both images) and compares it with the look before (`rim_covered`): a run of it that
changed is a cloth lying over that wall, partly out of the box (`box_rim`).

Where to look from (`look_tcp`): straight above the floor's middle, high enough that the
image holds the whole floor and the walls' tops. Not from the release pose: there the fingers are 6-8 cm
over the floor (a cloth is let go low, to fold onto the floor), the hand camera 10 cm
above them and 7 cm and 5 cm beside them, so its 14 x 11 cm field covered a quarter of
the 22 cm box's floor, under `min_in_view`, and no check after placing ever confirmed.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.control.cell import StereoCapture
from robot_app.geometry import invert_transform
from robot_app.vision import ClothModel, FitnessSettings, StereoRig, colour_codes, colours_match, to_hsv
from robot_app.vision.hue import HUE_RANGE
from robot_app.vision.regions import main_codes

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
        surround: distance of the ring around the box, from its centre, where the table's
            colour is read, as a share of the inner side [-].
        shadow_hue_step: in a shadow-proof check (`check_box`), a pixel whose hue moved
            less than this (or whose tone stayed) did not change [HSV_FULL steps].
        shadow_chroma_step: ... nor did a pixel whose chroma (its saturation as a vector at
            its hue's angle) moved less than this [HSV_FULL saturation steps; 0: off].
        rim_samples: points along the middle of each wall's top where the look reads the
            rim (`rim_view`) [-].
        rim_change: a rim point changed when its colour moved by more than this factor
            (log scale, after the whole rim's common change of exposure) [-].
        rim_run: a cloth lies over a wall when this long a run of its rim changed [m].
    """

    view_px: int = Field(96, ge=16, le=512)
    inset: float = Field(0.05, ge=0.0, lt=0.4)
    change_threshold: float = Field(40.0, gt=0.0)
    min_changed: float = Field(0.08, ge=0.0, le=1.0)
    min_model_share: float = Field(0.3, ge=0.0, le=1.0)
    min_in_view: float = Field(0.5, gt=0.0, le=1.0)
    surround: float = Field(0.75, gt=0.55, le=2.0)
    shadow_hue_step: int = Field(8, ge=0, le=64)
    shadow_chroma_step: float = Field(16.0, ge=0.0, le=255.0)
    rim_samples: int = Field(40, ge=4, le=400)
    rim_change: float = Field(0.3, gt=0.0)
    rim_run: float = Field(0.03, gt=0.0)


@dataclass(frozen=True)
class BoxView:
    """A top view of a box's inside.

    Attributes:
        image: (n, n, 3) uint8 BGR; in_view: (n, n) bool, pixels the camera saw.
        surround_bgr: (3,) median colour of the table around the box (None: not seen).
    """

    image: ImageBGR
    in_view: npt.NDArray[np.bool_]
    surround_bgr: FloatArray | None = None


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


def look_tcp(centre: npt.ArrayLike, camera_height: float, camera_offset: npt.ArrayLike) -> FloatArray:
    """TCP position [m] in Σ_W that puts the right camera `camera_height` [m] straight above
    the box floor's centre `centre` [m] (Σ_W); `camera_offset`: the right camera minus the
    TCP in Σ_W [m], which the hand's fixed orientation keeps."""
    c, offset = np.asarray(centre, dtype=float), np.asarray(camera_offset, dtype=float)
    return np.array([c[0] - offset[0], c[1] - offset[1], c[2] + camera_height - offset[2]])


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
    surround = _surround(image, rig, to_camera, c, inner_size * settings.surround)
    return BoxView(np.asarray(view, dtype=np.uint8), np.asarray(seen > 0, dtype=bool), surround)


def _surround(
    image: ImageBGR, rig: StereoRig, to_camera: FloatArray, centre: FloatArray, distance: float
) -> FloatArray | None:
    """Median colour of the image along a square ring at `distance` [m] around the box centre."""
    t = np.linspace(-distance, distance, 24)
    ring = np.vstack(
        [np.column_stack([t, np.full_like(t, s * distance)]) for s in (-1, 1)]
        + [np.column_stack([np.full_like(t, s * distance), t]) for s in (-1, 1)]
    )
    world = np.column_stack([ring + centre[:2], np.full(len(ring), centre[2])])
    points = world @ to_camera[:3, :3].T + to_camera[:3, 3]
    front = points[:, 2] > 0
    if not np.any(front):
        return None
    pixels = np.rint(rig.right.project(points[front])).astype(int)
    height, width = image.shape[:2]
    inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < width) & (pixels[:, 1] >= 0) & (pixels[:, 1] < height)
    if np.count_nonzero(inside) < 8:
        return None
    return np.median(image[pixels[inside, 1], pixels[inside, 0]].astype(float), axis=0)


WALL_NORMALS = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])  # outward, Σ_W xy
RIM_FLOOR = 8.0  # grey levels added before the log ratio: dark rim points do not flicker to "changed"


@dataclass(frozen=True)
class RimView:
    """What a look saw of a box's rim: the walls' tops, where a cloth that hangs out of the
    box lies over them.

    Attributes:
        bgr: (2, 4, n, 3) colour at `n` points along the middle of each wall's top
            (`WALL_NORMALS` order), in the right image and in the left.
        seen: (2, 4, n) the point lies in that image.
        spacing: distance between neighbouring points [m].
    """

    bgr: FloatArray
    seen: npt.NDArray[np.bool_]
    spacing: float


def rim_points(
    centre: npt.ArrayLike, inner_size: float, wall_height: float, wall_thickness: float, n: int
) -> FloatArray:
    """(4, n, 3) points [m] in Σ_W along the middle of each wall's top (`WALL_NORMALS`
    order), corner to corner."""
    c = np.asarray(centre, dtype=float)
    half = inner_size / 2 + wall_thickness / 2
    along = np.linspace(-half, half, n)
    walls = np.empty((4, n, 3))
    for k, (nx, ny) in enumerate(WALL_NORMALS):
        walls[k, :, 0] = c[0] + (nx * half if nx else along)
        walls[k, :, 1] = c[1] + (ny * half if ny else along)
        walls[k, :, 2] = c[2] + wall_height
    return walls


def rim_view(
    capture: StereoCapture,
    rig: StereoRig,
    centre: npt.ArrayLike,
    inner_size: float,
    wall_height: float,
    wall_thickness: float,
    settings: BoxCheckSettings,
) -> RimView:
    """Reads the box's rim (`rim_points`) in both images of `capture`."""
    n = settings.rim_samples
    points = rim_points(centre, inner_size, wall_height, wall_thickness, n).reshape(-1, 3)
    right_from_world = invert_transform(capture.transform_right_camera_to_world)
    left_from_world = invert_transform(rig.transform_left_to_right) @ right_from_world
    colours, seen = np.zeros((2, 4 * n, 3)), np.zeros((2, 4 * n), bool)
    for k, (camera, image, to_camera) in enumerate(
        ((rig.right, capture.right_bgr, right_from_world), (rig.left, capture.left_bgr, left_from_world))
    ):
        local = points @ to_camera[:3, :3].T + to_camera[:3, 3]
        pixels = camera.project(local)
        height, width = image.shape[:2]
        ok = (local[:, 2] > 0) & np.all(np.isfinite(pixels), axis=1)
        ok &= (
            (pixels[:, 0] >= 1)
            & (pixels[:, 0] <= width - 2)
            & (pixels[:, 1] >= 1)
            & (pixels[:, 1] <= height - 2)
        )
        at = np.rint(pixels[ok]).astype(int)
        patch = [image[at[:, 1] + dv, at[:, 0] + du].astype(float) for dv in (-1, 0, 1) for du in (-1, 0, 1)]
        colours[k, ok] = np.median(np.stack(patch), axis=0)
        seen[k] = ok
    spacing = (inner_size + wall_thickness) / (n - 1)
    return RimView(colours.reshape(2, 4, n, 3), seen.reshape(2, 4, n), spacing)


def rim_covered(before: RimView, after: RimView, settings: BoxCheckSettings) -> FloatArray:
    """(4,) how long [m] the longest run of each wall's rim (`WALL_NORMALS` order) is that
    changed between the looks `before` and `after` in either image: a cloth lying over
    it (`rim_runs`)."""
    return rim_runs(before, after, settings)[0]


def rim_runs(before: RimView, after: RimView, settings: BoxCheckSettings) -> tuple[FloatArray, FloatArray]:
    """For each wall's rim (`WALL_NORMALS` order), the longest run that changed between the
    looks `before` and `after` in either image: its length [m] and where its middle lies
    along the wall from the wall's middle [m] (towards +y on the x walls, +x on the y
    walls, as `rim_points` runs; 0 where none changed). The exposure may differ between
    looks: each image's common change of the rim's colour (the median over its points seen
    in both) is taken out first."""
    images, walls, n = after.seen.shape
    changed = np.zeros((walls, n), bool)
    for k in range(images):
        both = before.seen[k] & after.seen[k]
        if np.count_nonzero(both) < 8:
            continue
        ratio = np.log((after.bgr[k] + RIM_FLOOR) / (before.bgr[k] + RIM_FLOOR))
        ratio -= np.median(ratio[both], axis=0)
        changed |= both & (np.abs(ratio).max(axis=-1) > np.log1p(settings.rim_change))
    lengths, middles = np.zeros(len(changed)), np.zeros(len(changed))
    for wall, row in enumerate(changed):
        start, run = _longest_run(row)
        lengths[wall] = run * after.spacing
        if run:
            middles[wall] = (start + (run - 1) / 2 - (n - 1) / 2) * after.spacing
    return lengths, middles


def _longest_run(flags: npt.NDArray[np.bool_]) -> tuple[int, int]:
    """Where the longest run of True in `flags` starts, and how long it is."""
    best_start = best = run = 0
    for index, flag in enumerate(flags):
        run = run + 1 if flag else 0
        if run > best:
            best, best_start = run, index - run + 1
    return best_start, best


def check_box(
    before: BoxView | None,
    after: BoxView,
    model: ClothModel,
    fitness: FitnessSettings,
    settings: BoxCheckSettings,
    shadow_proof: bool = False,
) -> BoxCheck:
    """Did the cloth of `model` land in the box between the looks `before` and `after`?

    `shadow_proof`: a pixel counts as changed only where its colour code changed too (its
    hue by `shadow_hue_step` or more, or from a hue to a tone or back), and
    only the model's main colours that are hues count (not DARK or LIGHT): a shadow that
    moved darkens the floor's colour without changing its hue, or turns it DARK, which a
    dark cloth's tone matches (held-out episode 764, session 33: the arm's shadow, elsewhere
    than at the reference look, changed 53 % of the floor, all "in the colours" of No.16,
    which lay dropped on the table). A cloth of tones only, or of the floor's hue, is then
    never confirmed. Nor does a pixel count whose chroma moved less than
    `shadow_chroma_step`: a pale floor's saturation lies near `min_saturation`, and a change
    of exposure alone (auto-exposure still settling, a clipped channel freed) moves it
    across, a tone before and a hue after, with hardly a change of colour (held-out episode
    1704, session 48: 37 % of the floor "changed" so, all in the palette of No.8, which lay
    dropped on the table; the three drops that did fall into their box in the held-out runs
    kept 54-60 % of the floor changed at 16 steps, the false one 0 %).

    `before` None: the box was not looked into before; it is taken to have been empty, of
    the table's colour around it (`after.surround_bgr`), or, without that, every seen
    pixel counts as changed (the model's colours alone decide).
    """
    if before is None and after.surround_bgr is not None:
        empty = np.empty_like(after.image)
        empty[:] = np.clip(np.rint(after.surround_bgr), 0, 255).astype(np.uint8)
        before = BoxView(empty, np.ones(after.in_view.shape, bool), after.surround_bgr)
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

    def codes_of(hsv: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint16]:
        return colour_codes(hsv, fitness.min_saturation, fitness.min_value, fitness.value_split)

    hsv_after = to_hsv(after.image)
    codes = codes_of(hsv_after)
    palette = main_codes(model, 0.9)
    if shadow_proof and before is not None:
        hsv_before = to_hsv(before.image)
        changed &= ~colours_match(codes, codes_of(hsv_before), settings.shadow_hue_step)
        if settings.shadow_chroma_step > 0:
            changed &= _chroma_moved(hsv_after, hsv_before, settings.shadow_chroma_step)
        changed_share = float(np.count_nonzero(changed) / max(int(np.count_nonzero(seen)), 1))
        palette = palette[palette < HUE_RANGE]
    matches = np.zeros(codes.shape, bool)
    for code in palette:
        matches |= colours_match(codes, code, fitness.hue_threshold_in)
    model_share = float(np.count_nonzero(matches & changed) / max(int(np.count_nonzero(changed)), 1))
    confirmed = changed_share >= settings.min_changed and model_share >= settings.min_model_share
    return BoxCheck(bool(confirmed), changed_share, model_share, in_view)


def _chroma_moved(
    after: npt.NDArray[np.uint8], before: npt.NDArray[np.uint8], step: float
) -> npt.NDArray[np.bool_]:
    """Where the chroma (saturation as a vector at the hue's angle) moved by `step` or more
    between two views, HSV_FULL images: a measure of colour that exposure leaves alone."""

    def chroma(hsv_image: npt.NDArray[np.uint8]) -> npt.NDArray[np.float64]:
        hsv = hsv_image.astype(np.float64)
        angle = hsv[..., 0] * (2.0 * np.pi / HUE_RANGE)
        return hsv[..., 1:2] * np.stack([np.cos(angle), np.sin(angle)], axis=-1)

    moved: npt.NDArray[np.bool_] = np.linalg.norm(chroma(after) - chroma(before), axis=-1) >= step
    return moved


__all__ = [
    "WALL_NORMALS",
    "BoxCheck",
    "BoxCheckSettings",
    "BoxView",
    "RimView",
    "box_view",
    "check_box",
    "look_tcp",
    "rim_covered",
    "rim_points",
    "rim_runs",
    "rim_view",
]
