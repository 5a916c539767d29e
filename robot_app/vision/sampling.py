"""Where a photo model puts its points: S_in and S_out samples of the cloth's mask.

The pose information of a silhouette is in its outline: a point deep inside the cloth
scores the same whether the model sits 3 mm left or right, a point 1 mm inside or
outside the outline does not. Two layouts (ModelSettings.sampling):

- "grid" (the paper's Fig. 4 read literally): S_in on a uniform grid through the
  centroid, S_out the grid points in a band `band_gap` .. `band_gap + band_width`
  outside the outline.
- "edge" (default): rings that follow the outline at fixed distances, points every
  `edge_spacing` along them: `edge_offsets` inside (S_in) and `band_rings` rings from
  `band_gap` to `band_gap + band_width` outside (S_out), plus the interior on a coarser
  `point_spacing` grid for the cloth's pattern. With `band_gap` at about one photo
  pixel the innermost S_out ring and the outermost S_in ring pin the outline from
  both sides, so depth (scale) and position are pinned to a pixel or so.

Points are returned in the photo plane relative to the Σ_M origin [m]; the ring points
are ordered along the outline and the strided subsets used by the GA (every n-th point)
stay spread all around it.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, NamedTuple

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.hue import HUE_RANGE, colour_codes, colours_match, hue_distance

if TYPE_CHECKING:
    from robot_app.vision.photo_model import ModelSettings

Image = npt.NDArray[np.uint8]


class ModelSamples(NamedTuple):
    """Sampled S_in and S_out (photo plane, relative to the Σ_M origin).

    Attributes:
        points_in: (N_in, 2) S_in [m].
        hues_in: (N_in,) colour code of each S_in point (hue 0-255, or DARK / LIGHT).
        points_out: (N_out, 2) S_out [m].
        grid_in: (G, 2) S_in on the uniform `point_spacing` grid [m] (for symmetry tests).
        grid_hues: (G,) their colour codes.
        weights_in: (N_in,) area each S_in point stands for / point_spacing².
        weights_out: (N_out,) the same for S_out.
    """

    points_in: FloatArray
    hues_in: npt.NDArray[np.uint16]
    points_out: FloatArray
    grid_in: FloatArray
    grid_hues: npt.NDArray[np.uint16]
    weights_in: FloatArray
    weights_out: FloatArray


def sample_model(
    mask: npt.NDArray[np.bool_],
    smooth_hsv: Image,
    camera: PinholeCamera,
    distance: float,
    origin: FloatArray,
    settings: ModelSettings,
    background_hue: float | None = None,
) -> ModelSamples:
    """Samples S_in and S_out of a cloth mask in the model photo.

    Args:
        mask: (H, W) S_in in the photo (holes filled).
        smooth_hsv: (H, W, 3) the lightly blurred photo in HSV_FULL.
        camera: the model camera.
        distance: lens to the cloth plane [m].
        origin: (2,) the Σ_M origin on the plane [m].
        settings: sampling settings (ModelSettings).
        background_hue: H̄_B; an S_in sample whose (blurred) hue lies within
            `min_hue_difference` of it is dropped (a tone never is). Such samples sit on
            dark parts of the cloth next to the sheet, where the blur mixes a little green
            into black and the low value turns that tint into a saturated background hue: a yellow-black
            check cloth had 84 of its 547 S_in points with the sheet's hue, which in the
            hand images scored as mismatches on the black squares (fitness 0.78 at the
            true pose) and would match the bare sheet.

    An S_in sample nearer than `colour_edge_gap` to a pixel of the cloth of another colour
    is dropped: the blur mixes colours there, and black next to yellow reads as dark
    yellow (the yellow-black checks had 69 of 712 S_in points yellow on black squares,
    fitness 0.885 at the true pose in the simulator's hand images).

    Returns:
        The samples. An S_in sample without hue (saturation < settings.min_saturation or
        value < settings.min_value) gets its tone (DARK / LIGHT) with settings.tones, and is
        dropped without.
    """
    metres_per_pixel = distance / float(camera.camera_matrix[0, 0])
    reach = settings.band_gap + settings.band_width + 2 * settings.point_spacing
    pad = int(np.ceil(reach / metres_per_pixel)) + 2
    padded = cv2.copyMakeBorder(mask.astype(np.uint8), pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    outside_px = cv2.distanceTransform(1 - padded, cv2.DIST_L2, 5)  # distance to S_in [px]
    inside_px = cv2.distanceTransform(padded, cv2.DIST_L2, 5)  # distance to the outside [px]

    s = settings
    photo_codes = colour_codes(smooth_hsv, s.min_saturation, s.min_value, s.value_split)
    clear = _away_from_colour_edges(
        photo_codes, mask, round(s.colour_edge_gap / metres_per_pixel), background_hue, s.min_hue_difference
    )

    def usable_colours(uv: npt.NDArray[np.intp]) -> tuple[npt.NDArray[np.uint16], npt.NDArray[np.bool_]]:
        u = np.clip(uv[:, 0] - pad, 0, camera.width - 1)
        v = np.clip(uv[:, 1] - pad, 0, camera.height - 1)
        codes = photo_codes[v, u]
        hued = codes < HUE_RANGE
        usable = ~hued if settings.tones else np.zeros(len(codes), dtype=bool)
        if background_hue is not None:
            usable |= hued & (hue_distance(codes, background_hue) > settings.min_hue_difference)
        else:
            usable |= hued
        return codes, usable & clear[v, u]

    def plane(uv: npt.NDArray[np.intp]) -> FloatArray:
        return _pixels_to_plane(camera, distance, uv - pad) - origin

    # The uniform grid through the Σ_M origin, in padded pixel indices.
    step = settings.point_spacing
    grid_uv = _grid_pixels(camera, distance, origin, step, padded.shape, pad)
    on_cloth = padded[grid_uv[:, 1], grid_uv[:, 0]].astype(bool)
    grid_hues, grid_usable = usable_colours(grid_uv)
    take = on_cloth & grid_usable
    grid_in, grid_in_hues = plane(grid_uv[take]), grid_hues[take]
    if settings.sampling == "grid":
        gap = outside_px[grid_uv[:, 1], grid_uv[:, 0]] * metres_per_pixel
        band = ~on_cloth & (gap > settings.band_gap) & (gap <= settings.band_gap + settings.band_width)
        out = plane(grid_uv[band])
        return ModelSamples(
            grid_in, grid_in_hues, out, grid_in, grid_in_hues, np.ones(len(grid_in)), np.ones(len(out))
        )

    spacing_px = settings.edge_spacing / metres_per_pixel
    offsets = sorted(settings.edge_offsets)
    ring_uv = [_ring(inside_px >= d / metres_per_pixel, spacing_px) for d in offsets]
    interior_depth = offsets[-1] + 0.5 * step  # interior grid points lie deeper than this
    interior = take & (inside_px[grid_uv[:, 1], grid_uv[:, 0]] > interior_depth / metres_per_pixel)
    in_uv = np.concatenate([*ring_uv, grid_uv[interior]])
    # Each ring stands for the strip from the midpoints to its neighbours (the outermost
    # from the outline, the innermost to where the interior cells begin).
    limits = [0.0, *((a + b) / 2 for a, b in itertools.pairwise(offsets)), offsets[-1]]
    ring_weights = [settings.edge_spacing * (hi - lo) / step**2 for lo, hi in itertools.pairwise(limits)]
    weights_in = np.concatenate(
        [*(np.full(len(r), w) for r, w in zip(ring_uv, ring_weights, strict=True)), np.ones(interior.sum())]
    )
    hues, usable = usable_colours(in_uv)
    in_uv, hues, weights_in = in_uv[usable], hues[usable], weights_in[usable]
    distances = np.linspace(settings.band_gap, settings.band_gap + settings.band_width, settings.band_rings)
    out_weight = (
        settings.edge_spacing
        * max(settings.band_width / settings.band_rings, settings.edge_spacing)
        / step**2
    )
    # The boundary of "farther than d from the cloth" (its frame at the padded border aside).
    out_uv = np.concatenate([_ring(outside_px > d / metres_per_pixel, spacing_px) for d in distances])
    height, width = padded.shape
    frame = (
        (out_uv[:, 0] == 0) | (out_uv[:, 1] == 0) | (out_uv[:, 0] == width - 1) | (out_uv[:, 1] == height - 1)
    )
    out_uv = out_uv[~frame]
    return ModelSamples(
        plane(in_uv), hues, plane(out_uv), grid_in, grid_in_hues, weights_in, np.full(len(out_uv), out_weight)
    )


def _away_from_colour_edges(
    codes: npt.NDArray[np.uint16],
    mask: npt.NDArray[np.bool_],
    radius: int,
    background_hue: float | None,
    hue_threshold: int,
) -> npt.NDArray[np.bool_]:
    """(H, W): pixels whose colour matches every cloth pixel within `radius` (a square
    window); pixels outside the mask or of the background's hue (the sheet mixed in along
    the outline) do not count as another colour."""
    clear = np.ones(codes.shape, dtype=bool)
    if radius < 1:
        return clear
    other = mask.copy()
    if background_hue is not None:
        other &= ~((codes < HUE_RANGE) & (hue_distance(codes, background_hue) <= hue_threshold))
    height, width = codes.shape
    for dv in range(-radius, radius + 1):
        for du in range(-radius, radius + 1):
            if du == 0 and dv == 0:
                continue
            # the neighbour at (v + dv, u + du) of every pixel (v, u) that has one
            target = (slice(max(0, -dv), height - max(0, dv)), slice(max(0, -du), width - max(0, du)))
            source = (slice(max(0, dv), height - max(0, -dv)), slice(max(0, du), width - max(0, -du)))
            differs = other[source] & ~colours_match(codes[target], codes[source], hue_threshold)
            clear[target] &= ~differs
    return clear


def _ring(region: npt.NDArray[np.bool_], spacing_px: float) -> npt.NDArray[np.intp]:
    """Pixels every `spacing_px` along the boundaries of `region`, (N, 2) (u, v)."""
    contours, _ = cv2.findContours(region.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    picked = []
    for contour in contours:
        c = contour.reshape(-1, 2)
        closed = np.vstack([c, c[:1]]).astype(float)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
        if arc[-1] < spacing_px:
            continue  # a speck of a ring: nothing to pin
        n = int(arc[-1] // spacing_px)
        at = (np.arange(n) + 0.5) * (arc[-1] / n)
        picked.append(c[np.minimum(np.searchsorted(arc, at), len(c) - 1)])
    if not picked:
        return np.zeros((0, 2), np.intp)
    return np.concatenate(picked).astype(np.intp)


def _grid_pixels(
    camera: PinholeCamera, distance: float, origin: FloatArray, step: float, shape: tuple[int, ...], pad: int
) -> npt.NDArray[np.intp]:
    """Nearest padded-photo pixel of every point of the `step` grid through `origin` that lands
    in the padded photo, (N, 2) (u, v)."""
    height, width = shape[:2]
    corners = _pixels_to_plane(camera, distance, np.array([[-pad, -pad], [width - pad, height - pad]]))
    lo, hi = corners.min(axis=0) - origin, corners.max(axis=0) - origin
    gx, gy = (
        np.arange(np.ceil(a / step), np.floor(b / step) + 1) * step for a, b in zip(lo, hi, strict=True)
    )
    grid = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2) + origin
    pixels = camera.project(np.column_stack([grid, np.full(len(grid), distance)]))
    uv = np.rint(pixels).astype(np.intp) + pad
    keep = (uv[:, 0] >= 0) & (uv[:, 0] < width) & (uv[:, 1] >= 0) & (uv[:, 1] < height)
    return uv[keep]


def _pixels_to_plane(camera: PinholeCamera, distance: float, uv: npt.ArrayLike) -> FloatArray:
    """(N, 2) pixel positions -> (N, 2) points on the photo plane at `distance` [m]."""
    pixels = np.asarray(uv, dtype=float).reshape(-1, 2)
    K = camera.camera_matrix
    if camera.has_distortion:
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        normal = cv2.undistortPoints(pixels.reshape(-1, 1, 2), K, camera.dist_coeffs, criteria=criteria)
        return np.asarray(normal.reshape(-1, 2) * distance, dtype=float)
    return (
        np.column_stack([(pixels[:, 0] - K[0, 2]) / K[0, 0], (pixels[:, 1] - K[1, 2]) / K[1, 1]]) * distance
    )


__all__ = ["ModelSamples", "sample_model"]
