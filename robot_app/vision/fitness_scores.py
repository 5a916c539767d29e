"""The scores of the paper's fitness (eqs. 9-10): its settings and the score table.

For a pose ^CR T_M the model points are projected into both images (eq. 8) and each one
scores by the hue of the pixel it lands on (nearest pixel, as in the paper):

- S_in point with model hue H_M (eq. 9): `score_in_match` (2) if the image hue is within
  `hue_threshold_in` (30) of H_M, else `score_in_background` (-0.005) if it is within 30
  of the background hue H̄_B, else `score_in_other` (0);
- S_out point (eq. 10): `score_out_background` (0.1) if the image hue is within
  `hue_threshold_out` (20) of H̄_B, else `score_out_other` (-0.5).

Hue differences are taken on the circle (HSV_FULL, 256 steps per turn). Beyond the paper,
a pixel without hue (`min_saturation`, `min_value`) has a tone, DARK or LIGHT
(`robot_app.vision.hue`), and so may an S_in point (`ModelSettings.tones`): a tone point
matches a pixel of its tone as a hue point matches its hue; a hue point on a toned
pixel, or a tone point on another tone, scores `score_in_other`; an S_out point on a
toned pixel `score_out_other`. With the defaults (`min_saturation` 0) every pixel has
its hue, as in the paper.

All of it is one table (`score_table`): a row per model colour code (hue, DARK, LIGHT)
and one for S_out, a column per pixel code (`pixel_codes.py`); beside it, a "seen" table
says which points count towards the divisor (`fitness.py`). With `hidden_foreign` (the
recogniser's search uses it), a point on a pixel of a foreign hue (neither the
background's nor near any of the model's hues: a blue sheet over the cloth, a cloth of
other colours) is taken as hidden, like a point off the image: it scores 0 and is not
seen. `foreign_codes` gives the same notion per pixel code to the verify stage.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt
from pydantic import Field, model_validator

from robot_app.arrays import FloatArray
from robot_app.config import SettingValueError, StrictModel
from robot_app.vision.hue import COLOUR_CODES, HUE_RANGE, colours_match

OFF_IMAGE = COLOUR_CODES  # code of the frame around each image that off-image points read: scores 0
OUTSIDE_ROW = COLOUR_CODES  # table row of S_out points; rows 0-257 are S_in points by colour code
COLUMNS = COLOUR_CODES + 1  # pixel codes: hues 0-255, DARK, LIGHT, OFF_IMAGE


class FitnessSettings(StrictModel):
    """Constants of eqs. 9-10; the defaults are the paper's.

    Attributes:
        score_in_match: S_in point on a pixel of its own hue.
        score_in_background: S_in point on a background-hued pixel.
        score_in_other: S_in point on any other pixel.
        score_out_background: S_out point on a background-hued pixel.
        score_out_other: S_out point on any other pixel.
        hue_threshold_in: hue tolerance of eq. 9 [HSV_FULL steps, 0-128].
        hue_threshold_out: hue tolerance of eq. 10 [HSV_FULL steps, 0-128].
        min_saturation: pixels with saturation below this (0-255) have no hue but a tone
            (DARK / LIGHT): they match neither a model hue nor the background, only model
            points of their tone. 0 (the paper) gives every pixel a hue.
        min_value: pixels with value below this (0-255) have no hue either (the
            saturation of a dark pixel is mostly noise). 0: the paper.
        value_split: a pixel without hue is DARK below this value, else LIGHT; the model's
            (`ModelSettings.value_split`) should be the same.
        score_out_foreign: S_out point on a pixel whose hue is neither background nor
            within `hue_threshold_in` of any of the model's hues (a blue sheet over a red
            cloth, a cloth of another colour). None (the paper): `score_out_other`. The
            paper's -0.5 there makes an occluder push the model away from it; the
            recognizer searches with 0 (RecognitionSettings.search_out_foreign).
        normalisation: "model" divides by the maximum of all points (the paper), "view" by
            the maximum of the points that land on the images (see the module docstring).
        min_view_fraction: with "view", the divisor is at least this fraction of the
            model's maximum.
        hidden_foreign: with "view", points on a foreign hue score 0 and leave the
            divisor (hidden, see the module docstring); `score_out_foreign` is then unused.
        model_hue_min_share: for the foreign-hue test, a model hue counts if at least this
            share of the S_in points have it.
        hidden_penalty: with "view", subtracted times the share of the model's maximum
            that is not seen (off the images or hidden). Hiding then costs a little, so a
            cloth in full view beats the same model laid over another cloth that shares
            some of its hues (whose other hues would be "hidden"); 45 % hidden under a
            sheet still beats a smaller pose squeezed onto the visible part.
    """

    score_in_match: float = Field(default=2.0, gt=0)
    score_in_background: float = -0.005
    score_in_other: float = 0.0
    score_out_background: float = Field(default=0.1, ge=0)
    score_out_other: float = -0.5
    hue_threshold_in: int = Field(default=30, ge=0, le=128)
    hue_threshold_out: int = Field(default=20, ge=0, le=128)
    min_saturation: int = Field(default=0, ge=0, le=255)
    min_value: int = Field(default=0, ge=0, le=255)
    value_split: int = Field(default=128, ge=1, le=255)
    score_out_foreign: float | None = None
    normalisation: Literal["model", "view"] = "view"
    min_view_fraction: float = Field(default=0.5, gt=0.0, le=1.0)
    hidden_foreign: bool = False
    model_hue_min_share: float = Field(default=0.01, ge=0.0, le=1.0)
    hidden_penalty: float = Field(default=0.0, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _scores_ordered(self) -> FitnessSettings:
        if self.score_in_match < max(self.score_in_background, self.score_in_other):
            raise SettingValueError(
                "score_in_match", "score_in_match must be the largest S_in score", self.score_in_match
            )
        if self.score_out_background < self.score_out_other:
            raise SettingValueError(
                "score_out_background",
                "score_out_background must be at least score_out_other",
                self.score_out_background,
            )
        if self.hidden_foreign and self.normalisation != "view":
            raise SettingValueError(
                "normalisation", 'hidden_foreign needs normalisation "view"', self.normalisation
            )
        return self


def score_table(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike | None = None
) -> npt.NDArray[np.float32]:
    """(259, 259) table of eqs. 9-10: row = model colour code 0-257 (hue, DARK, LIGHT) or 258
    (S_out), column = pixel code.

    Pixel codes are hues 0-255, `DARK`, `LIGHT` and `OFF_IMAGE` (always 0).

    Args:
        background_hue: H̄_B [HSV_FULL, 0-256).
        params: scores and thresholds.
        model_hues: the model's S_in colour codes; needed only for `params.score_out_foreign`
            and `params.hidden_foreign`.
    """
    codes = np.arange(COLOUR_CODES)
    d_background = _background_distance(background_hue)  # tones: never the background
    match = colours_match(codes[:, None], codes[None, :], params.hue_threshold_in)  # (model, pixel)
    table = np.zeros((COLOUR_CODES + 1, COLUMNS), dtype=np.float32)
    inside = np.where(
        d_background <= params.hue_threshold_in, params.score_in_background, params.score_in_other
    )
    table[:COLOUR_CODES, :COLOUR_CODES] = np.where(match, params.score_in_match, inside[None, :])
    table[OUTSIDE_ROW, :COLOUR_CODES] = np.where(
        d_background <= params.hue_threshold_out, params.score_out_background, params.score_out_other
    )
    if params.score_out_foreign is not None and model_hues is not None:
        foreign = _foreign_hues(background_hue, params, model_hues, params.hue_threshold_out)
        table[OUTSIDE_ROW, :COLOUR_CODES][foreign] = params.score_out_foreign
    if params.hidden_foreign and model_hues is not None:
        table[~seen_table(background_hue, params, model_hues)] = 0.0
    return table


def seen_table(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike | None = None
) -> npt.NDArray[np.bool_]:
    """(259, 259) like `score_table`: does a point of that row on that pixel code count as seen?

    Not seen: `OFF_IMAGE`, and with `params.hidden_foreign` a foreign colour, i.e. a hue
    farther than `hue_threshold_in` from every model hue and, from the background's,
    farther than `hue_threshold_in` (S_in rows) or `hue_threshold_out` (the S_out row), or
    a tone the model does not have.

    Args:
        background_hue: H̄_B [HSV_FULL, 0-256).
        params: thresholds.
        model_hues: the model's S_in colour codes; needed for `params.hidden_foreign`.
    """
    seen = np.ones((COLOUR_CODES + 1, COLUMNS), dtype=bool)
    seen[:, OFF_IMAGE] = False
    if params.hidden_foreign and model_hues is not None:
        seen[:COLOUR_CODES, :COLOUR_CODES] = ~_foreign_hues(
            background_hue, params, model_hues, params.hue_threshold_in
        )
        seen[OUTSIDE_ROW, :COLOUR_CODES] = ~_foreign_hues(
            background_hue, params, model_hues, params.hue_threshold_out
        )
    return seen


def _background_distance(background_hue: float) -> FloatArray:
    """(258,) distance of each colour code from H̄_B: on the circle for a hue (H̄_B may lie
    between two hues), infinite for a tone."""
    d = np.abs(np.arange(HUE_RANGE) - background_hue) % HUE_RANGE
    return np.concatenate([np.minimum(d, HUE_RANGE - d), [np.inf, np.inf]])


def _foreign_hues(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike, background_threshold: int
) -> npt.NDArray[np.bool_]:
    """(258,) colour codes neither within `background_threshold` of H̄_B nor near a model colour."""
    far_from_background = _background_distance(background_hue) > background_threshold
    return np.asarray(far_from_background & ~_near_model_hues(model_hues, params))


def foreign_codes(
    background_hue: float, params: FitnessSettings, model_hues: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """(259,) per pixel code: is it a foreign colour for an S_in point (neither within
    `hue_threshold_in` of H̄_B nor near a colour the model has; `OFF_IMAGE` counts as
    foreign)? What the verification takes as hidden."""
    return np.append(_foreign_hues(background_hue, params, model_hues, params.hue_threshold_in), True)


def _near_model_hues(model_hues: npt.ArrayLike, params: FitnessSettings) -> npt.NDArray[np.bool_]:
    """(258,) colour codes that match one the model really has: one that at least
    `model_hue_min_share` of its S_in points have (a few mixed pixels along colour edges
    would otherwise make a blue sheet "near" a cyan cloth)."""
    counts = np.bincount(np.asarray(model_hues, dtype=int).ravel(), minlength=COLOUR_CODES)[:COLOUR_CODES]
    colours = np.flatnonzero(counts >= params.model_hue_min_share * max(int(counts.sum()), 1))
    if not len(colours):  # a spread-out model: every colour it has
        colours = np.flatnonzero(counts)
    codes = np.arange(COLOUR_CODES)
    return np.asarray(colours_match(codes[:, None], colours[None, :], params.hue_threshold_in).any(axis=1))


__all__ = [
    "COLUMNS",
    "OFF_IMAGE",
    "OUTSIDE_ROW",
    "FitnessSettings",
    "foreign_codes",
    "score_table",
    "seen_table",
]
