"""The tracking window: where a multi-step frame searches, and which pixels it can reach.

Between frames the kept poses move by the camera motion (Sec. II-E); the next frame's GA
searches a window around the best moved pose, `window` in x-y and `depth_window` in
depth (the window moves with the camera, so a descending camera keeps its cloth). A
model in that window, at any yaw and tilt, covers only part of each image: only those
pixels need colour codes (`FitnessEvaluator.update(regions=...)`), which halves a
tracking frame's pixel work for a cloth that fills a third of the image.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit
from pydantic import Field, field_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.camera import StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.ga import GASettings, SearchBoundsSettings


class TrackingSettings(StrictModel):
    """Multi-step proposal between frames.

    Attributes:
        ga: the tracking GA (its `generations` are per frame; 24 individuals, one island).
        window: half-width of the x-y search window around the motion-predicted pose [m].
        depth_window: half-width of the depth window [m]; the window moves with the
            camera, so a descending camera keeps its cloth.
        verify_every: verify (and decide) on every n-th tracking frame; between them the
            last verification's appearance is carried over (1: every frame), so a wrong
            pose is tracked at most n - 1 frames unverified. Kept at 1 by measurement: 2
            saves ~0.1-0.5 ms CPU a frame (scripts/bench_recognition.py --speed-only: 3.36
            against 3.30 ms, within its noise) and the conveyor cell (bench_conveyor.py,
            50 mm/s, 10 episodes) places 10/10 either way, but a carried appearance hides a
            track drifting off the cloth for that frame. Measured again in session 13 on
            the cheaper frame: 2 saves 0.16-0.23 ms a frame over 150 frames, five
            --speed-only runs' median 2.73 against 2.77 ms; bench_conveyor.py servo 25 and
            50 mm/s, 20 episodes each: placed 20 + 20 against 20 + 19, but the grasp offset's
            95th percentile at 25 mm/s 10.1 -> 26.1 mm (episode 19, navy No.15: 9.7 -> 39.6
            mm) and the descent's tracking error p95 9.1 -> 17.5 mm: not adopted.
        yaw_window_deg: half-width of the yaw window around the motion-predicted pose
            [deg]: a tracked cloth turns little between frames, while the hue fitness
            cannot tell a plain cloth from its half turn, so a GA free in yaw flipped a
            denim rectangle half a turn on the first tracking frame (pick-and-place,
            realistic cell: every frame 180 deg off, the filter rejected them all).
        view_floor: the tracking GA's (min_view_fraction, hidden_penalty) of the search
            fitness's "view" normalisation; None: the search fitness's own. Near the cloth
            only part of it is in view, and the search's floor (a pose with less than 30 %
            of its points in view scores in proportion to them) and its hidden penalty pay
            a pose for bringing more of the model into view: farther and towards the middle
            of the image. A descending camera's tracked pose slid with them, 10 mm off at a
            camera-to-cloth distance of 0.16 m and 31 mm at 0.10 m (scripts/bench_close_range.py);
            the window around the moved pose already keeps the far, squeezed poses out
            that the floor is for, so tracking scores the points in view.
    """

    ga: GASettings = GASettings(population=24, generations=3, islands=1, elite=2)
    window: float = Field(default=0.02, gt=0.0)
    depth_window: float = Field(default=0.03, gt=0.0)
    verify_every: int = Field(default=1, ge=1)
    yaw_window_deg: float = Field(default=30.0, gt=0.0, le=180.0)
    view_floor: tuple[float, float] | None = (0.05, 0.0)

    @field_validator("view_floor")
    @classmethod
    def _fractions(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and not (0.0 < value[0] <= 1.0 and 0.0 <= value[1] <= 1.0):
            raise ValueError(
                f"view_floor needs min_view_fraction in (0, 1] and hidden_penalty in [0, 1], got {value}"
            )
        return value


def window_around(
    pose: FloatArray, tracking: TrackingSettings, bounds: SearchBoundsSettings
) -> SearchBoundsSettings:
    """The search window around `pose` ^CR T_M: `tracking.window` in x-y, `depth_window` in
    depth, the tilt and yaw bounds of `bounds`."""
    x, y, z = (float(value) for value in pose[:3, 3])
    if not np.isfinite([x, y, z]).all():
        raise ValueError(f"the tracking window needs a finite pose position, got {(x, y, z)}")
    # built without pydantic's validation (~0.05-0.08 ms a tracking frame with the caches
    # cold): the ranges increase (windows > 0, depth clamped), tilt and yaw come from `bounds`
    return SearchBoundsSettings.model_construct(
        x=(x - tracking.window, x + tracking.window),
        y=(y - tracking.window, y + tracking.window),
        z=(max(z - tracking.depth_window, 1e-3), max(z + tracking.depth_window, 2e-3)),
        max_tilt_deg=bounds.max_tilt_deg,
        max_yaw_deg=bounds.max_yaw_deg,
    )


_jit = njit(cache=True, nogil=True, error_model="numpy")


def reachable_regions(
    window: SearchBoundsSettings, model: ClothModel, rig: StereoRig, depth: float | None = None
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Per image (left, right), the (H, 2) row spans (first and last column of each row,
    inclusive; (0, -1) for a row without any) that the model's points can reach with its
    origin anywhere in `window`, at any yaw and at any tilt the search can give it, a few
    pixels to spare; the whole image when a camera could see the model from behind.

    A point of the model lies within `model.radius` (its farthest point) of the origin
    across the camera's axis and within `depth` along it (None: `reach_in_depth` at
    `search_tilt_sine(window.max_tilt_deg)`): the points reach no farther than the window's
    box grown by a disk of that radius in x-y and by `depth` in depth. That set is convex
    and lies inside the box grown by a 16-gon around the disk (`_SIDES`), whose 128
    corners are projected; each row's span is that of their convex hull, 4 px to spare
    around it (a point is read at its nearest pixel, or at the two around it), and never
    wider than the box of the grown window's 8 corners (`_corner_box`, which was the
    region before: a disk's square, 21 % more pixels for the bench's tracking cloth).
    Compiled (`_hull_spans`, ~20 us an image)."""
    radius = model.radius
    if depth is None:
        depth = reach_in_depth(radius, off_plane(model), search_tilt_sine(window.max_tilt_deg))
    low = np.array([window.x[0], window.y[0], window.z[0] - depth])
    high = np.array([window.x[1], window.y[1], window.z[1] + depth])
    width, height = rig.image_size
    left = _hull_spans(low, high, radius, rig.transform_right_to_left, rig.left.camera_matrix, width, height)
    right = _hull_spans(low, high, radius, _IDENTITY, rig.right.camera_matrix, width, height)
    return left, right


