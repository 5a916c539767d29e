"""Making a cloth model from one photo (paper Sec. II-B, Fig. 4).

A photo of the cloth lying flat on a green sheet, taken by the model camera at a known
distance (Fig. 7, paper: 400 mm), becomes a `cloth_model.ClothModel`: S_in, the pixels
whose hue differs from the average background hue H̄_B, each with its colour code, and
S_out, a band enveloping S_in that must look like background (`sampling.py` places the
points), in metres in Σ_M; the yaws under which the cloth looks the same; the photo's
texture around the cloth and the sheet's colour.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field, field_validator

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.errors import InputError, ModelError
from robot_app.geometry import rotation_about_z
from robot_app.input_files import read_image
from robot_app.vision.camera import ModelCamera, PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.hue import (
    HUE_RANGE,
    circular_mean_hue,
    colour_codes,
    colours_match,
    hue_distance,
    to_hsv,
)
from robot_app.vision.sampling import sample_model

Image = npt.NDArray[np.uint8]

_TEXTURE_MARGIN_PX = 4  # photo pixels kept around the cloth's bounding box


class ModelSettings(StrictModel):
    """How a photo becomes a model (paper Sec. II-B).

    Pixels whose saturation is below `min_saturation`, or whose value is below
    `min_value`, have no meaningful hue (white, grey, black): they belong to the cloth's
    outline (the sheet is saturated green), so S_out stays outside the whole cloth. With
    `tones` (beyond the paper) they are sampled into S_in with a tone, DARK (value below
    `value_split`) or LIGHT, that the fitness matches against pixels of the same tone
    (its `FitnessSettings.min_saturation` etc. should be the same); without, they carry no
    sample, as in the paper's hue-only model, and a cloth's black or white parts add
    nothing to its fitness: a yellow-black check cloth then scored 0.83 at its true pose
    in the simulator, and a maroon cloth with white dots matched itself half-turned.

    Where the points go is `sampling` (see `robot_app.vision.sampling`): "edge" (rings
    along the outline at `edge_offsets` inside and `band_rings` rings from `band_gap` to
    `band_gap + band_width` outside, every `edge_spacing`, plus the interior on a
    `point_spacing` grid) or "grid" (the paper's uniform grid and band).
    """

    sampling: Literal["edge", "grid"] = "edge"
    point_spacing: float = Field(0.008, gt=0.0005, le=0.05, description="S_in (interior) grid step [m]")
    edge_spacing: float = Field(0.004, gt=0.0005, le=0.05, description="step along the edge rings [m]")
    edge_offsets: tuple[float, ...] = Field(
        (0.001, 0.004), min_length=1, description="S_in rings inside the outline [m]"
    )
    band_rings: int = Field(2, ge=1, le=10, description="S_out rings from band_gap to band_gap+band_width")
    band_width: float = Field(0.008, ge=0.0, le=0.1, description="width of the S_out band [m]")
    band_gap: float = Field(0.001, ge=0.0, le=0.05, description="outline to the first S_out ring [m]")
    min_hue_difference: int = Field(30, gt=0, lt=128, description="cloth vs background hue [0-255]")
    min_saturation: int = Field(40, ge=0, lt=255, description="below this, hue is undefined [0-255]")
    min_value: int = Field(40, ge=0, lt=255, description="below this too (dark pixels) [0-255]")
    value_split: int = Field(128, ge=1, le=255, description="DARK below, LIGHT from here [0-255]")
    tones: bool = True
    colour_edge_gap: float = Field(
        0.001, ge=0.0, le=0.01, description="S_in samples this near another colour are dropped [m]"
    )
    speckle_size: float = Field(0.003, ge=0.0, le=0.05, description="specks smaller are removed [m]")
    min_object_area: float = Field(1e-4, gt=0.0, description="smallest cloth area kept [m²]")
    largest_object_only: bool = True
    fill_holes: bool = True
    min_background_agreement: float = Field(
        0.9, gt=0.5, le=1.0, description="share of background pixels within the hue threshold"
    )
    symmetry_agreement: float = Field(0.9, gt=0.5, le=1.0, description="self-overlap to call a yaw symmetric")
    symmetry_texture: float = Field(
        0.7, gt=0.0, le=1.0, description="and the photo's lightness correlation with itself turned (textured)"
    )

    @field_validator("edge_offsets")
    @classmethod
    def _offsets_inside(cls, offsets: tuple[float, ...]) -> tuple[float, ...]:
        if any(not 0.0 < d <= 0.05 for d in offsets):
            raise ValueError("edge_offsets must be distances in (0, 0.05] m inside the outline")
        return offsets


def load_photo(path: str | Path) -> Image:
    """Reads a colour image file as (H, W, 3) uint8 BGR.

    Raises:
        InputError: missing, a folder, or not a readable image.
        ResourceError: too large for the default memory limit.
    """
    return read_image(path).bgr  # header and size checked first; libpng warnings kept quiet


def make_model(
    photo_bgr: Image,
    model_camera: ModelCamera,
    background_bgr: Image | None = None,
    settings: ModelSettings | None = None,
    name: str = "cloth",
    *,
    sources: Mapping[str, str] | None = None,
) -> ClothModel:
    """Makes a cloth model from a photo of the cloth lying on a uniform (green) sheet.

    Args:
        photo_bgr: (H, W, 3) uint8 photo from `model_camera` (Fig. 4 b).
        model_camera: its intrinsics and distance to the sheet [m].
        background_bgr: optional photo of the empty sheet (Fig. 4 a); without it the
            background hue is estimated from the photo's border.
        settings: sampling and segmentation settings (defaults if None).
        name: the model's name.
        sources: file names to record in the metadata (photo, background, camera).

    Raises:
        InputError: an image of the wrong type or size for the camera (`key` photo or
            background).
        ModelError: a background that is not uniform or not coloured, or no cloth (`key`
            photo or background), or too few points (`key` point_spacing).
    """
    settings = ModelSettings() if settings is None else settings
    camera = model_camera.camera
    hsv = _checked_hsv(photo_bgr, camera, "photo", "photo")
    if background_bgr is not None:
        background_hsv = _checked_hsv(background_bgr, camera, "background photo", "background")
        H_B, agreement = _background_hue(
            background_hsv.reshape(-1, 3), settings, "background photo", "background"
        )
    else:
        H_B, agreement = _background_hue(_border(hsv), settings, "photo border", "photo")
    metric = _metric_grid(camera, model_camera.distance)  # (H, W, 2) photo plane [m]
    metres_per_pixel = model_camera.distance / float(camera.camera_matrix[0, 0])
    mask, n_objects = _cloth_mask(hsv, H_B, settings, metres_per_pixel)  # S_in of Fig. 4 (c)
    origin = metric[mask].mean(axis=0)  # Σ_M origin: centroid of S_in [m]
    xy = metric[mask] - origin
    extent = (float(np.ptp(xy[:, 0]) + metres_per_pixel), float(np.ptp(xy[:, 1]) + metres_per_pixel))

    smooth = to_hsv(
        np.asarray(cv2.GaussianBlur(np.ascontiguousarray(photo_bgr), (0, 0), 1.0), dtype=np.uint8)
    )
    samples = sample_model(mask, smooth, camera, model_camera.distance, origin, settings, H_B)
    if len(samples.points_in) < 3:
        raise ModelError(
            f"the cloth has only {len(samples.points_in)} sample points at point_spacing="
            f"{settings.point_spacing} m; use a smaller point_spacing or a larger cloth",
            key="point_spacing",
            value=settings.point_spacing,
            expected="a spacing that gives the cloth at least 3 points",
        )
    points_in = np.column_stack([samples.points_in, np.zeros(len(samples.points_in))])
    hues_in = samples.hues_in
    points_out = np.column_stack([samples.points_out, np.zeros(len(samples.points_out))])
    inside_px = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 5)
    deepest = inside_px >= inside_px.max() - 1.0  # on a ridge, the point nearest the centroid
    grasp_xy = metric[deepest][np.argmin(np.linalg.norm(metric[deepest] - origin, axis=1))] - origin
    grasp = np.append(grasp_xy, 0.0)
    metadata = {
        "photo_size": [camera.width, camera.height],
        "metres_per_pixel": metres_per_pixel,
        "model_camera": model_camera.to_dict(),
        "origin_in_photo_plane": origin.tolist(),  # Σ_M origin in the photo camera's plane [m]
        "background": "background photo" if background_bgr is not None else "photo border",
        "background_agreement": agreement,
        "objects": n_objects,
        "area_m2": float(mask.sum() * metres_per_pixel**2),
        "settings": settings.model_dump(mode="json"),
        "sources": dict(sources or {}),
    }
    grid = np.column_stack([samples.grid_in, np.zeros(len(samples.grid_in))])
    lightness = cv2.GaussianBlur(
        cv2.cvtColor(np.ascontiguousarray(photo_bgr), cv2.COLOR_BGR2GRAY), (0, 0), 2.0
    )

    def lightness_at(points: FloatArray) -> FloatArray:
        u, v = _to_pixel_index(camera, model_camera.distance, points[:, :2] + origin)
        u, v = np.clip(u, 0, camera.width - 1), np.clip(v, 0, camera.height - 1)
        return np.asarray(lightness[v, u], dtype=float)

    symmetry = _symmetry_angles(grid, samples.grid_hues, settings.point_spacing, settings, lightness_at)
    texture, texture_mask, texture_from_model = _texture(
        photo_bgr, mask, camera, model_camera.distance, origin
    )
    sheet = _sheet_colour(photo_bgr, hsv, mask, H_B, settings)
    return ClothModel(
        name,
        points_in,
        hues_in,
        points_out,
        H_B,
        grasp,
        extent,
        symmetry,
        metadata,
        weights_in=samples.weights_in,
        weights_out=samples.weights_out,
        texture_bgr=texture,
        texture_mask=texture_mask,
        texture_from_model=texture_from_model,
        sheet_bgr=sheet,
    )


def _texture(
    photo_bgr: Image, mask: npt.NDArray[np.bool_], camera: PinholeCamera, distance: float, origin: FloatArray
) -> tuple[Image, npt.NDArray[np.bool_], FloatArray]:
    """The photo (undistorted) cropped around the cloth, its mask there and the affine map
    of Σ_M (x, y) [m] to the crop's pixels."""
    K = camera.camera_matrix
    photo = np.ascontiguousarray(photo_bgr)
    if camera.has_distortion:
        photo = np.asarray(cv2.undistort(photo, K, camera.dist_coeffs, None, K), dtype=np.uint8)
        mask = cv2.undistort(mask.astype(np.uint8), K, camera.dist_coeffs, None, K).astype(bool)
    rows, cols = np.nonzero(mask)
    m = _TEXTURE_MARGIN_PX
    v0, v1 = max(int(rows.min()) - m, 0), min(int(rows.max()) + m + 1, camera.height)
    u0, u1 = max(int(cols.min()) - m, 0), min(int(cols.max()) + m + 1, camera.width)
    fx, fy = K[0, 0] / distance, K[1, 1] / distance  # [px/m] on the cloth plane
    affine = np.array([[fx, 0.0, fx * origin[0] + K[0, 2] - u0], [0.0, fy, fy * origin[1] + K[1, 2] - v0]])
    return photo[v0:v1, u0:u1].copy(), mask[v0:v1, u0:u1].copy(), affine


def _sheet_colour(
    photo_bgr: Image, hsv: Image, mask: npt.NDArray[np.bool_], H_B: float, settings: ModelSettings
) -> FloatArray:
    """Median (b, g, r) of the sheet in the photo: saturated background-hued pixels away
    from the cloth."""
    near = cv2.dilate(mask.astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool)
    sheet = (
        ~near
        & (hsv[..., 1] >= settings.min_saturation)
        & (hue_distance(hsv[..., 0], H_B) <= settings.min_hue_difference // 2)
    )
    return np.maximum(np.median(np.asarray(photo_bgr)[sheet].reshape(-1, 3), axis=0), 1.0).astype(float)


def _checked_hsv(image: Image, camera: PinholeCamera, what: str, key: str) -> Image:
    """`image` in HSV_FULL; an `InputError` with `key` (photo, background) if it is not an
    (H, W, 3) uint8 image of the camera's size."""
    array = np.asarray(image)
    if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
        raise InputError(
            f"{what} must be an (H, W, 3) uint8 colour image, got {array.shape} {array.dtype}",
            key=key,
            value=(array.shape, str(array.dtype)),
            expected="an (H, W, 3) uint8 colour image",
        )
    if array.shape[:2] != (camera.height, camera.width):
        raise InputError(
            f"{what} is {array.shape[1]}x{array.shape[0]} px but the camera file says "
            f"{camera.width}x{camera.height}",
            key=key,
            value=(array.shape[1], array.shape[0]),
            expected=f"{camera.width}x{camera.height} px, the camera file's image_size",
        )
    return to_hsv(np.ascontiguousarray(array))


def _border(hsv: Image) -> Image:
    """Pixels of a strip along the four edges (4 % of the short side), (N, 3)."""
    w = max(2, round(0.04 * min(hsv.shape[:2])))
    return np.concatenate([hsv[:w].reshape(-1, 3), hsv[-w:].reshape(-1, 3),
                           hsv[w:-w, :w].reshape(-1, 3), hsv[w:-w, -w:].reshape(-1, 3)])  # fmt: skip


def _background_hue(pixels_hsv: Image, settings: ModelSettings, what: str, key: str) -> tuple[float, float]:
    """Robust average background hue H̄_B: circular mean around the hue histogram's mode.

    Raises:
        ModelError: `key` (photo, background) is not a coloured sheet (`value`: the share
            of saturated pixels) or not a uniform one (`value`: the share near H̄_B).
    """
    saturated = pixels_hsv[:, 1] >= settings.min_saturation
    if saturated.mean() < settings.min_background_agreement:
        raise ModelError(
            f"the {what} is not a coloured sheet: only {saturated.mean():.0%} of its pixels have "
            f"saturation >= {settings.min_saturation}; use a uniform green sheet as in Fig. 7",
            key=key,
            value=float(saturated.mean()),
            expected=f"at least {settings.min_background_agreement:.0%} of the sheet's pixels saturated",
        )
    hues = pixels_hsv[saturated, 0]
    histogram = np.bincount(hues, minlength=256).astype(float)
    histogram = np.convolve(np.concatenate([histogram[-8:], histogram, histogram[:8]]), np.ones(17), "valid")
    mode = int(np.argmax(histogram))
    near = hues[hue_distance(hues, mode) <= settings.min_hue_difference // 2]
    H_B = circular_mean_hue(near)
    agreement = float(
        np.mean(hue_distance(pixels_hsv[:, 0], H_B) <= settings.min_hue_difference / 2) * saturated.mean()
    )
    if agreement < settings.min_background_agreement:
        raise ModelError(
            f"the {what} is not uniform: only {agreement:.0%} of it is within "
            f"{settings.min_hue_difference // 2} of its average hue {H_B:.0f}; needs "
            f">= {settings.min_background_agreement:.0%} (a plain sheet, no other objects)",
            key=key,
            value=agreement,
            expected=f"at least {settings.min_background_agreement:.0%} of the sheet near one hue",
        )
    return H_B, agreement


def _cloth_mask(
    hsv: Image, H_B: float, settings: ModelSettings, metres_per_pixel: float
) -> tuple[npt.NDArray[np.bool_], int]:
    """S_in in the photo: not the sheet, specks removed, objects selected, holes filled.

    A pixel is cloth if its hue is far from H̄_B, or if it has no hue at all (white,
    grey, black: the sheet is verified to be saturated): a white stripe is part of the
    cloth's outline (and with `tones`, carries a DARK or LIGHT sample).
    """
    codes = colour_codes(hsv, settings.min_saturation, settings.min_value, settings.value_split)
    differs = (codes >= HUE_RANGE) | (hue_distance(codes, H_B) > settings.min_hue_difference)
    mask = differs.astype(np.uint8)
    speck = round(settings.speckle_size / metres_per_pixel)
    if speck >= 2:
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (speck, speck))
        opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        mask = np.asarray(cv2.morphologyEx(opened, cv2.MORPH_CLOSE, kernel), dtype=np.uint8)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA] * metres_per_pixel**2
    keep = np.flatnonzero(areas >= settings.min_object_area) + 1
    if keep.size == 0:
        largest = float(areas.max()) if areas.size else 0.0
        raise ModelError(
            f"no cloth in the photo: no region with hue > {settings.min_hue_difference} away from the "
            f"background ({H_B:.0f}) is larger than {settings.min_object_area * 1e4:.2f} cm² "
            f"(largest: {largest * 1e4:.2f} cm²)",
            key="photo",
            value=largest,
            expected=f"a region of at least {settings.min_object_area} m² off the background's hue",
        )
    if settings.largest_object_only:
        keep = keep[[int(np.argmax(stats[keep, cv2.CC_STAT_AREA]))]]
    mask = np.isin(labels, keep).astype(np.uint8)
    if settings.fill_holes:
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        mask = np.asarray(
            cv2.drawContours(np.zeros_like(mask), contours, -1, 1, thickness=cv2.FILLED), dtype=np.uint8
        )
    edge = np.concatenate([mask[0], mask[-1], mask[:, 0], mask[:, -1]])
    if edge.any():
        raise ModelError(
            "the cloth touches the photo's border, so its outline is cut: centre it in the view",
            key="photo",
            expected="the whole cloth inside the photo",
        )
    return mask.astype(bool), int(keep.size)


def _metric_grid(camera: PinholeCamera, distance: float) -> FloatArray:
    """(H, W, 2) position of every pixel centre on the photo plane [m] (undistorted)."""
    u, v = np.meshgrid(np.arange(camera.width, dtype=float), np.arange(camera.height, dtype=float))
    K = camera.camera_matrix
    if camera.has_distortion:
        pixels = np.stack([u, v], axis=-1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        normal = cv2.undistortPoints(pixels, K, camera.dist_coeffs, criteria=criteria)
        return np.asarray(normal.reshape(camera.height, camera.width, 2) * distance, dtype=float)
    return np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]], axis=-1) * distance


