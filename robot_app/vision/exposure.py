"""The scene's exposure and white balance, referred to the model photo by the green sheet.

The sheet under the cloth is in every hand image and in the model photo. The ratio of its
colour in the model photo to its colour in a hand image, channel by channel, maps the
scene's exposure (camera gain, light level) and white balance onto the model photo's.
Multiplying a hand image by these gains before its colour codes are taken (the fitness's
`bgr_codes`) lets the tones DARK / LIGHT (value below / above `value_split`, no hue below
`min_value`) and the hues mean what they meant in the model photo, under a camera that is
a third darker or brighter or tinted by 12 % per channel.

Light is not even over the cell: the arm and the cameras cast shadows (the pick-and-place
cell's key light is 30-50° off vertical), and a white cloth half in the arm's shadow is
grey there: its tone turned DARK where the model says LIGHT, and the search took that half
as a mismatch (the white cloths No.17 / No.18 were "not found" in 4 of 100 pick-and-place
episodes, each time under the arm's shadow). The sheet shows the shadow too, all around
the cloth: `scene_exposure` measures the sheet's brightness block by block, fills the
blocks the cloth covers from the sheet around them (inpainting), and where that brightness
differs from the sheet's median by more than `shading_min`, gives each block a factor
(`Shading`) that the pixel codes and the verification multiply in after the gains.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.exposure_kernels import encoded_deviation, sheet_sample


class ExposureSettings(StrictModel):
    """Exposure reference by the green sheet.

    Attributes:
        enabled: adapt to the scene's exposure (needs a model with `sheet_bgr`, version 3).
        step: every `step`-th pixel in each direction is looked at [px].
        hue_tolerance: sheet pixels are within this of the model's background hue [0-128].
        min_saturation: ... and at least this saturated [0-255].
        min_share: fewer sheet pixels than this share of those looked at: no adaptation.
        max_gain: gains are clipped to [1 / max_gain, max_gain].
        shading: also correct uneven light (shadows) block by block, `step` pixels a block.
        shading_min: light that differs from the sheet's median by less than this factor
            minus one everywhere is taken as even (no shading correction).
        shading_max: shading factors are clipped to [1 / shading_max, shading_max].
        shading_step: factors are quantised to steps of this in their logarithm.
    """

    enabled: bool = True
    step: int = Field(default=8, ge=1, le=64)
    hue_tolerance: int = Field(default=20, ge=1, le=64)
    min_saturation: int = Field(default=40, ge=0, le=255)
    min_share: float = Field(default=0.05, gt=0.0, le=1.0)
    max_gain: float = Field(default=2.5, ge=1.0, le=10.0)
    shading: bool = True
    shading_min: float = Field(default=0.3, ge=0.0, le=4.0)
    shading_max: float = Field(default=3.0, ge=1.0, le=10.0)
    shading_step: float = Field(default=0.04, gt=0.0, le=0.5)


@dataclass(frozen=True)
class Shading:
    """The light's unevenness over one image, as a factor per block of pixels.

    Attributes:
        index: (Hb, Wb) uint8, the level of each `block` x `block` pixel block (block
            (i, j) holds pixels v // block == i, u // block == j).
        factors: (L,) the brightness factor of each level (1: as lit as the sheet's median).
        block: block side [px].
    """

    index: npt.NDArray[np.uint8]
    factors: FloatArray
    block: int

    def factor_map(self, shape: tuple[int, int]) -> FloatArray:
        """(H, W) the factor at every pixel of an image of `shape` (height, width)."""
        rows = np.minimum(np.arange(shape[0]) // self.block, self.index.shape[0] - 1)
        cols = np.minimum(np.arange(shape[1]) // self.block, self.index.shape[1] - 1)
        return np.asarray(self.factors[self.index[rows][:, cols]], dtype=float)


@dataclass(frozen=True)
class SceneExposure:
    """One image's exposure against the model photo's.

    Attributes:
        gains: (3,) b, g, r factors (`sheet_gains`).
        shading: the factor per block on top of `gains`; None: even light (or no
            reference, or `shading` off).
    """

    gains: FloatArray
    shading: Shading | None


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
    return scene_exposure(image_bgr, model, settings, shading=False).gains


def scene_exposure(
    image_bgr: npt.NDArray[np.uint8], model: ClothModel, settings: ExposureSettings, shading: bool = True
) -> SceneExposure:
    """The image's gains (`sheet_gains`) and, if `shading` and `settings.shading`, its
    shading (see the module docstring); gains of one and no shading when disabled, without
    a reference or without enough sheet.

    Args:
        image_bgr: (H, W, 3) uint8 hand image.
        model: the cloth model (its `sheet_bgr` and `background_hue`).
        settings: how the sheet is found.
        shading: also measure the shading.
    """
    none = SceneExposure(np.ones(3), None)
    if not settings.enabled or model.sheet_bgr is None:
        return none
    background_hue = int(np.asarray(model.background_hue, dtype=np.int32))  # as `hue.hue_distance` takes it
    sheet, count, medians, value, median, core, size = sheet_sample(
        np.asarray(image_bgr), settings.step, settings.min_saturation, background_hue, settings.hue_tolerance
    )
    if count < max(settings.min_share * sheet.size, 3):
        return none
    scene = np.maximum(medians, 1.0)
    gains = np.clip(np.asarray(model.sheet_bgr) / scene, 1.0 / settings.max_gain, settings.max_gain)
    if not (shading and settings.shading) or size < 3:
        return SceneExposure(gains, None)
    return SceneExposure(gains, _shading(value, median, core, settings))


def _shading(
    value: npt.NDArray[np.uint8], median: float, core: npt.NDArray[np.bool_], settings: ExposureSettings
) -> Shading | None:
    """The factor per block from the sheet's brightness (`value`, one sample per block;
    `median` its median over the sheet, `core` the sheet samples that have no non-sheet
    neighbour: a blurred cloth edge mixes in); None if it stays within `shading_min` of the
    median."""
    log_max = float(np.log(settings.shading_max))
    scale = 127.0 / log_max
    encoded, deviation = encoded_deviation(value, core, _encoding(median, scale))
    if deviation <= np.log1p(settings.shading_min) * scale:
        return None  # even light: the common case costs this much only
    filled = cv2.inpaint(encoded, np.where(core, 0, 255).astype(np.uint8), 2.0, cv2.INPAINT_TELEA)
    filled = cv2.medianBlur(np.asarray(filled, dtype=np.uint8), 3)
    steps = np.rint((filled.astype(np.float64) - 128.0) / (scale * settings.shading_step)).astype(np.int64)
    levels, index = np.unique(steps, return_inverse=True)
    if len(levels) > 255:
        raise RuntimeError(f"{len(levels)} shading levels: shading_step too small for shading_max")
    return Shading(
        np.ascontiguousarray(index.reshape(steps.shape).astype(np.uint8)),
        np.exp(levels * settings.shading_step),
        settings.step,
    )


@functools.lru_cache(maxsize=1024)
def _encoding(median: float, scale: float) -> npt.NDArray[np.uint8]:
    """(256,) read-only: each value's log-brightness against the sheet's `median`, as
    128 + log(median / value) * `scale` rounded and clipped to 0-255 (> 128: darker than
    the median); a median is one of 511 half-steps, so a tracking run builds few."""
    ratio = np.log(median / np.maximum(np.arange(256, dtype=np.float64), 1.0))
    table = np.clip(np.rint(128.0 + ratio * scale), 0, 255).astype(np.uint8)
    table.setflags(write=False)
    return table


__all__ = ["ExposureSettings", "SceneExposure", "Shading", "scene_exposure", "sheet_gains"]
