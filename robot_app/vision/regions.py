"""Where in an image a recognised cloth lies, and which of its pixels it explains.

Identification among many models compares recognitions region by region: two models
whose recognitions explain mostly the same pixels describe one cloth, and the more
confident one names it. This module draws those regions in the right image of a stereo
pair (undistorted, as the fitness sees it):

- the *footprint* of a recognition: the model photo's cloth mask mapped into the image by
  the plane homography of Σ_M's z = 0 plane (where the cloth would be, fully visible);
- the *explained* pixels: footprint pixels whose colour code (hue, or tone without one)
  agrees with the model photo's at that place (`hue.colours_match`, the fitness's hue
  threshold): the part of the cloth the image shows as the model says;
- the *sheet*: pixels of the green sheet's hue; everything else is foreground (cloths,
  and what lies on them);
- the *outline contrast* of a footprint over another: how sharply the image's colour
  changes across the footprint's edge where it runs inside the other footprint. The edge
  of the cloth on top is an edge in the image (its cloth against the one under it); the
  edge of the cloth underneath is hidden there, and only the upper cloth's print crosses it.

All masks are (H, W) bool arrays of the right camera's image size.
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.fitness_scores import FitnessSettings
from robot_app.vision.hue import DARK, LIGHT, colour_codes, colours_match, hue_distance, to_hsv

Mask = npt.NDArray[np.bool_]
Codes = npt.NDArray[np.uint16]


def undistorted(image_bgr: npt.NDArray[np.uint8], camera: PinholeCamera) -> npt.NDArray[np.uint8]:
    """The image as an ideal pinhole with the camera's matrix would see it."""
    if not camera.has_distortion:
        return np.ascontiguousarray(image_bgr)
    K = camera.camera_matrix
    return np.asarray(cv2.undistort(image_bgr, K, camera.dist_coeffs, None, K), dtype=np.uint8)


def image_codes(
    image_bgr: npt.NDArray[np.uint8], gains: FloatArray, fitness: FitnessSettings, blur_px: float = 1.0
) -> Codes:
    """(H, W) colour codes of an (undistorted) image after the exposure gains (b, g, r)."""
    scaled = np.asarray(image_bgr, dtype=np.float32) * np.asarray(gains, dtype=np.float32)
    blurred = cv2.GaussianBlur(scaled, (0, 0), blur_px) if blur_px > 0 else scaled
    image8 = np.clip(blurred, 0, 255).astype(np.uint8)
    return colour_codes(to_hsv(image8), fitness.min_saturation, fitness.min_value, fitness.value_split)


def sheet_mask(
    image_bgr: npt.NDArray[np.uint8], sheet_hue: float, tolerance: int, min_saturation: int
) -> Mask:
    """Pixels of the green sheet: within `tolerance` of its hue and at least this saturated
    (a shadow on the sheet keeps its hue)."""
    hsv = to_hsv(np.ascontiguousarray(image_bgr))
    near = hue_distance(hsv[..., 0], sheet_hue) <= tolerance
    return np.asarray(near & (hsv[..., 1] >= min_saturation), dtype=bool)


def homography_model_to_image(
    model: ClothModel, camera: PinholeCamera, transform_model_to_camera: FloatArray
) -> FloatArray:
    """(3, 3) map of model-photo texture pixels (u, v, 1) to image pixels, through Σ_M's plane z = 0."""
    if model.texture_from_model is None:
        raise ValueError(f"model {model.name!r} has no texture (a version 1-2 file)")
    T = np.asarray(transform_model_to_camera, dtype=float)
    plane_to_image = camera.camera_matrix @ np.column_stack([T[:3, 0], T[:3, 1], T[:3, 3]])
    texture_from_model = np.vstack([model.texture_from_model, [0.0, 0.0, 1.0]])
    return np.asarray(plane_to_image @ np.linalg.inv(texture_from_model), dtype=float)


