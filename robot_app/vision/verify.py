"""Verify stage: does the model photo's full colour texture agree with the images at a pose?

The hue fitness looks at hue bands only: a print of nearly one hue matches itself turned
by half a turn, and another cloth of the same hue family matches nearly as well as the
target. The model photo holds more. At a candidate pose, samples of the photo's texture
(every `spacing` on the cloth, `edge_margin` inside its outline, blurred to about a hand
camera pixel) are projected into both images; a sample counts if it lands in the image
and not on a foreign colour (an occluder: the fitness's notion of hidden). The cloth is
cut into square cells of `cell_size`, and each cell with enough visible samples compares
model and image: where the model is textured by the zero-mean normalised cross-correlation
of each colour channel (invariant to a gain and offset per channel: exposure and white
balance), where it is flat by whether the image is flat too and of the model's mean colour.
The appearance score is the cells' mean agreement in [-1, 1], weighted by their visible
samples; `agreeing` is the weighted share of cells that agree; the visible fraction is
the share of samples visible; `interleaved` is the share of the samples in view that lie
in partly hidden cells (a sheet hides whole cells, another cloth's stripes of a colour
foreign to the model hide parts of many).

Alignment (`Verifier.aligned`): the correlation of a fine-grained print (a woven cloth)
needs sub-millimetre alignment, finer than the hue fitness, which is flat within a few
millimetres on a partly covered cloth: two millimetres off, the agreeing share of a
covered woven cloth fell from 0.80 to 0.08. So where the texture agrees poorly
(`agreeing` below `align_below`) and is compared mostly by correlation (`textured_share`
at least `align_textured_from`: a plain cell's flatness and mean colour need no such
alignment, and searching them only lets a plain model fit another cloth's patch of its
colour better), the verification searches the best agreement in a small
neighbourhood of the pose in the cloth plane (a grid of `align_step` within
`align_shift` in x and y, then turns within `align_turn_deg`, then half steps) and
reports the evidence found there; the pose itself is kept (the hue fitness placed it).

Outline (`Verification.outline`): the texture cannot tell a plain model on its own cloth
from the same model on a patch of another cloth that shows its colour (a plain red model on
the red stripes of a red-yellow cloth: the yellow is foreign, hence hidden, and the red in
view agrees). The model photo also holds the cloth's outline. Every `outline_spacing` along
it (`outline.model_outline`) a pair of points, `outline_inside` inside and `outline_outside`
outside, is projected into both images. A pair counts where its inner point shows the model
photo's colour there (chromaticity within `chroma_tolerance`, brightness within
`brightness_tolerance`, after the exposure gains and the shading, as the texture is
compared; without the shading the arm's shadow made a cloth's pairs astray): it is an
*edge* if its outer point does not show that colour (the sheet, an occluder, another cloth)
and *same* if it does (the region goes on past the outline: a patch of a larger print, or
a pose off the cloth). An
inner point on a foreign colour is hidden (an occluder: not counted against the pose)
unless its outer point shows the sheet: a foreign region that ends exactly on the outline
is another cloth's other colours, not a sheet over the cloth (a *seam*, counted against).
An inner point of another colour than the model's there (a folded corner's back side, an
occluder of a near hue) is *astray* and left out (`outline_astray` reports its share), and
so is one whose texture cell does not agree (the texture already says the model is not
there: a textured print under a plain sheet of its own colour, whose sheet goes on past the
outline, or a fold; without this a covered print lost to a plain sheet of its outline and
colour beside it, `test_look_alike_sheet.py`).
`outline` = edges / (edges + same + seams): a share, so a folded corner or a wrong stretch
costs only its own part. A seam's inner point is foreign, so it has no texture cell to
check; where the texture is compared mostly by correlation (`textured_share` at least
`align_textured_from`, as for alignment) the seams are counted at the rate the cell gate
lets the model-coloured pairs through (edges / (edges + same + rate · seams)): a fine print
seen 3-10 mm off disagrees in most cells, and its ungated seams (not investigated further)
outnumbered the few edges left. A plain model's flat cells need no
fine alignment, and its seams all count (counting them at the rate too accepted a plain red
model on the stripes and on the patchwork again).

Occluders of a hue the model has (`read_occluders`, `occluder_read.py`): a sample on a
foreign colour is hidden, but a sheet of a hue the model has (brown over red, blue over
violet) is not foreign, and its cells count as seen and disagreeing. At a final pose, plain
disagreeing cells of one colour whose region goes on past the outline (its outline pairs show
its colour outside too, not the green sheet) are read as such an occluder, and the pose is
verified again with the pixels of its colour connected to them hidden (`pixels_hidden`; none
where the texture agrees; the outline keeps the unmasked image).

A model without texture (a version 1-2 file) cannot be verified: `Verification.appearance`
is NaN and the decision uses its stand-in (`DecisionSettings.appearance_without_texture`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.exposure import Shading
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.fitness_scores import FitnessSettings, foreign_codes
from robot_app.vision.hue import COLOUR_CODES, HUE_RANGE, colours_match
from robot_app.vision.occluder_read import (
    CellGrid,
    OccluderRead,
    OutlineLooks,
    cell_statistics,
    read_occluders,
    same_colour,
)
from robot_app.vision.outline import model_outline
from robot_app.vision.poses import as_poses
from robot_app.vision.texture_polish import in_plane
from robot_app.vision.verify_kernels import appearance, cell_sums, outline_contrast


class VerificationSettings(StrictModel):
    """The appearance check.

    Attributes:
        spacing: texture samples every this on the cloth [m].
        edge_margin: no sample nearer the outline than this [m] (a pose a millimetre off
            must not compare the sheet with the cloth).
        blur: standard deviation of the blur of the model photo before sampling [m]
            (about a hand-camera pixel at 580 mm).
        cell_size: side of the square cells compared one by one [m].
        min_points: samples a cell needs in view to be compared.
        texture_min: RMS deviation of the model's colour in a cell from which it is
            compared by correlation, below it by flatness [grey levels].
        flat_tolerance: how much more an image cell may vary than a flat model cell before
            it disagrees [grey levels] (noise of sigma 7 and JPEG stay inside).
        chroma_tolerance: a flat cell's mean chromaticity (b, g, r over their sum) may
            differ this much from the model's before it disagrees.
        brightness_tolerance: ... and its brightness by this factor minus one (after the
            exposure gains; smooth shading stays inside).
        ambiguity_margin: alternatives (half and quarter turns, other peaks) whose search
            fitness is within this of the best are verified and the most confident kept.
        partial_low, partial_high: a cell in view whose hidden share (samples on a foreign
            colour) lies between these is partly hidden (see `Verification.interleaved`).
        agree_level: a cell agrees from this score (see `Verification.agreeing`).
        look_alike_below: a pose where the texture agrees in less than this share of the
            compared cells (`Verification.agreeing`) at each of its quarter turns shows
            another object of the model's hues, not the cloth (a sheet of a look-alike hue:
            plain where the print is not, or of another lightness or chroma); the propose
            stage searches elsewhere (`Proposer.propose(look_alike=)`). 0: never.
        align_below: a final pose whose agreeing share is below this is aligned
            (`Verifier.aligned`; 0: never).
        align_textured_from: ... and whose textured share is at least this.
        align_shift: the alignment's reach in the cloth plane, x and y [m].
        align_step: its grid step in x and y [m] (halved once at the end).
        align_turn_deg: its reach about the cloth normal [deg] (steps of half of it).
        outline_spacing: outline pairs every this along the model's outline [m].
        outline_inside, outline_outside: each pair's inner and outer point lie this far
            inside and outside the outline [m] (a pose a few millimetres off still puts
            them on the right sides).
        outline_min_pairs: pairs (both images) an outline needs to be measured.
        saturated: an image channel read at this or more (0-255, before the exposure gains)
            was clipped by the camera: its true value is at least that, and a model value
            above it counts as seen (plain texture cells and outline points; 256: off). A
            bright cloth under a strong gain clips its main channel: the orange L's red read
            253 and, after the sheet's gains, 181 against the photo's 219, so every plain cell
            disagreed at the truth (appearance -0.77). Off (256) by default: at 250 the
            bench's default seeds (`scripts/bench_recognition.py --skip-speed --skip-fullsearch
            --set verify.saturated=250`) raised the confidence of five present scenes (a flat
            yellow square 0.63 -> 1.00) and decided nothing else differently, but a folded
            red-yellow stripes print (scene 82), whose clipped stripes then agreed with a pose
            9 mm off, was taken there (folded within 98 -> 97 %).
        evidence_saturated: `saturated` for the final evidence of a one-shot recognition and
            a check only, the pose kept (`Verifier.clipped_from`, the recogniser's
            `_final_evidence`): a clipped channel read as a lower bound where it cannot move a
            pose. Over-exposure is what breaks first when one camera axis is moved at a time
            (`scripts/bench_camera_axes.py --axes gain`: flat found 90 / 40 % at gain 1.7 / 2.0).
        occluder_read: read a plain occluder of a hue the model has as hidden in the final
            evidence of a one-shot recognition and a check where that raises the decision's
            log-odds (`occluder_read.py`; the recogniser's `_read_and_aligned`); false: the
            evidence and poses as before.
        occluder_plain: a disagreeing cell is plain (a candidate occluder) up to this RMS
            deviation of the image over it [grey levels].
        occluder_min_pairs: an occluder region needs this many outline pairs (both points
            showing its colour, the outer one not the green sheet) ...
        occluder_continued: ... and this share of its outline pairs in view.
    """

    spacing: float = Field(default=0.003, gt=0.0005, le=0.02)
    edge_margin: float = Field(default=0.003, ge=0.0, le=0.02)
    blur: float = Field(default=0.0008, ge=0.0, le=0.005)
    cell_size: float = Field(default=0.02, gt=0.002, le=0.2)
    min_points: int = Field(default=8, ge=2)
    texture_min: float = Field(default=6.0, gt=0.0)
    flat_tolerance: float = Field(default=10.0, gt=0.0)
    chroma_tolerance: float = Field(default=0.05, gt=0.0, le=1.0)
    brightness_tolerance: float = Field(default=0.35, gt=0.0, le=4.0)
    ambiguity_margin: float = Field(default=0.1, ge=0.0, le=1.0)
    partial_low: float = Field(default=0.2, gt=0.0, lt=1.0)
    partial_high: float = Field(default=0.8, gt=0.0, lt=1.0)
    agree_level: float = Field(default=0.5, ge=-1.0, le=1.0)
    look_alike_below: float = Field(default=0.1, ge=0.0, le=1.0)
    align_below: float = Field(default=0.9, ge=0.0, le=1.0)
    align_textured_from: float = Field(default=0.5, ge=0.0, le=1.0)
    align_shift: float = Field(default=0.002, ge=0.0, le=0.01)
    align_step: float = Field(default=0.001, gt=0.0, le=0.01)
    align_turn_deg: float = Field(default=2.0, ge=0.0, le=10.0)
    outline_spacing: float = Field(default=0.002, gt=0.0005, le=0.02)
    outline_inside: float = Field(default=0.003, gt=0.0, le=0.02)
    outline_outside: float = Field(default=0.004, gt=0.0, le=0.02)
    outline_min_pairs: int = Field(default=10, ge=1)
    saturated: float = Field(default=256.0, gt=0.0, le=256.0)
    evidence_saturated: float = Field(default=250.0, gt=0.0, le=256.0)
    occluder_read: bool = True
    occluder_plain: float = Field(default=8.0, gt=0.0)
    occluder_min_pairs: int = Field(default=4, ge=1)
    occluder_continued: float = Field(default=0.5, gt=0.0, le=1.0)


@dataclass(frozen=True)
class Verification:
    """The appearance check at one pose.

    Attributes:
        appearance: cells' mean agreement in [-1, 1]; NaN without texture or with no cell in view.
        visible_fraction: share of the texture samples in view and not under a foreign colour
            (mean of both images); for a model without texture, the hue fitness's seen share.
        textured_share: share of the compared weight on textured cells (0: a plain cloth,
            compared by flatness alone).
        interleaved: share of the samples in view that lie in partly hidden cells. A sheet
            over the cloth hides whole cells but those along its edge; a cloth of other
            colours whose stripes, checks or dots of a foreign colour the model takes as
            hidden hides parts of many cells.
        agreeing: share of the compared weight on cells that agree at least
            `agree_level`: a compact region that disagrees (a folded corner, a sheet of
            the model's own hue) costs it only its own share, where it pulls the mean
            `appearance` down by twice that (NaN: nothing compared).
        outline: share of the outline pairs whose inner point shows the model's colour and
            whose outer point does not (an edge where the outline lies); the rest show the
            model's colour going on past the outline (NaN: fewer than `outline_min_pairs`
            such pairs in view, or no texture). See the module docstring.
        outline_astray: share of the outline pairs in view and not hidden whose inner point
            shows neither the model's colour there nor a foreign one (NaN: none in view).
        occluded: share of the samples (both images) read as behind a plain occluder of a
            hue the model has (`occluder_read.py`; 0: not read, or none found); they are
            left out of the other fields.
    """

    appearance: float
    visible_fraction: float
    textured_share: float
    interleaved: float = 0.0
    agreeing: float = float("nan")
    outline: float = float("nan")
    outline_astray: float = float("nan")
    occluded: float = 0.0


class Verifier:
    """The verify stage of one model on one evaluator (whose current pair and pixel codes it reads).

    Args:
        model: the cloth model (its texture).
        evaluator: the fitness evaluator holding the current pair's pixel codes.
        search: the search fitness settings, which say what colour is foreign (hidden).
        settings: the appearance check.
    """

    def __init__(
        self,
        model: ClothModel,
        evaluator: FitnessEvaluator,
        search: FitnessSettings,
        settings: VerificationSettings,
    ) -> None:
        self.model = model
        self.evaluator = evaluator
        self.settings = settings
        self._foreign = np.ascontiguousarray(foreign_codes(model.background_hue, search, model.hues_in))
        self._samples = _texture_samples(model, settings)
        self._clip_levels = _clip_levels(self._samples, settings.texture_min, settings.saturated)
        self._outline_saturated = settings.saturated
        self._outline = _outline_pairs(model, settings, self._samples)
        self._neighbours = [] if self._samples is None else _cell_grid(self._samples, settings).neighbours()
        sheet_hue = round(model.background_hue) % HUE_RANGE
        sheet = colours_match(np.arange(COLOUR_CODES), sheet_hue, search.hue_threshold_in)
        self._sheet = np.append(sheet, False)  # OFF_IMAGE
        self._images: tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]] | None = None
        self._gains = (np.ones(3), np.ones(3))
        self._shading: tuple[Shading | None, Shading | None] = (None, None)
        self._outline_codes: tuple[npt.NDArray[np.uint16], npt.NDArray[np.uint16]] | None = None

    @property
    def n_samples(self) -> int:
        """Texture samples compared per image and pose (0 without texture)."""
        return 0 if self._samples is None else len(self._samples[0])

    def update(
        self,
        image_left_bgr: npt.NDArray[np.uint8],
        image_right_bgr: npt.NDArray[np.uint8],
        gains: tuple[FloatArray, FloatArray] | None = None,
        shading: tuple[Shading | None, Shading | None] | None = None,
    ) -> None:
        """Takes the pair the evaluator has (undistorted the same way), its exposure gains
        and its shading (`exposure.scene_exposure`; None: even light)."""
        images = []
        for image, camera in (
            (image_left_bgr, self.evaluator.rig.left),
            (image_right_bgr, self.evaluator.rig.right),
        ):
            array = np.ascontiguousarray(image)
            if camera.has_distortion:
                K = camera.camera_matrix
                array = np.asarray(cv2.undistort(array, K, camera.dist_coeffs, None, K), dtype=np.uint8)
            images.append(array)
        self._images = (images[0], images[1])
        self._gains = (
            (np.ones(3), np.ones(3))
            if gains is None
            else (np.asarray(gains[0], float), np.asarray(gains[1], float))
        )
        self._shading = (None, None) if shading is None else shading

    def verify(self, transforms_model_to_camera: npt.ArrayLike, outline: bool = True) -> list[Verification]:
        """The appearance check of each of (P, 4, 4) or (4, 4) poses; with `outline` false the
        outline is not measured (`Verification.outline` and `outline_astray` NaN: for a ranking
        of poses, which leaves the outline out, `decide.ranking`; it saves 20-50 % of the time).

        Raises:
            RuntimeError: no pair yet (call `update`).
        """
        poses = as_poses(transforms_model_to_camera)
        if self._samples is None:
            seen = self.evaluator.seen_fraction(poses)
            return [Verification(float("nan"), float(v), 0.0, 0.0, float("nan")) for v in seen]
        if self._images is None:
            raise RuntimeError("no stereo pair to verify on: call update(left, right) first")
        scores, visible, textured, interleaved, agreeing, agree_cells = self._appearance(poses)
        if outline:
            outlines, astray = self._outline_evidence(poses, agree_cells, textured)
        else:
            outlines = astray = np.full(len(poses), np.nan)
        return [
            Verification(float(a), float(v), float(t), float(i), float(g), float(o), float(r))
            for a, v, t, i, g, o, r in zip(
                scores, visible, textured, interleaved, agreeing, outlines, astray, strict=True
            )
        ]

    def _appearance(self, poses: FloatArray) -> tuple[npt.NDArray[Any], ...]:
        """`verify_kernels.appearance` of (P, 4, 4) poses on the current pair (needs the texture)."""
        if self._samples is None or self._images is None:
            raise RuntimeError("no texture or no stereo pair to compare (see `verify`)")
        px, py, values, cells, n_cells = self._samples
        codes_left, codes_right = self.evaluator.codes
        rig = self.evaluator.rig
        s = self.settings
        (factors_left, index_left), (factors_right, index_right) = (_shade(x) for x in self._shading)
        block = max(x.block if x is not None else 1 for x in self._shading)
        return appearance(
            poses, rig.left.camera_matrix, rig.right.camera_matrix,
            np.ascontiguousarray(rig.transform_right_to_left), px, py, values, cells, n_cells,
            self._images[0], self._images[1], codes_left, codes_right, self._foreign,
            self._gains[0], self._gains[1], factors_left, index_left, factors_right, index_right, block,
            self._clip_levels, float(s.min_points), s.texture_min, s.flat_tolerance,
            s.chroma_tolerance, s.brightness_tolerance, s.partial_low, s.partial_high, s.agree_level,
        )  # fmt: skip

    def _outline_evidence(
        self, poses: FloatArray, agree_cells: npt.NDArray[np.uint8], textured: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """(P,) `Verification.outline` and (P,) `Verification.outline_astray` of each pose
        (`agree_cells`: (P, 2, cells) the texture cells' verdicts (`verify_kernels.AGREES`),
        from `appearance`;
        `textured`: (P,) `Verification.textured_share`)."""
        if self._outline is None or self._images is None:
            nan = np.full(len(poses), np.nan)
            return nan, nan
        inner, outer, model_bgr, inner_cells = self._outline
        codes_left, codes_right = self.evaluator.codes if self._outline_codes is None else self._outline_codes
        rig = self.evaluator.rig
        s = self.settings
        (factors_left, index_left), (factors_right, index_right) = (_shade(x) for x in self._shading)
        block = max(x.block if x is not None else 1 for x in self._shading)
        counts = outline_contrast(
            poses, rig.left.camera_matrix, rig.right.camera_matrix,
            np.ascontiguousarray(rig.transform_right_to_left), inner, outer, model_bgr, inner_cells,
            agree_cells, self._images[0], self._images[1], codes_left, codes_right,
            self._gains[0], self._gains[1], factors_left, index_left, factors_right, index_right, block,
            self._outline_saturated, self._foreign, self._sheet, s.chroma_tolerance, s.brightness_tolerance,
        )  # fmt: skip
        edge, same, astray, seam, coloured = (counts[:, k] for k in range(5))
        with np.errstate(invalid="ignore", divide="ignore"):
            # A seam's inner point is foreign: no texture cell to check there. Where the
            # texture is compared mostly by correlation (as for `aligned`), a pose a few
            # millimetres off disagrees in most cells, so the seams are counted at the rate
            # the cell gate lets the model-coloured pairs through (edges and seams alike).
            # A plain model's cells need no fine alignment: its seams all count.
            passed = np.where(coloured > 0, (edge + same) / coloured, 0.0)
            correlated = np.nan_to_num(textured) >= s.align_textured_from
            measured = edge + same + seam * np.where(correlated, passed, 1.0)
            outline = np.where(measured >= s.outline_min_pairs, edge / measured, np.nan)
            share = np.where(measured + astray > 0, astray / (measured + astray), np.nan)
        return outline, share

    @contextmanager
    def clipped_from(self, level: float) -> Iterator[bool]:
        """Within the block, an image channel read at `level` or more counts as clipped (as
        `VerificationSettings.saturated` does everywhere); yields whether that changes
        anything: False when `level` is the settings' own or no pixel of the images reaches it."""
        images = self._images
        if level >= self.settings.saturated or images is None or max(int(i.max()) for i in images) < level:
            yield False
            return
        saved = self._clip_levels, self._outline_saturated
        self._clip_levels = _clip_levels(self._samples, self.settings.texture_min, level)
        self._outline_saturated = level
        try:
            yield True
        finally:
            self._clip_levels, self._outline_saturated = saved

    @contextmanager
    def pixels_hidden(self, masks: tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]) -> Iterator[None]:
        """Within the block, the pixels of (H, W) bool `masks` (left, right) read as hidden to
        the evaluator (the search fitness, `FitnessEvaluator.pixels_hidden`) and to the texture
        samples, but not to the outline: an occluder read past the outline would otherwise hide
        the outer points that show a model colour going on past it (a plain cloth larger than
        the model, of one of its colours, read as an occluder around the model's own colour,
        kept an outline of 1.0 on what was left and was accepted at 0.61)."""
        codes = self.evaluator.codes
        with self.evaluator.pixels_hidden(masks):
            self._outline_codes = codes
            try:
                yield
            finally:
                self._outline_codes = None

    def read_occluders(
        self, transform_model_to_camera: FloatArray, verification: Verification | None = None
    ) -> tuple[Verification, tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]] | None]:
        """The verification of one (4, 4) pose with its plain occluders of a hue the model has
        read as hidden (`occluder_read.py`), and the pixels hidden (each region's colour
        connected to its cells, `occluder_pixels`; None: nothing read, and the verification is
        the plain one, `verification` if given). Nothing is read without texture or with
        `occluder_read` off.

        Raises:
            RuntimeError: no pair yet (call `update`).
        """
        pose = np.asarray(transform_model_to_camera, dtype=float)
        s = self.settings
        if self._samples is None or self._outline is None or not s.occluder_read:
            return (self.verify(pose)[0] if verification is None else verification), None
        statistics = cell_statistics(
            self._cell_sums(pose), float(s.min_points), s.texture_min, s.flat_tolerance,
            s.chroma_tolerance, s.brightness_tolerance,
        )  # fmt: skip
        candidates = (statistics.weights > 0) & (statistics.scores < s.agree_level)
        found = None
        if (candidates & (statistics.image_rms <= s.occluder_plain)).any():
            found = read_occluders(
                statistics,
                self._outline_looks(pose),
                self._neighbours,
                agree_level=s.agree_level,
                plain=s.occluder_plain,
                chroma_tolerance=s.chroma_tolerance,
                brightness_tolerance=s.brightness_tolerance,
                min_pairs=s.occluder_min_pairs,
                continued=s.occluder_continued,
            )
        plain = self.verify(pose)[0] if verification is None else verification
        if found is None or not found.any:
            return plain, None
        masks = self.occluder_pixels(pose, found)
        with self.pixels_hidden(masks):
            read = self.verify(pose)[0]
        occluded = max(plain.visible_fraction - read.visible_fraction, 0.0)
        return replace(read, occluded=occluded), masks

    def occluder_pixels(
        self, transform_model_to_camera: FloatArray, found: OccluderRead, dilate: int = 2
    ) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        """(H, W) bool per image (left, right): the pixels of each occluder region `found` at
        the (4, 4) pose (`read_occluders`): those of its colour (`same_colour`, gain- and
        shading-corrected) connected to a pixel where one of its cells' visible samples
        landed, grown by `dilate` pixels (its blurred edge), but none where the texture agrees
        (the samples of the agreeing cells, grown to cover their cells: a print of nearly
        one hue under a sheet of its own mean colour has that colour in view too, and hiding
        it took 65-73 % of the cloth for 45 % covered)."""
        if self._images is None or self._samples is None:
            raise RuntimeError("no texture or no stereo pair (see `read_occluders`)")
        s = self.settings
        pose = np.asarray(transform_model_to_camera, dtype=float)
        out = []
        for side in range(2):
            image = self._images[side]
            height, width = image.shape[:2]
            colours = found.colours[side]
            if not colours:
                out.append(np.zeros((height, width), dtype=bool))
                continue
            corrected = image.astype(np.float64) * self._gains[side]
            shading = self._shading[side]
            if shading is not None:
                corrected *= shading.factor_map((height, width))[:, :, None]
            agreeing_pixels = np.zeros((height, width), dtype=np.uint8)
            agree = self._sample_pixels(pose, side, found.agreeing[side])
            agreeing_pixels[agree[:, 1], agree[:, 0]] = 1
            K = self.evaluator.rig.right.camera_matrix if side else self.evaluator.rig.left.camera_matrix
            reach = int(np.ceil(0.5 * s.spacing * float(K[0, 0]) / max(float(pose[2, 3]), 1e-3))) + 1
            disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
            protected = cv2.dilate(agreeing_pixels, disc) > 0
            seeds = self._sample_pixels(pose, side, found.hidden[side])
            mask = np.zeros((height, width), dtype=bool)
            for colour in colours:
                match = (
                    same_colour(corrected, colour, s.chroma_tolerance, s.brightness_tolerance) & ~protected
                )
                _, labels = cv2.connectedComponents(match.astype(np.uint8), connectivity=8)
                keep = np.unique(labels[seeds[:, 1], seeds[:, 0]][match[seeds[:, 1], seeds[:, 0]]])
                mask |= np.isin(labels, keep[keep > 0])
            if dilate > 0:
                grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * dilate + 1, 2 * dilate + 1))
                mask = cv2.dilate(mask.astype(np.uint8), grow) > 0
            out.append(mask & ~protected)
        return out[0], out[1]

    def _cell_sums(self, pose: FloatArray) -> FloatArray:
        """(2, C, 17) `verify_kernels.cell_sums` of one pose on the current pair."""
        if self._samples is None or self._images is None:
            raise RuntimeError("no texture or no stereo pair to compare (see `verify`)")
        px, py, values, cells, n_cells = self._samples
        codes_left, codes_right = self.evaluator.codes
        rig = self.evaluator.rig
        (factors_left, index_left), (factors_right, index_right) = (_shade(x) for x in self._shading)
        block = max(x.block if x is not None else 1 for x in self._shading)
        return cell_sums(
            np.ascontiguousarray(pose), rig.left.camera_matrix, rig.right.camera_matrix,
            np.ascontiguousarray(rig.transform_right_to_left), px, py, values, cells, n_cells,
            self._images[0], self._images[1], codes_left, codes_right, self._foreign,
            self._gains[0], self._gains[1], factors_left, index_left, factors_right, index_right, block,
            self._clip_levels,
        )  # fmt: skip

    def _project(self, pose: FloatArray, side: int, points: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(N, 2) pixel positions of (N, 2) points of the cloth plane [m] in image `side` at
        `pose`, and (N,) their depths [m]."""
        rig = self.evaluator.rig
        X = np.column_stack([points[:, :2], np.zeros(len(points)), np.ones(len(points))]) @ pose.T
        if side == 0:
            X = X @ np.asarray(rig.transform_right_to_left, dtype=float).T
            K = rig.left.camera_matrix
        else:
            K = rig.right.camera_matrix
        z = X[:, 2]
        uv = (X[:, :3] @ np.asarray(K, dtype=float).T)[:, :2] / np.where(np.abs(z) > 1e-9, z, 1e-9)[:, None]
        return uv, z

    def _colours_at(self, side: int, uv: FloatArray) -> tuple[FloatArray, npt.NDArray[np.bool_], npt.NDArray]:
        """Gain- and shading-corrected b, g, r at the nearest pixels of (N, 2) `uv` in image
        `side`, whether each is in the image, and its pixel code."""
        if self._images is None:
            raise RuntimeError("no stereo pair (call update)")
        image = self._images[side]
        height, width = image.shape[:2]
        iu, iv = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
        inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height)
        iu, iv = np.clip(iu, 0, width - 1), np.clip(iv, 0, height - 1)
        colour = image[iv, iu].astype(np.float64) * self._gains[side]
        shading = self._shading[side]
        if shading is not None:
            rows = np.minimum(iv // shading.block, shading.index.shape[0] - 1)
            cols = np.minimum(iu // shading.block, shading.index.shape[1] - 1)
            colour *= np.asarray(shading.factors, dtype=float)[shading.index[rows, cols]][:, None]
        codes = self.evaluator.codes[side]
        code = codes[(iv + 1) * (width + 3) + iu + 1]
        return colour, inside, code

    def _outline_looks(self, pose: FloatArray) -> tuple[OutlineLooks, OutlineLooks]:
        """The outline pairs in each image at `pose` (`occluder_read.OutlineLooks`)."""
        if self._outline is None:
            raise RuntimeError("no outline to look at (a model without texture)")
        inner, outer, _, inner_cells = self._outline
        looks = []
        for side in range(2):
            uv_in, z_in = self._project(pose, side, inner)
            uv_out, z_out = self._project(pose, side, outer)
            colour_in, in_image, _ = self._colours_at(side, uv_in)
            colour_out, out_image, code_out = self._colours_at(side, uv_out)
            looks.append(
                OutlineLooks(
                    inner_cells,
                    in_image & out_image & (z_in > 1e-6) & (z_out > 1e-6),
                    colour_in,
                    colour_out,
                    self._sheet[code_out],
                )
            )
        return looks[0], looks[1]

    def _sample_pixels(
        self, pose: FloatArray, side: int, cells: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.int64]:
        """(K, 2) the pixels (u, v) in image `side` where the samples of `cells` land at `pose`
        (inside the image)."""
        if self._samples is None or self._images is None:
            raise RuntimeError("no texture or no stereo pair")
        px, py, _, sample_cells, _ = self._samples
        chosen = cells[sample_cells]
        uv, z = self._project(pose, side, np.column_stack([px[chosen], py[chosen]]).astype(float))
        height, width = self._images[side].shape[:2]
        iu, iv = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
        inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height) & (z > 1e-6)
        return np.column_stack([iu[inside], iv[inside]])

    def aligned(
        self,
        transform_model_to_camera: FloatArray,
        verification: Verification,
        score: Callable[[list[Verification]], FloatArray],
    ) -> Verification:
        """The best verification near a pose whose texture agrees poorly (module docstring).

        Args:
            transform_model_to_camera: (4, 4) the pose.
            verification: its verification.
            score: the ranking of verifications (higher is better; the decision's log-odds).

        Returns:
            `verification` if it agrees well enough, nothing was compared or no neighbour
            scores higher; else the best neighbour's.
        """
        s = self.settings
        poor = verification.agreeing < s.align_below  # NaN: nothing compared
        if not poor or verification.textured_share < s.align_textured_from or s.align_shift <= 0.0:
            return verification
        pose = np.asarray(transform_model_to_camera, dtype=float)
        best, best_score, at = verification, float(score([verification])[0]), np.zeros(3)
        reach = int(np.floor(s.align_shift / s.align_step + 1e-9))
        grid = np.arange(-reach, reach + 1) * s.align_step
        turn = np.deg2rad(s.align_turn_deg)
        half = s.align_step / 2
        stages = (
            [(x, y, 0.0) for x in grid for y in grid if x or y],
            [(0.0, 0.0, a) for a in (-turn, -turn / 2, turn / 2, turn) if a],
            [(x, y, 0.0) for x in (-half, 0.0, half) for y in (-half, 0.0, half) if x or y],
        )
        for offsets in stages:
            if not offsets:
                continue
            moves = at + np.array(offsets)
            keep = (np.abs(moves[:, :2]) <= s.align_shift + 1e-9).all(axis=1)
            moves = moves[keep]
            poses = np.array([pose @ in_plane(*m) for m in moves])
            found = self.verify(poses)
            scores = score(found)
            k = int(np.argmax(scores))
            if scores[k] > best_score:
                best, best_score, at = found[k], float(scores[k]), moves[k]
        return best


_EVEN = (np.ones(1), np.zeros((1, 1), dtype=np.uint8))


def _shade(shading: Shading | None) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
    """(factors, index) of the verification kernel: one level of factor 1 for even light."""
    if shading is None:
        return _EVEN
    return np.asarray(shading.factors, dtype=np.float64), shading.index


def _outline_pairs(
    model: ClothModel, settings: VerificationSettings, samples: tuple | None
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.int64]] | None:
    """Points just inside and just outside the model's outline, (N, 2) each [m] in Σ_M, and
    the model photo's (blurred) b, g, r and the texture cell (of `samples`: its nearest
    sample's) at each inner point; every
    `outline_spacing` along the outline, across it along its normal. A pair whose inner
    point is not on the model's mask or whose outer point is (a concave corner) is left
    out. None without texture (no mask to tell the sides)."""
    if model.texture_mask is None or model.texture_from_model is None or model.texture_bgr is None:
        return None
    if samples is None:
        return None
    A = np.asarray(model.texture_from_model, dtype=float)
    mask = np.asarray(model.texture_mask) > 0
    height, width = mask.shape

    def on_mask(points: FloatArray) -> npt.NDArray[np.bool_]:
        u = np.rint(points @ A[:, :2].T + A[:, 2]).astype(int)
        inside = (u[:, 0] >= 0) & (u[:, 0] < width) & (u[:, 1] >= 0) & (u[:, 1] < height)
        inside[inside] = mask[u[inside, 1], u[inside, 0]]
        return inside

    points, normals = [], []
    for polygon in model_outline(model):
        xy = np.asarray(polygon[:, :2], dtype=float)
        ends = np.roll(xy, -1, axis=0)
        for start, end in zip(xy, ends, strict=True):
            length = float(np.linalg.norm(end - start))
            if length <= 1e-9:
                continue
            direction = (end - start) / length
            steps = np.arange(0.0, length, settings.outline_spacing)
            points.append(start + steps[:, None] * direction)
            normals.append(np.tile([direction[1], -direction[0]], (len(steps), 1)))
    if not points:
        return None
    p, n = np.vstack(points), np.vstack(normals)
    flip = on_mask(p + settings.outline_inside * n) & ~on_mask(p - settings.outline_inside * n)
    n[flip] *= -1.0  # n points outwards
    inner, outer = p - settings.outline_inside * n, p + settings.outline_outside * n
    keep = on_mask(inner) & ~on_mask(outer)
    if keep.sum() < settings.outline_min_pairs:
        return None
    inner, outer = inner[keep], outer[keep]
    texture = np.asarray(model.texture_bgr, dtype=np.float32)
    if settings.blur > 0:
        sigma = settings.blur * float(A[0, 0])
        texture = np.asarray(cv2.GaussianBlur(texture, (0, 0), sigma), dtype=np.float32)
    u = np.rint(inner @ A[:, :2].T + A[:, 2]).astype(int)
    colours = texture[u[:, 1], u[:, 0]].astype(np.float64)
    inner_cells = _nearest_cells(inner, samples)
    return (
        np.ascontiguousarray(inner),
        np.ascontiguousarray(outer),
        np.ascontiguousarray(colours),
        np.ascontiguousarray(inner_cells),
    )


def _nearest_cells(points: FloatArray, samples: tuple) -> npt.NDArray[np.int64]:
    """(N,) the cell of each of (N, 2) points' nearest texture sample (of `_texture_samples`)."""
    px, py, _, cells, _ = samples
    sample_xy = np.column_stack([px, py]).astype(np.float64)
    out = np.empty(len(points), dtype=np.int64)
    for start in range(0, len(points), 256):
        d = ((points[start : start + 256, None, :] - sample_xy[None, :, :]) ** 2).sum(axis=2)
        out[start : start + 256] = cells[np.argmin(d, axis=1)]
    return out


def _clip_levels(
    samples: tuple[npt.NDArray[Any], npt.NDArray[Any], npt.NDArray[Any], npt.NDArray[Any], int] | None,
    texture_min: float,
    saturated: float,
) -> npt.NDArray[np.float32]:
    """(N,) the image value from which a sample's channel reads as clipped (`saturated`): the
    samples of plain cells (the model's RMS deviation over the cell under `texture_min`)
    only. A textured cell is compared by correlation, and taking the model's values where
    the image clipped would lend any pose over a clipped area the model's own texture. (The
    folded red-yellow stripes of the bench's scene 82 still slid 9 mm with this: its wide
    stripes fill whole cells, which are plain; see `VerificationSettings.saturated`.)"""
    if samples is None:
        return np.empty(0, dtype=np.float32)
    _, _, values, cells, n_cells = samples
    count = np.maximum(np.bincount(cells, minlength=n_cells), 1)
    variance = np.zeros(n_cells)
    for k in range(3):
        mean = np.bincount(cells, values[:, k], n_cells) / count
        variance += np.bincount(cells, values[:, k].astype(np.float64) ** 2, n_cells) / count - mean**2
    plain = np.sqrt(np.maximum(variance, 0.0) / 3.0) < texture_min
    return np.ascontiguousarray(np.where(plain[cells], saturated, 256.0), dtype=np.float32)


def _cell_grid(samples: tuple, settings: VerificationSettings) -> CellGrid:
    """Each texture cell's place on the grid of `cell_size` squares (of `_texture_samples`)."""
    px, py, _, cells, n_cells = samples
    cx = np.floor((px - px.min()) / settings.cell_size).astype(np.int64)
    cy = np.floor((py - py.min()) / settings.cell_size).astype(np.int64)
    positions = np.zeros((n_cells, 2), dtype=np.int64)
    positions[cells] = np.column_stack([cx, cy])
    return CellGrid(positions)


def _texture_samples(
    model: ClothModel, settings: VerificationSettings
) -> (
    tuple[
        npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.int64], int
    ]
    | None
):
    """Sample positions (x, y [m]), their blurred b, g, r, cell indices and the cell count."""
    if model.texture_bgr is None or model.texture_mask is None or model.texture_from_model is None:
        return None
    A = np.asarray(model.texture_from_model)
    px_per_m = float(A[0, 0])
    texture = np.asarray(model.texture_bgr, dtype=np.float32)
    if settings.blur > 0:
        texture = np.asarray(cv2.GaussianBlur(texture, (0, 0), settings.blur * px_per_m), dtype=np.float32)
    margin = round(settings.edge_margin * px_per_m)
    mask = np.asarray(model.texture_mask, dtype=np.uint8)
    if margin > 0:
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * margin + 1, 2 * margin + 1))
        mask = np.asarray(cv2.erode(mask, disc), dtype=np.uint8)
    xs = model.points_in[:, 0]
    ys = model.points_in[:, 1]
    gx = np.arange(xs.min(), xs.max() + settings.spacing, settings.spacing)
    gy = np.arange(ys.min(), ys.max() + settings.spacing, settings.spacing)
    x, y = (a.ravel() for a in np.meshgrid(gx, gy))
    u = A[0, 0] * x + A[0, 1] * y + A[0, 2]
    v = A[1, 0] * x + A[1, 1] * y + A[1, 2]
    iu, iv = np.rint(u).astype(int), np.rint(v).astype(int)
    height, width = mask.shape
    inside = (iu >= 0) & (iu < width) & (iv >= 0) & (iv < height)
    inside[inside] = mask[iv[inside], iu[inside]] > 0
    if inside.sum() < settings.min_points:
        return None
    x, y, iu, iv = x[inside], y[inside], iu[inside], iv[inside]
    values = texture[iv, iu].astype(np.float32)
    cx = np.floor((x - x.min()) / settings.cell_size).astype(np.int64)
    cy = np.floor((y - y.min()) / settings.cell_size).astype(np.int64)
    cells = cx * (int(cy.max()) + 1) + cy
    _, cells = np.unique(cells, return_inverse=True)
    return (
        np.ascontiguousarray(x, dtype=np.float32),
        np.ascontiguousarray(y, dtype=np.float32),
        np.ascontiguousarray(values),
        np.ascontiguousarray(cells.astype(np.int64)),
        int(cells.max()) + 1,
    )


__all__ = ["Verification", "VerificationSettings", "Verifier"]
