"""The scene's exposure and white balance, referred to the model photo by the green sheet.

The sheet under the cloth is in every hand image and in the model photo. The ratio of its
colour in the model photo to its colour in a hand image, channel by channel, maps the
scene's exposure (camera gain, light level) and white balance onto the model photo's.
Multiplying a hand image by these gains before its colour codes are taken (the fitness's
`bgr_codes`) lets the tones DARK / LIGHT (value below / above `value_split`, no hue below
`min_value`) and the hues mean what they meant in the model photo, under a camera that is
a third darker or brighter or tinted by 12 % per channel.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.hue import hue_distance, to_hsv


class ExposureSettings(StrictModel):
    """Exposure reference by the green sheet.

    Attributes:
        enabled: adapt to the scene's exposure (needs a model with `sheet_bgr`, version 3).
        step: every `step`-th pixel in each direction is looked at [px].
        hue_tolerance: sheet pixels are within this of the model's background hue [0-128].
        min_saturation: ... and at least this saturated [0-255].
        min_share: fewer sheet pixels than this share of those looked at: no adaptation.
        max_gain: gains are clipped to [1 / max_gain, max_gain].
    """

    enabled: bool = True
    step: int = Field(default=8, ge=1, le=64)
    hue_tolerance: int = Field(default=20, ge=1, le=64)
    min_saturation: int = Field(default=40, ge=0, le=255)
    min_share: float = Field(default=0.05, gt=0.0, le=1.0)
    max_gain: float = Field(default=2.5, ge=1.0, le=10.0)


def sheet_gains(
    image_bgr: npt.NDArray[np.uint8], model: ClothModel, settings: ExposureSettings
) -> FloatArray:
    """(3,) factors of the b, g, r channels that bring `image_bgr`'s sheet to the model
    photo's sheet colour; ones when disabled, without a reference or without enough sheet.

    Args:
        image_bgr: (H, W, 3) uint8 hand image.
        model: the cloth model (its `sheet_bgr` and `background_hue`).
        settings: how the sheet is found.
    """
    if not settings.enabled or model.sheet_bgr is None:
        return np.ones(3)
    sample = np.ascontiguousarray(np.asarray(image_bgr)[:: settings.step, :: settings.step])
    hsv = to_hsv(sample).reshape(-1, 3)
    sheet = (hsv[:, 1] >= settings.min_saturation) & (
        hue_distance(hsv[:, 0], model.background_hue) <= settings.hue_tolerance
    )
    if sheet.sum() < max(settings.min_share * len(hsv), 3):
        return np.ones(3)
    scene = np.maximum(_channel_medians(sample.reshape(-1, 3)[sheet]), 1.0)
    return np.clip(np.asarray(model.sheet_bgr) / scene, 1.0 / settings.max_gain, settings.max_gain)


def _channel_medians(pixels: npt.NDArray[np.uint8]) -> FloatArray:
    """(3,) median of each channel of (N, 3) uint8 pixels (the lower median), by histogram."""
    out = np.empty(3)
    half = (len(pixels) + 1) // 2
    for k in range(3):
        counts = np.bincount(pixels[:, k], minlength=256)
        out[k] = float(np.searchsorted(np.cumsum(counts), half))
    return out


__all__ = ["ExposureSettings", "sheet_gains"]
