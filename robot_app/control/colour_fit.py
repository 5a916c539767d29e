"""How well a patch of the right image fits a cloth's colours: the measure that names a lost
cloth's region (`table_lost.match_lost`) and what hangs from the hand (`held_look`).

A cloth's *main colours* are the colour codes that cover most of its model photo
(`vision.regions.main_codes`). A patch fits a cloth by the share of its pixels in them
(`palette_share`), by how alike their mix is to the photo's (`palette_proportions`: a white
heap fits every palette with white in it, but not every palette's mix), and, for a cloth of
tones only, by its lightness (`not_lighter`), and for a cloth mostly white by its white
showing (`shows_light`): a cloth seen in shade may look darker than its photo, not
lighter, and a crumpled white cloth shows white somewhere.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.vision import Recognizer
from robot_app.vision.exposure import sheet_gains
from robot_app.vision.hue import DARK, LIGHT, colours_match
from robot_app.vision.regions import image_codes, main_codes, undistorted, with_folds

LIT_PERCENTILE = 95  # a region's or model's lit value: this percentile of its pixels' V
LIGHTER_TOLERANCE = 40.0  # grey levels a region may look lighter than a cloth's lit value
MIN_LIGHT_SHARE = 0.2  # share of LIGHT pixels from which a region fits a white cloth fully


@dataclass(frozen=True)
class ColourFit:
    """How well a patch's colours (an unknown region's, a held cloth's) fit a cloth's model.

    Attributes:
        share: share of the region's pixels in the model's main colours (`palette_share`).
        proportions: how alike the shares of those colours are in the region and in the
            model (`palette_proportions`; 1: the same mix).
        lightness: 1, or less where a cloth of tones only (white, grey, black) would look
            lighter in the region than its own lit colour (`not_lighter`).
    """

    share: float
    proportions: float
    lightness: float = 1.0

    @property
    def score(self) -> float:
        """share x proportions x lightness: what ranks the lost cloths for a region."""
        return self.share * self.proportions * self.lightness


def survey_colours(
    capture: StereoCapture, recognizers: Mapping[str, Recognizer]
) -> tuple[npt.NDArray[np.uint8], FloatArray, npt.NDArray[np.uint16]]:
    """The undistorted right image, the sheet's exposure gains on it and its colour codes
    after them, as the recognisers (all of one rig and settings) see it."""
    first = next(iter(recognizers.values()))
    image = undistorted(capture.right_bgr, first.rig.right)
    gains = sheet_gains(image, first.model, first.settings.exposure)
    return image, gains, image_codes(image, gains, first.settings.fitness)


def colour_shares(
    capture: StereoCapture, mask: npt.ArrayLike, recognizers: Mapping[str, Recognizer]
) -> dict[str, ColourFit]:
    """Name -> how the pixels `mask` ((H, W) bools of the undistorted right image: an
    unknown region, or what hangs from the hand) fit that model's main colours (`ColourFit`)."""
    fitness = next(iter(recognizers.values())).settings.fitness
    image, gains, codes = survey_colours(capture, recognizers)
    where = np.asarray(mask, dtype=bool)
    seen = codes[where]
    seen_light = lit_value(np.clip(image[where] * np.asarray(gains), 0, 255))
    fits = {}
    for name, recognizer in recognizers.items():
        model = recognizer.model
        palette, threshold = main_codes(model), fitness.hue_threshold_in
        lightness = 1.0
        if model.texture_bgr is not None and np.all(palette >= DARK):  # tones only, no hue
            lightness = not_lighter(seen_light, lit_value(model.texture_bgr[model.texture_mask]))
        if palette.size and palette[0] == LIGHT:  # a cloth mostly white shows its white, folds or not
            lightness *= shows_light(seen)
        fits[name] = ColourFit(
            palette_share(seen, palette, threshold),
            palette_proportions(seen, model.hues_in, palette, threshold),
            lightness,
        )
    return fits


def lit_value(bgr: npt.ArrayLike) -> float:
    """The `LIT_PERCENTILE` of the pixels' value (HSV V, their largest channel) [0-255]:
    the cloth's lit colour, above its folds' shade."""
    pixels = np.asarray(bgr, dtype=float).reshape(-1, 3)
    return float(np.percentile(pixels.max(axis=1), LIT_PERCENTILE)) if len(pixels) else 0.0