def footprint(model: ClothModel, camera: PinholeCamera, transform_model_to_camera: FloatArray) -> Mask:
    """Where the cloth would cover the image if nothing hid it (the photo's cloth mask, mapped)."""
    H = homography_model_to_image(model, camera, transform_model_to_camera)
    mask = np.asarray(model.texture_mask, dtype=np.uint8)
    width, height = camera.image_size
    warped = cv2.warpPerspective(mask, H, (width, height), flags=cv2.INTER_NEAREST, borderValue=0)
    return np.asarray(warped > 0, dtype=bool)


def explained(
    model: ClothModel,
    camera: PinholeCamera,
    transform_model_to_camera: FloatArray,
    codes: Codes,
    fitness: FitnessSettings,
) -> tuple[Mask, Mask]:
    """(footprint, explained): the footprint and its pixels whose colour code agrees with
    the model photo's there.

    Args:
        model: the cloth model (with its photo's texture).
        camera: the (undistorted) camera the codes are of.
        transform_model_to_camera: (4, 4) the recognised pose in that camera [m].
        codes: (H, W) the image's colour codes (`image_codes`).
        fitness: hue threshold and tone settings (the recogniser's reported fitness).
    """
    H = homography_model_to_image(model, camera, transform_model_to_camera)
    width, height = camera.image_size
    photo = np.asarray(model.texture_bgr, dtype=np.uint8)
    scale = _texture_pixels_per_image_pixel(H, (photo.shape[0], photo.shape[1]))
    # the photo is finer than the image: blur it to about an image pixel first
    texture = (
        np.asarray(cv2.GaussianBlur(photo, (0, 0), 0.5 * scale), dtype=np.uint8) if scale > 1.5 else photo
    )
    warped = np.asarray(
        cv2.warpPerspective(texture, H, (width, height), flags=cv2.INTER_LINEAR, borderValue=(0, 0, 0)),
        dtype=np.uint8,
    )
    mask = cv2.warpPerspective(
        np.asarray(model.texture_mask, dtype=np.uint8), H, (width, height), flags=cv2.INTER_NEAREST
    )
    inside = np.asarray(mask > 0, dtype=bool)
    model_codes = colour_codes(to_hsv(warped), fitness.min_saturation, fitness.min_value, fitness.value_split)
    agree = np.zeros_like(inside)
    agree[inside] = colours_match(model_codes[inside], codes[inside], fitness.hue_threshold_in)
    return inside, agree


def lab_image(image_bgr: npt.NDArray[np.uint8]) -> FloatArray:
    """(H, W, 3) CIE L*a*b* of an 8-bit BGR image (L 0-100): colour differences by distance."""
    return np.asarray(cv2.cvtColor(np.asarray(image_bgr, np.float32) / 255.0, cv2.COLOR_BGR2Lab), dtype=float)


def outline_contrast(
    image_lab: FloatArray, footprint: Mask, inside: Mask, offset: float, inset: int, min_points: int
) -> float:
    """The median colour difference (CIE76 delta E) across `footprint`'s edge where the edge
    runs `inset` [px] or more inside the mask `inside`: between the image points `offset`
    [px] inside and outside the edge along its normal. NaN where fewer than `min_points`
    edge pixels run there. The median, not the mean: a print crossing a hidden edge
    differs at a few places, an edge in view along most of it."""
    mask = np.asarray(footprint, dtype=np.uint8)
    edge = mask & ~np.asarray(cv2.erode(mask, np.ones((3, 3), np.uint8)), dtype=np.uint8)
    size = 2 * inset + 1
    within = np.asarray(cv2.erode(np.asarray(inside, np.uint8), np.ones((size, size), np.uint8)), np.uint8)
    v, u = np.nonzero(edge & within)
    if len(u) < min_points:
        return float("nan")
    smooth = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 2.0)
    gy, gx = np.gradient(smooth)  # points into the footprint
    nx, ny = gx[v, u], gy[v, u]
    length = np.hypot(nx, ny) + 1e-9
    nx, ny = nx / length, ny / length
    lab = np.asarray(image_lab, dtype=np.float32)

    def at(uu: FloatArray, vv: FloatArray) -> FloatArray:
        columns, rows = uu.astype(np.float32).reshape(1, -1), vv.astype(np.float32).reshape(1, -1)
        return np.asarray(cv2.remap(lab, columns, rows, cv2.INTER_LINEAR), dtype=float).reshape(-1, 3)

    difference = at(u + offset * nx, v + offset * ny) - at(u - offset * nx, v - offset * ny)
    return float(np.median(np.linalg.norm(difference, axis=1)))