def search_tilt_sine(max_tilt_deg: float) -> float:
    """The sine of the largest tilt the search scores in a window of `max_tilt_deg`: the GA
    bounds the tilt's quaternion parts ε1, ε2 by sin(max_tilt / 2) each
    (`SearchBoundsSettings.gene_ranges`), so cos tilt = 1 - 2(ε1² + ε2²) >= 1 - 4
    sin²(max_tilt / 2) (its diagonal, ~1.4x max_tilt; 1 past a right angle), and the
    refinement keeps the tilt within max_tilt."""
    cos_tilt = 1.0 - 4.0 * np.sin(np.deg2rad(max_tilt_deg) / 2.0) ** 2
    return 1.0 if cos_tilt <= 0.0 else float(np.sqrt(1.0 - cos_tilt * cos_tilt))


def reach_in_depth(radius: float, off_plane: float, tilt_sine: float) -> float:
    """How far in depth [m] a point of a model of `radius` and `off_plane` (`off_plane`)
    can lie from the model's origin at a tilt whose sine is at most `tilt_sine`: a point p
    of Σ_M lies at most |p_xy| sin(tilt) + |p_z| from it in depth, and never more than |p|.
    With a flat model (z = 0) and the search's max_tilt of 20°, 0.48 of the radius: the
    near side of the window comes less close, and a fifth fewer pixels need colour codes
    (the bench's tracking cloth) than growing the depth by the radius."""
    return min(radius, radius * tilt_sine + off_plane)