def _to_pixel_index(
    camera: PinholeCamera, distance: float, xy: FloatArray
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Nearest pixel of points on the photo plane (may be outside the image)."""
    pixels = camera.project(np.column_stack([xy, np.full(len(xy), distance)]))
    return np.rint(pixels[:, 0]).astype(np.intp), np.rint(pixels[:, 1]).astype(np.intp)


def _symmetry_angles(
    points: FloatArray,
    hues: npt.NDArray[np.uint16],
    step: float,
    settings: ModelSettings,
    lightness_at: Callable[[FloatArray], FloatArray] | None = None,
) -> tuple[float, ...]:
    """Yaws k·π/4 (k = 1..7) under which S_in and its colours map onto themselves and, where
    the photo is textured (lightness deviation of at least 6 grey levels), its lightness
    correlates with itself turned by at least `symmetry_texture`: a print of nearly one
    hue on an ellipse is not symmetric under a half turn, its picture tells the two apart."""
    cells = {(int(i), int(j)): h for (i, j), h in zip(np.rint(points[:, :2] / step), hues, strict=True)}
    own = lightness_at(points) if lightness_at is not None else None
    textured = own is not None and float(np.std(own)) >= 6.0
    angles = []
    for k in range(1, 8):
        angle = k * np.pi / 4
        rotated = points @ rotation_about_z(angle).T
        hits = 0
        for (i, j), hue in zip(np.rint(rotated[:, :2] / step).astype(int), hues, strict=True):
            other = cells.get((int(i), int(j)))
            hits += int(other is not None and bool(colours_match(hue, other, settings.min_hue_difference)))
        if hits < settings.symmetry_agreement * len(points):
            continue
        if textured and own is not None and lightness_at is not None:
            turned = lightness_at(rotated)  # the lightness that lands on each point when turned
            if float(np.corrcoef(own, turned)[0, 1]) < settings.symmetry_texture:
                continue
        angles.append(float(angle))
    return tuple(angles)


__all__ = ["ModelSettings", "load_photo", "make_model"]
