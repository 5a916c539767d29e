"""Hue: the one place where images are converted, and hue distances on the circle.

Hue is OpenCV's `COLOR_BGR2HSV_FULL` channel: 0-255 for a full turn, so that 256 hue
steps wrap around (hue 250 and hue 5 are 11 apart).

A pixel without a meaningful hue (white, grey, black: saturation below a threshold, or
too dark for its saturation to mean anything) has a *tone* instead: `DARK` or `LIGHT`.
A colour code is a hue 0-255 or one of these two; `colour_codes` gives them, and
`colours_match` compares them (hues on the circle, tones by equality).
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

HUE_RANGE = 256  # hue values per full turn in HSV_FULL
DARK = HUE_RANGE  # colour code of a pixel without hue below the value split (black, dark grey)
LIGHT = HUE_RANGE + 1  # colour code of a pixel without hue at or above it (white, light grey)
COLOUR_CODES = HUE_RANGE + 2  # hues 0-255, DARK, LIGHT


def to_hsv(image_bgr: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """(H, W, 3) uint8 BGR image -> (H, W, 3) uint8 HSV_FULL (hue 0-255).

    Raises:
        ValueError: not an (H, W, 3) uint8 array (the user's images are checked where
            they enter: `pixel_codes.checked_image`, `photo_model.make_model`).
    """
    image = np.asarray(image_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(f"expected an (H, W, 3) uint8 BGR image, got {image.shape} {image.dtype}")
    return np.asarray(cv2.cvtColor(image, cv2.COLOR_BGR2HSV_FULL), dtype=np.uint8)


def to_hue(image_bgr: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """(H, W, 3) uint8 BGR image -> (H, W) uint8 hue, 0-255 for a full turn."""
    return np.ascontiguousarray(to_hsv(image_bgr)[:, :, 0])


def hue_distance(hue_a: npt.ArrayLike, hue_b: npt.ArrayLike) -> npt.NDArray[np.int32]:
    """Distance between hues on the circle, 0-128 (HSV_FULL units)."""
    d = np.abs(np.asarray(hue_a, dtype=np.int32) - np.asarray(hue_b, dtype=np.int32)) % HUE_RANGE
    return np.minimum(d, HUE_RANGE - d)


def colour_codes(
    hsv: npt.NDArray[np.uint8], min_saturation: int, min_value: int = 0, value_split: int = 128
) -> npt.NDArray[np.uint16]:
    """HSV_FULL values (..., 3) -> colour codes (...): the hue, or a tone where the pixel has
    none: saturation < `min_saturation` or value < `min_value` (the saturation of a dark
    pixel is mostly noise); the tone is `DARK` for value < `value_split`, else `LIGHT`.
    `min_saturation` 0 and `min_value` 0 give every pixel its hue (the paper)."""
    hsv = np.asarray(hsv)
    hue, saturation, value = (hsv[..., k].astype(np.uint16) for k in range(3))
    tone = np.where(value < value_split, np.uint16(DARK), np.uint16(LIGHT))
    return np.where((saturation < min_saturation) | (value < min_value), tone, hue).astype(np.uint16)


def colours_match(code_a: npt.ArrayLike, code_b: npt.ArrayLike, hue_threshold: int) -> npt.NDArray[np.bool_]:
    """Do colour codes agree: two hues within `hue_threshold` on the circle, or the same tone."""
    a, b = np.asarray(code_a, dtype=np.int32), np.asarray(code_b, dtype=np.int32)
    hues = (a < HUE_RANGE) & (b < HUE_RANGE)
    return np.where(hues, hue_distance(a, b) <= hue_threshold, a == b)


def circular_mean_hue(hues: npt.ArrayLike) -> float:
    """Mean of hues (0-255) on the circle, in [0, 256)."""
    angles = np.asarray(hues, dtype=float).reshape(-1) * (2 * np.pi / HUE_RANGE)
    if angles.size == 0:
        raise ValueError("circular_mean_hue of no hues")
    mean = np.arctan2(np.sin(angles).mean(), np.cos(angles).mean())
    hue = float((mean * HUE_RANGE / (2 * np.pi)) % HUE_RANGE)
    return 0.0 if hue >= HUE_RANGE else hue  # -1e-15 % 256 rounds to 256.0


__all__ = [
    "COLOUR_CODES",
    "DARK",
    "HUE_RANGE",
    "LIGHT",
    "circular_mean_hue",
    "colour_codes",
    "colours_match",
    "hue_distance",
    "to_hsv",
    "to_hue",
]