def off_plane(model: ClothModel) -> float:
    """The largest |z| of a model point [m] (0 for a flat model)."""
    return max(float(np.max(np.abs(p[:, 2]), initial=0.0)) for p in (model.points_in, model.points_out))


_IDENTITY = np.eye(4)


@_jit
def _corner_box(low, high, to_camera, K, width, height):
    """The (u0, v0, u1, v1) int64 box of `reachable_regions` in one camera: the 8 corners
    of the box [low, high] (Σ_CR) through `to_camera` (^C T_CR) and `K`, 3 px to spare
    (4 on the far sides), floored and clipped to the image; the whole image if a corner
    lies at or behind 1 mm of depth."""
    u_min, v_min, u_max, v_max = np.inf, np.inf, -np.inf, -np.inf
    for corner in range(8):
        p0 = high[0] if corner & 4 else low[0]
        p1 = high[1] if corner & 2 else low[1]
        p2 = high[2] if corner & 1 else low[2]
        x = p0 * to_camera[0, 0] + p1 * to_camera[0, 1] + p2 * to_camera[0, 2] + to_camera[0, 3]
        y = p0 * to_camera[1, 0] + p1 * to_camera[1, 1] + p2 * to_camera[1, 2] + to_camera[1, 3]
        z = p0 * to_camera[2, 0] + p1 * to_camera[2, 1] + p2 * to_camera[2, 2] + to_camera[2, 3]
        if z <= 1e-3:
            return np.array([0, 0, width - 1, height - 1], dtype=np.int64)
        u = K[0, 0] * (x / z) + K[0, 1] * (y / z) + K[0, 2]
        v = K[1, 0] * (x / z) + K[1, 1] * (y / z) + K[1, 2]
        u_min, u_max = min(u_min, u), max(u_max, u)
        v_min, v_max = min(v_min, v), max(v_max, v)
    box = np.empty(4, dtype=np.int64)
    limits = (width - 1, height - 1, width - 1, height - 1)
    values = (u_min - 3.0, v_min - 3.0, u_max + 4.0, v_max + 4.0)
    for k in range(4):
        box[k] = np.int64(min(max(np.floor(values[k]), 0.0), float(limits[k])))
    return box


_SIDES = 16  # the polygon around the model's disk: its sides touch the circle (1.9 % more area)
_MARGIN = 4.0  # pixels to spare around the hull (the box had 3 on its near sides, 4 on its far)