def dilated(mask: Mask, side: int) -> Mask:
    """`mask` grown by a `side` x `side` square of pixels (as it is for `side` <= 1)."""
    if side <= 1:
        return np.asarray(mask, dtype=bool)
    return np.asarray(cv2.dilate(np.asarray(mask, np.uint8), np.ones((side, side), np.uint8)) > 0)


def model_area(model: ClothModel) -> float:
    """The cloth's area [m²]: its photo's cloth mask (else the area `make_model` recorded)."""
    if model.texture_mask is not None and model.texture_from_model is not None:
        pixels_per_metre = float(np.sqrt(abs(np.linalg.det(np.asarray(model.texture_from_model)[:, :2]))))
        return float(np.count_nonzero(model.texture_mask)) / pixels_per_metre**2
    return float(model.metadata.get("area_m2", model.extent[0] * model.extent[1]))


def main_codes(model: ClothModel, coverage: float = 0.8) -> npt.NDArray[np.uint16]:
    """The model's colour codes that cover `coverage` of its S_in points, most frequent first."""
    codes, counts = np.unique(np.asarray(model.hues_in), return_counts=True)
    order = np.argsort(-counts)
    cumulative = np.cumsum(counts[order]) / counts.sum()
    return np.asarray(codes[order][: int(np.searchsorted(cumulative, coverage)) + 1], dtype=np.uint16)


def _texture_pixels_per_image_pixel(H: FloatArray, shape: tuple[int, int]) -> float:
    """About how many texture pixels one image pixel spans (at the texture's centre)."""
    v, u = shape[0] / 2.0, shape[1] / 2.0
    points = np.array([[u, v, 1.0], [u + 10.0, v, 1.0], [u, v + 10.0, 1.0]]).T
    mapped = H @ points
    mapped = mapped[:2] / mapped[2]
    step = 0.5 * (np.linalg.norm(mapped[:, 1] - mapped[:, 0]) + np.linalg.norm(mapped[:, 2] - mapped[:, 0]))
    return float(10.0 / max(float(step), 1e-9))


def with_folds(palette: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """`palette` with DARK appended when it has a LIGHT tone and no DARK one: a white
    cloth's folds lie in its own shade (`control.table_lost.palette_share`)."""
    colours = np.asarray(palette, dtype=np.int64).reshape(-1)
    if np.any(colours == LIGHT) and not np.any(colours == DARK):
        colours = np.append(colours, DARK)
    return colours


def in_palette(
    codes: npt.ArrayLike, palette: npt.ArrayLike, hue_threshold: int, folds: bool = True
) -> npt.NDArray[np.bool_]:
    """Which `codes` are in `palette` (a model's main codes), as
    `control.table_lost.palette_share` counts them (`folds`: with the folds' shade,
    `with_folds`)."""
    flat = np.asarray(codes)
    colours = (with_folds(palette) if folds else np.asarray(palette, dtype=np.int64)).reshape(
        (1,) * flat.ndim + (-1,)
    )
    return np.asarray(np.any(colours_match(flat[..., None], colours, hue_threshold), axis=-1), dtype=bool)


__all__ = [
    "dilated",
    "explained",
    "footprint",
    "homography_model_to_image",
    "image_codes",
    "in_palette",
    "lab_image",
    "main_codes",
    "model_area",
    "outline_contrast",
    "sheet_mask",
    "undistorted",
    "with_folds",
]