def not_lighter(seen: float, own: float) -> float:
    """1 unless a region's lit value `seen` exceeds a cloth's own lit value `own` (its
    model photo, the same exposure after the sheet's gains) by more than
    `LIGHTER_TOLERANCE`; then less, down to 0 at twice the tolerance. A cloth can look
    darker than in its photo (shade, a fold) but not lighter: a grey knit (lit value about 160)
    is no white heap (~245), a white cloth in shade may be a grey one (both kept). Written for
    bench episode 22, where it changed nothing: the dragged white No.18 lay dark there (coded
    DARK throughout, lit value under 155 after the gains) and tied with the black No.20,
    which this rule rightly keeps."""
    excess = seen - own - LIGHTER_TOLERANCE
    return float(np.clip(1.0 - excess / LIGHTER_TOLERANCE, 0.0, 1.0))


def shows_light(codes: npt.ArrayLike) -> float:
    """1 when at least `MIN_LIGHT_SHARE` of a region's colour `codes` are LIGHT, less below
    it, 0 with none: how well the region can be a cloth whose main colour is white (LIGHT
    first among its main codes: a white cloth, or a white print). Its folds lie in shade
    (DARK, which `palette_share` counts as its colour), but a crumpled white cloth is not
    dark all over. Bench episode 60 (session 21): No.20's black heap (no LIGHT pixel in the
    black tee's photo) was 95 % "in the colours" of the guessed whites No.17 and No.18, once
    No.20 was booked placed it was taken for No.17, and went into the whites box. Until
    session 39 this held for all-white palettes only, and the white print No.6 (73 % LIGHT,
    with blue and pink motifs, whites) fitted every dark cloth seen hanging at 0.72-0.73,
    its LIGHT taking the DARK pixels as folds: the grey No.19 and the black No.20 (colours)
    went back at every lift, doubted for No.6, which no survey had seen (held-out 1108, 11
    lifts; 1129, 4 lifts; 769 put No.19 into whites as No.6)."""
    flat = np.asarray(codes).reshape(-1)
    if not flat.size:
        return 0.0
    return float(np.clip(np.mean(flat == LIGHT) / MIN_LIGHT_SHARE, 0.0, 1.0))


def _palette_bins(codes: npt.ArrayLike, palette: npt.ArrayLike, hue_threshold: int) -> FloatArray:
    """Share of `codes` taken by each colour of `palette` (the first that matches, most
    frequent first), a LIGHT tone taking DARK pixels as in `palette_share`."""
    flat, own = np.asarray(codes).reshape(-1), np.asarray(palette).reshape(-1)
    bins = np.zeros(len(own))
    if not flat.size:
        return bins
    light = np.flatnonzero(own == LIGHT)
    colours = with_folds(own)
    matching = colours_match(flat[:, None], colours[None, :], hue_threshold)
    first = np.argmax(matching, axis=1)[np.any(matching, axis=1)]
    counts = np.bincount(first, minlength=len(colours)).astype(float)
    if len(colours) > len(bins):  # the DARK added for a white cloth's folds counts as its LIGHT
        counts[light[0]] += counts[-1]
    return counts[: len(bins)] / flat.size


def palette_share(seen: npt.ArrayLike, palette: npt.ArrayLike, hue_threshold: int) -> float:
    """Share of the colour codes `seen` that are in `palette` (a model's main codes): a hue
    within `hue_threshold` of one of its hues, or one of its tones; a LIGHT tone (a white
    or light grey cloth, which has no hue) also takes DARK pixels, since a crumpled white
    cloth's folds lie in its own shade, darker but still without hue (a dark cloth's
    folds do not get lighter)."""
    return float(np.sum(_palette_bins(seen, palette, hue_threshold)))


def palette_proportions(
    seen: npt.ArrayLike, model_codes: npt.ArrayLike, palette: npt.ArrayLike, hue_threshold: int
) -> float:
    """How alike the mix of `palette`'s colours is among the codes `seen` and among the
    model's own (`model_codes`, its S_in): the overlap of the two mixes, each over its
    pixels in the palette (1: the same shares, 0: none in common). `palette_share` asks
    only how much of a region a palette explains, so a white heap fitted every palette
    with white in it as well as a white cloth's (bench episode 1: two whites laid back
    together, never picked, since unseen cloths of the colours box with white stripes or
    dots fitted it as well); their mix of white and their other colours does not."""
    region = _palette_bins(seen, palette, hue_threshold)
    model = _palette_bins(model_codes, palette, hue_threshold)
    if region.sum() <= 0 or model.sum() <= 0:
        return 0.0
    return float(np.minimum(region / region.sum(), model / model.sum()).sum())


__all__ = [
    "LIGHTER_TOLERANCE",
    "LIT_PERCENTILE",
    "MIN_LIGHT_SHARE",
    "ColourFit",
    "colour_shares",
    "lit_value",
    "not_lighter",
    "palette_proportions",
    "palette_share",
    "shows_light",
    "survey_colours",
]