@_jit
def _hull_spans(low, high, radius, to_camera, K, width, height):
    """The (height, 2) int64 row spans of `reachable_regions` in one camera: the box
    [low, high] (Σ_CR) grown in x-y by a `_SIDES`-gon whose sides touch the circle of
    `radius` (so it holds the disk and lies in its square), its corners through
    `to_camera` (^C T_CR) and `K`; per row, the columns of their convex hull within
    `_MARGIN` rows, `_MARGIN` px to spare, inside the box of `_corner_box`; the whole
    image if a corner lies at or behind 1 mm of depth."""
    grown_low = np.array([low[0] - radius, low[1] - radius, low[2]])
    grown_high = np.array([high[0] + radius, high[1] + radius, high[2]])
    box = _corner_box(grown_low, grown_high, to_camera, K, width, height)
    spans = np.zeros((height, 2), dtype=np.int64)
    spans[:, 1] = -1
    n = 8 * _SIDES
    u = np.empty(n)
    v = np.empty(n)
    outer = radius / np.cos(np.pi / _SIDES)
    k = 0
    for corner in range(8):
        for side in range(_SIDES):
            angle = (side + 0.5) * (2.0 * np.pi / _SIDES)
            p0 = (high[0] if corner & 4 else low[0]) + outer * np.cos(angle)
            p1 = (high[1] if corner & 2 else low[1]) + outer * np.sin(angle)
            p2 = high[2] if corner & 1 else low[2]
            x = p0 * to_camera[0, 0] + p1 * to_camera[0, 1] + p2 * to_camera[0, 2] + to_camera[0, 3]
            y = p0 * to_camera[1, 0] + p1 * to_camera[1, 1] + p2 * to_camera[1, 2] + to_camera[1, 3]
            z = p0 * to_camera[2, 0] + p1 * to_camera[2, 1] + p2 * to_camera[2, 2] + to_camera[2, 3]
            if z <= 1e-3:
                spans[:, 0], spans[:, 1] = 0, width - 1
                return spans
            u[k] = K[0, 0] * (x / z) + K[0, 1] * (y / z) + K[0, 2]
            v[k] = K[1, 0] * (x / z) + K[1, 1] * (y / z) + K[1, 2]
            k += 1
    hull_u, hull_v = _convex_hull(u, v)
    m = hull_u.shape[0]
    first = max(int(np.floor(hull_v.min() - _MARGIN)), box[1])
    last = min(int(np.ceil(hull_v.max() + _MARGIN)), box[3])
    for row in range(first, last + 1):
        top, bottom = row - _MARGIN, row + _MARGIN
        a, b = np.inf, -np.inf
        for e in range(m):  # each hull edge's part within the rows [top, bottom]
            ua, va = hull_u[e], hull_v[e]
            ub, vb = hull_u[(e + 1) % m], hull_v[(e + 1) % m]
            if max(va, vb) < top or min(va, vb) > bottom:
                continue
            if va == vb:
                a, b = min(a, ua, ub), max(b, ua, ub)
                continue
            t_top, t_bottom = (top - va) / (vb - va), (bottom - va) / (vb - va)
            for t in (max(min(t_top, t_bottom), 0.0), min(max(t_top, t_bottom), 1.0)):
                end = ua + t * (ub - ua)  # the ends of the edge's part within the rows
                a, b = min(a, end), max(b, end)
        if a > b:
            continue
        spans[row, 0] = max(int(np.floor(a - _MARGIN)), box[0])
        spans[row, 1] = min(int(np.ceil(b + _MARGIN)), box[2])
    return spans


@_jit
def _convex_hull(u, v):
    """The convex hull of the points (u, v), its corners in order (Andrew's monotone chain)."""
    by_v = np.argsort(v, kind="mergesort")
    order = by_v[np.argsort(u[by_v], kind="mergesort")]  # by u, then by v
    n = order.shape[0]
    hull = np.empty(2 * n, dtype=np.int64)
    size = 0
    for rank in range(n):  # lower chain
        k = order[rank]
        while size >= 2 and _turn(u, v, hull[size - 2], hull[size - 1], k) <= 0.0:
            size -= 1
        hull[size] = k
        size += 1
    lower = size + 1
    for rank in range(n - 2, -1, -1):  # upper chain
        k = order[rank]
        while size >= lower and _turn(u, v, hull[size - 2], hull[size - 1], k) <= 0.0:
            size -= 1
        hull[size] = k
        size += 1
    corners = hull[: max(size - 1, 1)]
    return u[corners], v[corners]


@_jit
def _turn(u, v, a, b, c):
    """The cross product (b - a) x (c - a): > 0 for a left turn."""
    return (u[b] - u[a]) * (v[c] - v[a]) - (v[b] - v[a]) * (u[c] - u[a])


__all__ = [
    "TrackingSettings",
    "off_plane",
    "reach_in_depth",
    "reachable_regions",
    "search_tilt_sine",
    "window_around",
]
