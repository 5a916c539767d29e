"""The height of the top cloth's surface at a grasp point, by the stereo pair of a survey.

The survey's pose of a cloth on a pile is the model fitted to its colours, its depth
fixed by a stereo plane through the outline's edges (`vision.stereo_depth`): on a pile the
lower cloths and the table around that outline pull it down (bench_clear_table episodes
30 and 32: the top cloth put 12 and 32 mm low). The fingers reach about 13 mm below the
surface the loop believes (the simulated grasp's radius less `loop.grasp_height`) and the
cloths of a pile lie 14-18 mm apart, so a low surface closes the fingers on the cloth
beneath too: a double pick.

`surface_height` sweeps horizontal planes over a patch of the right image around the
grasp point, inside the part of the target the survey saw (eroded, so that no lower
cloth or table beside it counts): the height whose plane best correlates the pair there
is the surface the fingers meet. The job (`TableClearer`) aims the grasp at it when the
measurement is trusted, else at the pose as before.
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
from robot_app.vision import ClothModel
from robot_app.vision.camera import StereoRig
from robot_app.vision.stereo_depth import DepthCheckSettings, StereoDepth, peak_shift


class SurfaceSettings(StrictModel):
    """Measuring the top surface at the grasp point (the `clear.surface` section).

    Attributes:
        enabled: aim the grasp at the measured surface (else at the pose's plane).
        radius: the patch around the grasp point [m]; when it holds too few textured
            pixels, twice that.
        close: gaps in the target's visible part up to about twice this wide are closed
            first (the identification leaves out the blurred pixels along its print's
            edges, which are the very pixels the pair can correlate) [px].
        erode: pixels then taken off the edge of the visible part [px].
        min_gradient: a pixel counts if its horizontal grey gradient is at least this
            (lower than the outline's check: the patch lies inside a cloth) [grey levels].
        min_samples: fewer textured pixels in the patch: not measured.
        min_correlation: the best plane's correlation must reach this to be trusted.
        below, above: heights swept, from this below the table to this above it [m].
        coarse_step, fine_step: the sweep's steps; a parabola through the best three [m].
    """

    enabled: bool = True
    radius: float = Field(0.02, gt=0.0, le=0.1)
    close: int = Field(4, ge=0, le=20)
    erode: int = Field(3, ge=0, le=20)
    min_gradient: float = Field(4.0, ge=0.0)
    min_samples: int = Field(40, ge=16)
    min_correlation: float = Field(0.7, ge=-1.0, le=1.0)
    below: float = Field(0.005, ge=0.0, le=0.05)
    above: float = Field(0.12, gt=0.0, le=0.3)
    coarse_step: float = Field(0.002, gt=0.0, le=0.01)
    fine_step: float = Field(0.0005, gt=0.0, le=0.005)


@dataclass(frozen=True)
class SurfaceHeight:
    """The surface measured around a grasp point.

    Attributes:
        z: its height in Σ_W [m] (NaN: not measured).
        correlation: of the best plane (-1 to 1; NaN: not measured).
        samples: textured pixels of the patch.
        trusted: enough pixels and a correlation of at least `min_correlation`.
    """

    z: float
    correlation: float
    samples: int
    trusted: bool


def surface_height(
    capture: StereoCapture,
    rig: StereoRig,
    model: ClothModel,
    depth_settings: DepthCheckSettings,
    visible: npt.NDArray[np.bool_],
    point_world: npt.ArrayLike,
    table_z: float,
    settings: SurfaceSettings,
) -> SurfaceHeight:
    """The top surface's height at `point_world` ((3,) or (2,) [m], Σ_W), measured on the
    pair of `capture` inside `visible` ((H, W) the target's pixels in the right image)."""
    point = np.asarray(point_world, dtype=float).ravel()
    return surface_heights(capture, rig, model, depth_settings, visible, point[None], table_z, settings)[0]


def surface_heights(
    capture: StereoCapture,
    rig: StereoRig,
    model: ClothModel,
    depth_settings: DepthCheckSettings,
    visible: npt.NDArray[np.bool_],
    points_world: npt.ArrayLike,
    table_z: float,
    settings: SurfaceSettings,
) -> list[SurfaceHeight]:
    """`surface_height` at each of `points_world` ((N, 3) or (N, 2) [m], Σ_W), the pair
    prepared once."""
    depth = StereoDepth(model, rig, depth_settings)
    depth.update(capture.left_bgr, capture.right_bgr)
    T = np.asarray(capture.transform_right_camera_to_world, dtype=float)
    inside = _eroded(_closed(visible, settings.close), settings.erode)
    points = np.atleast_2d(np.asarray(points_world, dtype=float))
    return [_measured(depth, T, rig.right.camera_matrix, inside, p, table_z, settings) for p in points]


def _measured(
    depth: StereoDepth,
    T: FloatArray,
    K: FloatArray,
    inside: npt.NDArray[np.bool_],
    point_world: FloatArray,
    table_z: float,
    settings: SurfaceSettings,
) -> SurfaceHeight:
    point = np.array([point_world[0], point_world[1], point_world[2] if len(point_world) > 2 else table_z])
    in_camera = T[:3, :3].T @ (point - T[:3, 3])
    if in_camera[2] <= 1e-6:
        return SurfaceHeight(float("nan"), float("nan"), 0, False)
    u, v = K[0, 0] * in_camera[0] / in_camera[2] + K[0, 2], K[1, 1] * in_camera[1] / in_camera[2] + K[1, 2]
    # planes z_W = h in Σ_CR: n = -(R's third row) points away from the camera, d = t_z - h
    normal = -T[2, :3]
    heights = np.arange(table_z - settings.below, table_z + settings.above + 1e-12, settings.coarse_step)
    samples, scores = 0, np.full(len(heights), -2.0)
    for scale in (1.0, 2.0):
        radius_px = scale * settings.radius * K[0, 0] / in_camera[2]
        patch = inside & _disk(inside.shape, u, v, radius_px)
        scores, samples = depth.sweep_mask(patch, _planes(normal, T[2, 3], heights), 1, settings.min_gradient)
        if samples >= settings.min_samples:
            break
    if samples < settings.min_samples or float(scores.max()) <= -2.0:
        return SurfaceHeight(float("nan"), float("nan"), samples, False)
    centre = float(heights[int(np.argmax(scores))])
    half = round(settings.coarse_step / settings.fine_step)
    fine = centre + np.arange(-half, half + 1, dtype=float) * settings.fine_step
    fine_scores, _ = depth.sweep_mask(patch, _planes(normal, T[2, 3], fine), 1, settings.min_gradient)
    j = int(np.argmax(fine_scores))
    z, best = float(fine[j]) + peak_shift(fine_scores, j, settings.fine_step), float(fine_scores[j])
    return SurfaceHeight(z, best, samples, best >= settings.min_correlation)


def aimed_at(
    transform_model_to_world: npt.ArrayLike, grasp_point_model: npt.ArrayLike, z: float
) -> FloatArray:
    """(3,) `grasp_point_model` (Σ_M [m]) moved along Σ_M's z axis so that the pose
    `transform_model_to_world` puts it at height `z` [m] in Σ_W: a flat cloth's pose,
    whose z axis is vertical, keeps it over the same table point."""
    T = np.asarray(transform_model_to_world, dtype=float)
    point = np.asarray(grasp_point_model, dtype=float).reshape(3).copy()
    if abs(T[2, 2]) < 1e-6:
        return point
    point[2] = (z - T[2, 3] - T[2, 0] * point[0] - T[2, 1] * point[1]) / T[2, 2]
    return point


def _planes(normal: FloatArray, camera_z: float, heights: FloatArray) -> FloatArray:
    """(D, 4) the planes z_W = h for each of `heights`, in Σ_CR."""
    return np.column_stack([np.tile(normal, (len(heights), 1)), camera_z - heights])


def _closed(mask: npt.NDArray[np.bool_], pixels: int) -> npt.NDArray[np.bool_]:
    if pixels == 0:
        return np.asarray(mask, dtype=bool)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * pixels + 1, 2 * pixels + 1))
    return np.asarray(cv2.morphologyEx(np.asarray(mask, dtype=np.uint8), cv2.MORPH_CLOSE, kernel), dtype=bool)


def _eroded(mask: npt.NDArray[np.bool_], pixels: int) -> npt.NDArray[np.bool_]:
    if pixels == 0:
        return np.asarray(mask, dtype=bool)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * pixels + 1, 2 * pixels + 1))
    return np.asarray(cv2.erode(np.asarray(mask, dtype=np.uint8), kernel), dtype=bool)


def _disk(shape: tuple[int, ...], u: float, v: float, radius: float) -> npt.NDArray[np.bool_]:
    rows, cols = np.ogrid[: shape[0], : shape[1]]
    return np.asarray((cols - u) ** 2 + (rows - v) ** 2 <= radius**2, dtype=bool)


__all__ = ["SurfaceHeight", "SurfaceSettings", "aimed_at", "surface_height", "surface_heights"]
