"""Hue: the one place where images are converted, and hue distances on the circle.

Hue is OpenCV's `COLOR_BGR2HSV_FULL` channel: 0-255 for a full turn, so that 256 hue
steps wrap around (hue 250 and hue 5 are 11 apart).
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.errors import InputError

HUE_RANGE = 256  # hue values per full turn in HSV_FULL


def to_hsv(image_bgr: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """(H, W, 3) uint8 BGR image -> (H, W, 3) uint8 HSV_FULL (hue 0-255)."""
    image = np.asarray(image_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise InputError(f"expected an (H, W, 3) uint8 BGR image, got {image.shape} {image.dtype}")
    return cv2.cvtColor(image, cv2.COLOR_BGR2HSV_FULL)


def to_hue(image_bgr: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """(H, W, 3) uint8 BGR image -> (H, W) uint8 hue, 0-255 for a full turn."""
    return np.ascontiguousarray(to_hsv(image_bgr)[:, :, 0])


def hue_distance(hue_a: npt.ArrayLike, hue_b: npt.ArrayLike) -> npt.NDArray[np.int32]:
    """Distance between hues on the circle, 0-128 (HSV_FULL units)."""
    d = np.abs(np.asarray(hue_a, dtype=np.int32) - np.asarray(hue_b, dtype=np.int32)) % HUE_RANGE
    return np.minimum(d, HUE_RANGE - d)


def circular_mean_hue(hues: npt.ArrayLike) -> float:
    """Mean of hues (0-255) on the circle, in [0, 256)."""
    angles = np.asarray(hues, dtype=float).reshape(-1) * (2 * np.pi / HUE_RANGE)
    if angles.size == 0:
        raise InputError("circular_mean_hue of no hues")
    mean = np.arctan2(np.sin(angles).mean(), np.cos(angles).mean())
    hue = float((mean * HUE_RANGE / (2 * np.pi)) % HUE_RANGE)
    return 0.0 if hue >= HUE_RANGE else hue  # -1e-15 % 256 rounds to 256.0


__all__ = ["HUE_RANGE", "circular_mean_hue", "hue_distance", "to_hsv", "to_hue"]
