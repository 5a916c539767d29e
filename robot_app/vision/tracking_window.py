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
            last verification's appearance is carried over (1: every frame). Kept at 1 by
            measurement: 2 saves ~0.1-0.5 ms CPU a frame (scripts/bench_recognition.py
            --speed-only: 3.36 against 3.30 ms, within its noise) and the conveyor cell
            (bench_conveyor.py, 50 mm/s, 10 episodes) places 10/10 either way, but a
            carried appearance hides a track drifting off the cloth for that frame.
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
    x, y, z = pose[:3, 3]
    return SearchBoundsSettings(
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
    """Per image (left, right), the (u0, v0, u1, v1) box, inclusive and inside the image,
    that the model's points can reach with its origin anywhere in `window`, at any yaw and
    at any tilt the search can give it, a few pixels to spare; the whole image when a camera
    could see the model from behind.

    The window is grown by the model's radius in x and y and by `depth` in depth (None:
    `reach_in_depth` at `search_tilt_sine(window.max_tilt_deg)`); only the grown box's 8
    corners are projected: a pinhole's u and v are ratios of linear functions of the point,
    so over a box in front of the camera their extremes (and the least depth) lie at its
    corners. Compiled (`_corner_box`): as numpy calls on 8 points it cost ~0.25 ms a
    tracking frame."""
    radius = model.radius
    if depth is None:
        depth = reach_in_depth(radius, off_plane(model), search_tilt_sine(window.max_tilt_deg))
    low = np.array([window.x[0] - radius, window.y[0] - radius, window.z[0] - depth])
    high = np.array([window.x[1] + radius, window.y[1] + radius, window.z[1] + depth])
    width, height = rig.image_size
    left = _corner_box(low, high, rig.transform_right_to_left, rig.left.camera_matrix, width, height)
    right = _corner_box(low, high, _IDENTITY, rig.right.camera_matrix, width, height)
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


__all__ = [
    "TrackingSettings",
    "off_plane",
    "reach_in_depth",
    "reachable_regions",
    "search_tilt_sine",
    "window_around",
]
