"""Decide stage: found or not, by one calibrated confidence (and, given the catalogue, its rivals).

The confidence combines what the other stages measured at the final pose (`Evidence`):

    confidence = 1 / (1 + exp(-(bias + w_f · fitness + w_a · appearance + w_v · visible
                                + w_i · interleaved + w_g · agreeing
                                + w_av · appearance · visible + w_gv · agreeing · visible
                                + w_o · outline + w_op · outline · (1 - textured)
                                + w_gt · agreeing · textured)))

with `fitness` the search fitness (eqs. 9-11 with occluders taken as hidden, 1.0 = a
perfect match), `outline` the verification's share of the model's outline lying on an
edge of the model's colour (`verify.Verification.outline`), `appearance` the
verification's agreement of the model photo's texture with the images (-1 to 1),
`visible` its visible fraction, `interleaved` its share of the visible texture in partly
hidden cells and `agreeing` its share of cells that agree (a folded corner or a sheet of
the model's own hue disagrees in one compact region,
which the mean appearance counts twice: -1 against +1). `interleaved` tells a sheet over
the cloth (one compact hidden region: only the cells along its edge are partly hidden)
from a cloth of other colours whose stripes or checks of a colour foreign to the model are taken
as hidden (many partly hidden cells): without it a plain red model on a red-yellow
striped cloth looked like a red cloth half under a sheet (confidence 0.93). The two
products weigh the texture's agreement by how much of it was seen: good agreement on half
a cloth (a plain model on the one colour of another cloth whose other colours are taken as
hidden) is weaker evidence than on the whole cloth; with them the held-out rates on the
calibration scenes went from 97.6 % present found / 96.3 % absent rejected to 98.6 / 97.4 %
(10 random halves of the 100-scene calibration set; `w_av = w_gv = 0` with the earlier
weights is the earlier decision).

The weights are a logistic regression fitted on synthetic scenes of present cloths (flat,
wrinkled, folded, 45 % covered by sheets of several colours) against absent ones (other
cloths, same-hue-family cloths), on scene seeds apart from those the benchmark reports
on (`taskset -c 0 python scripts/bench_recognition.py --calibrate --scenes 100
--identification-size 20`, which prints them: 245 present scenes recognised at the right pose
against 480 absent ones, 380 of them the wrong pairs of a 20x20 identification; 5 present
scenes recognised at a wrong pose left out; in sample 98.4 % present found, 98.1 % absent
rejected at the threshold 0.437, where the earlier weights (bias -15.90, fitness 3.52,
appearance 4.46, visible 11.86, interleaved -2.01, agreeing 6.37, threshold 0.691) had
98.0 / 96.9 %), and the threshold is the
one that separated them best there; the bench reports the rates on its test seeds.
Crumpled cloths (`synthetic_prints.crumpled`: two corners turned over, 4-8 mm wrinkles)
were tried among the present calibration scenes and not adopted: with them (50 scenes, 22
recognised at the right pose; the command above with `--kinds
flat,wrinkled,folded,covered,crumpled,absent_family,absent_other`) the fit gave bias
-7.962, fitness 4.186, appearance 0.513, visible 2.694, interleaved 1.493, agreeing
-2.396, appearance·visible 0.417, agreeing·visible 10.070, threshold 0.310; in sample a
crumpled cloth at its right pose was found in 4 of 22, and on the bench's seeds present
found 97.3 -> 98.0 %, absent rejected 96.7 -> 86.7 %, crumpled found 6.7 % of 30. A
crumpled cloth's evidence (appearance -0.97 to +0.35, agreeing 0 to 0.47) is that of an
absent one; one weight vector cannot take both. The clear-table dropped cloth at 4 substeps is
not a decision case either: its best recognition had search fitness 0.26 and agreeing 0.02
(the search did not find it).

The outline (this session's addition): a plain model on another cloth's patch of its
colour (a red plain model on the red stripes or the red patch of another cloth, the other
colours taken as hidden) agrees in texture wherever it is in view, and only the catalogue's
rivals rejected it; its outline does not lie on an edge (the colour goes on past it). Its
weight and a new bias were fitted with the other weights held at the earlier ones, and the
recogniser ranks a pose's alternatives without it (`ranking`): its poses are the earlier
decision's exactly. (A free refit of all weights, and the outline in the ranking, were
measured and dropped: on the bench's 60 scenes the free refit turned a folded stripes
print by half a turn, and the outline in the ranking lost a covered print.) `taskset -c 0
python scripts/bench_recognition.py --calibrate --scenes 100 --identification-size 20
--hold-weights` printed bias -22.753, outline 10.752, threshold 0.594: 243 present scenes
at the right pose, 480 absent; in sample 99.6 % present found and 99.6 % absent rejected,
where the earlier decision had 99.6 / 97.9 % on the same scenes; 10 random halves held
out (bias and outline refitted on each half) 99.2 / 99.4 %, without the outline (all
weights refitted) 97.4 / 97.9 %. The fit is loose: the sets are nearly separable, so the
ridge sets the scale. Pick-and-place episode 44 (violet_cells in the arm's shadow) went
placed -> not_present with this decision, because the outline's colour test ignored the
scene shading (fixed in verify_kernels: placed again, episodes 40-64 25/25). A fine print
(violet_cells) recognised 3-10 mm off under a fold or a cover scored an outline of 0.62-0.78,
as its few agreeing cells left few edges against the ungated seams (two folded and one
covered of the full run's 500 present scenes not found, confidence 0.583, 0.386, 0.449); its
seams are now counted at the cell gate's rate (verify.py), which gives 0.820, 0.763, 0.596
(`b15c/vcells.py`, weights and threshold unchanged, not refitted). The earlier
decision is `weight_outline: 0, bias: -14.335, threshold: 0.437` (the same poses).
A model without texture has no outline to check (`outline_without_texture`, 1.0: nothing
against it); an outline too little of which is in view takes `outline_unmeasured`.

Identity by what the model has (session 19): `textured` is the share of the compared
texture on cells compared by correlation (`verify.Verification.textured_share`, a property of
the model's print more than of the scene). The texture's agreement and the outline say
different things for a plain model and for a print. A plain model's cells are compared by
flatness and mean colour, which any patch of its colour satisfies: a plain cyan or red model
on the patchwork's patch of its colour, the other patches taken as hidden, agreed in 0.92-0.99
of its cells (visible 0.55-0.63), and only its outline (0.56-0.71: the colour goes on past it,
or the hidden part ends exactly on it with the table beyond) said it was part of another
object; present plain models on the bench never scored an outline under 0.82 (flat, wrinkled,
folded, 45 % covered). A print's cells are compared by correlation, which only its own print
satisfies: a yellow-dots model on a plain cyan cloth of nearly its outline (outline 0.85-0.93,
fitness 0.66) agreed in 0.30 of its cells, every dot missing, where a present print agrees in
0.42 or more (folded, covered by a sheet of a near hue). With one outline weight and one
agreeing weight for both, the fitted decision accepted those at 0.60-0.81. Two whether-terms
(`ranking` leaves them out: the poses stay the earlier decision's) weigh that: the outline times
the plain share (`w_op`) and the agreeing share times the textured share (`w_gt`). Fitted with
the other weights held
(`taskset -c 1 python scripts/bench_recognition.py --calibrate --scenes 100
--identification-size 20 --identification-rounds 2 --hold-weights`): bias -27.302, outline
8.345, outline·plain 5.681, agreeing·textured 13.238, threshold 0.640 (was bias -22.753,
outline 10.752, threshold 0.594); 246 present scenes at the right pose against 860 absent
(760 of them wrong identification pairs); in sample 100 / 100 % (the earlier decision on the
same scenes 100 / 99.3 %: six wrong pairs accepted); 20 random halves held out 99.7 / 99.7 %
(the earlier form refitted the same way 99.0 / 99.5 %). On the bench's test seeds
(`scripts/bench_recognition.py --skip-speed --skip-fullsearch`) every pose stayed the same;
identification false accepts 2 / 4 -> 0 / 0 (12x12 / 20x20; `--seed 1` 2 / 4 -> 0 / 1), absent
rejected 99.5 -> 100 %, present found 99.6 -> 99.8 %. **Not adopted**: in the simulated cell
(`scripts/bench_pick_place.py --first 0 --episodes 50 --workers 1 --set loop.vision_latency=0.06`)
it lost episode 31 (No.14, a light-blue knit jersey, wrinkled, in the arm's shadow, 45 % under
the blue paper, a near hue the occluder read did not take): at the right pose its knit agreed in
0.19-0.28 of the cells, as the dots model on plain cyan does, and the fitted decision said
not present (0.05-0.47) where the earlier one found it (0.76-0.92). So a print's agreement is
not yet identity evidence one can weigh this much: a wrinkled, shadowed fine fabric at 320x240
disagrees like a missing print. The defaults keep the earlier decision (both weights 0, bias
-22.753, outline 10.752, threshold 0.594); `--set decide.bias=-27.302 --set
decide.weight_outline=8.345 --set decide.weight_outline_plain=5.681 --set
decide.weight_agreeing_textured=13.238 --set decide.threshold=0.640` gives the fitted one back
(docs/history.md, session 19).

Session 11 measured two more such terms (the outline's knee and a scattered disagreement);
they were not adopted and are gone (history: docs/history.md, "Recognition").

`threshold` is THE acceptance threshold of the project: the recogniser's `found`, the
pick-and-place loop and the trials all use it.

Rivals: does another catalogue model explain the accepted region better? One model's
decision alone cannot tell its cloth from a region of another cloth that shows the
model's colours: a plain red model lying on the red patch of a patchwork cloth
(the other patches of foreign colours taken as hidden) scores like a red cloth half
under a sheet. Where the catalogue is known (in a pick-and-place cell it is: the cloths
the cell handles), the decision asks the catalogue, as `identify` does among all models:
each *rival* (a catalogue model whose main colours share a hue band with the target's,
`overlapping`) is recognised in the same pair, and a rival that is more confident than
the target, explains more than `shared_limit` of the target's explained pixels
(`regions.explained`: the footprint pixels whose colour agrees with the model photo) and
explains more pixels than the target in all describes the same cloth region better: the
target is not found there. The last condition tells the two ways a region is shared: a
plain model on one patch of a catalogue cloth explains a part of what that cloth's model
explains, while a look-alike found on the visible part of a covered target explains less
than the target does (on the calibration seeds a 45 % covered patchwork was otherwise
rejected in favour of the plain red model found on its red patches: confidence 0.901
against 0.899, 66 % of the patchwork's explained pixels, but 24 000 of them against
36 000).

The cost is bounded: only rivals of overlapping hue bands, only for a target the decision
accepted, only when its confidence is below `decisive_confidence`, and only rivals whose
colours the image shows in the target's region and, for most of the rival, in the
foreground (`judge`). Still, a rival search costs more than the target's own: on 12
45 % covered calibration scenes (CPU, one loaded core) a recognition took 47 ms alone and
0.97-1.17 s with its rivals asked (median 5 rivals; `restarts: 1` saves about a sixth).
Without rivals (the default, and the paper's mode) or with `enabled: false` the decision
is the single-model one exactly.

Rivals are not the only thing that rejects an absent cloth: a look-alike outside the
catalogue has no rival, and the single-model decision still has to reject it
(`scripts/bench_recognition.py --rivals leave-out` measures that).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.camera import PinholeCamera
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.fitness_scores import FitnessSettings
from robot_app.vision.hue import COLOUR_CODES, colours_match
from robot_app.vision.recognition import Recognition
from robot_app.vision.regions import Codes, Mask, explained, main_codes, model_area


class DecisionSettings(StrictModel):
    """The confidence and its threshold.

    Attributes:
        threshold: confidence from which the cloth counts as found (the one acceptance
            threshold).
        bias, weight_fitness, weight_appearance, weight_visible, weight_interleaved,
            weight_agreeing, weight_appearance_visible, weight_agreeing_visible: the
            logistic model.
        appearance_without_texture: the appearance a model without texture (a version 1-2
            file) is taken to have; such a model is decided by hue alone.
        appearance_nothing_seen: the appearance when no cell of the texture is in view.
        weight_outline: the logistic weight of the outline evidence (`Evidence.outline`).
        weight_outline_plain: ... and of the outline times the plain share of the compared
            texture (1 - `Evidence.textured_share`): for a plain model the outline is the one
            thing that tells its cloth from a patch of its colour on another.
        weight_agreeing_textured: the logistic weight of the agreeing share times
            `Evidence.textured_share`: for a print the texture's agreement is what tells its
            cloth from another of its hues. Both 0 by default: fitted and measured in session
            19, not adopted (module docstring).
        outline_without_texture: the outline evidence a model without texture is taken to
            have (none against it: decided as before).
        outline_unmeasured: ... and a model with texture whose outline was not measured
            (too little of it in view).
    """

    threshold: float = Field(default=0.594, gt=0.0, lt=1.0)
    bias: float = -22.753
    weight_fitness: float = 8.885
    weight_appearance: float = -0.131
    weight_visible: float = 4.051
    weight_interleaved: float = -3.920
    weight_agreeing: float = -3.089
    weight_appearance_visible: float = 6.162
    weight_agreeing_visible: float = 11.261
    weight_outline: float = 10.752
    weight_outline_plain: float = 0.0
    weight_agreeing_textured: float = 0.0
    outline_without_texture: float = Field(default=1.0, ge=0.0, le=1.0)
    outline_unmeasured: float = Field(default=0.5, ge=0.0, le=1.0)
    appearance_without_texture: float = Field(default=0.6, ge=-1.0, le=1.0)
    appearance_nothing_seen: float = Field(default=-1.0, ge=-1.0, le=1.0)


@dataclass(frozen=True)
class Evidence:
    """What the stages measured at one pose.

    Attributes:
        fitness: the search fitness (1.0 = a perfect match).
        appearance: the texture's agreement with the images, -1 to 1 (NaN: not measured).
        visible_fraction: share of the texture in view and not under a foreign colour.
        interleaved: share of the visible texture in partly hidden cells.
        has_texture: the model has a texture (a version 3 file).
        agreeing: share of the compared cells that agree (NaN: not measured).
        outline: share of the outline pairs on an edge of the model's colour
            (`verify.Verification.outline`; NaN: not measured).
        textured_share: share of the compared texture on cells compared by correlation
            (`verify.Verification.textured_share`; 0: a plain model, or no texture).
    """

    fitness: float
    appearance: float
    visible_fraction: float
    interleaved: float
    has_texture: bool
    agreeing: float = float("nan")
    outline: float = float("nan")
    textured_share: float = 0.0


@dataclass(frozen=True)
class Decision:
    """The decision at one pose.

    Attributes:
        found: confidence >= threshold.
        confidence: in [0, 1].
    """

    found: bool
    confidence: float


def logit(settings: DecisionSettings, evidence: Evidence) -> float:
    """The confidence's log-odds (see the module docstring); a NaN appearance is replaced
    by `appearance_without_texture` (no texture) or `appearance_nothing_seen`, a NaN
    `agreeing` by the same mapped from [-1, 1] onto [0, 1]."""
    appearance, agreeing = _texture(settings, evidence)
    return (
        settings.bias
        + settings.weight_fitness * evidence.fitness
        + settings.weight_appearance * appearance
        + settings.weight_visible * evidence.visible_fraction
        + settings.weight_interleaved * evidence.interleaved
        + settings.weight_agreeing * agreeing
        + settings.weight_appearance_visible * appearance * evidence.visible_fraction
        + settings.weight_agreeing_visible * agreeing * evidence.visible_fraction
        + _whether_terms(settings, evidence)
    )


def _texture(settings: DecisionSettings, evidence: Evidence) -> tuple[float, float]:
    """(appearance, agreeing) with their NaN replaced by the stand-ins (see `logit`)."""
    appearance, agreeing = evidence.appearance, evidence.agreeing
    if math.isnan(appearance):
        appearance = (
            settings.appearance_nothing_seen if evidence.has_texture else settings.appearance_without_texture
        )
    if math.isnan(agreeing):
        agreeing = (appearance + 1.0) / 2.0
    return appearance, agreeing


def ranking(settings: DecisionSettings, evidence: Evidence) -> float:
    """The log-odds without `_whether_terms` (the outline's): how the
    recogniser ranks a pose's alternatives (half and quarter turns, other runs' ends, the
    alignment's neighbours).
    The outline says whether the object is the model's cloth, not which of its poses fits
    best: ranked by it, a print 45 % under a plain sheet of its own colour lost to a plain
    look-alike of its outline beside it (`test_look_alike_sheet.py`, 7 -> 3 of 8) and a
    covered print on the bench moved 4 -> 8.5 mm off (then not found). The other weights
    are held at the earlier ones, so the ranking is the earlier decision's."""
    return logit(settings, evidence) - _whether_terms(settings, evidence)


def _whether_terms(settings: DecisionSettings, evidence: Evidence) -> float:
    """The log-odds terms that say whether the object is the model's cloth, not which of its
    poses fits best: the outline, weighed more where the texture is plain, and the agreeing
    share where it is compared by correlation. `ranking` leaves them out."""
    outline = _outline(settings, evidence)
    textured = min(max(evidence.textured_share, 0.0), 1.0)
    _, agreeing = _texture(settings, evidence)
    return (
        settings.weight_outline * outline
        + settings.weight_outline_plain * outline * (1.0 - textured)
        + settings.weight_agreeing_textured * agreeing * textured
    )


def _outline(settings: DecisionSettings, evidence: Evidence) -> float:
    """The outline evidence, its NaN replaced by the stand-in (see `logit`)."""
    if not math.isnan(evidence.outline):
        return evidence.outline
    return settings.outline_unmeasured if evidence.has_texture else settings.outline_without_texture


def confidence(settings: DecisionSettings, evidence: Evidence) -> float:
    """The calibrated confidence in [0, 1] (see the module docstring)."""
    return 1.0 / (1.0 + math.exp(-max(min(logit(settings, evidence), 60.0), -60.0)))


def decide(settings: DecisionSettings, evidence: Evidence) -> Decision:
    """Found or not at one pose (see `confidence`)."""
    value = confidence(settings, evidence)
    return Decision(value >= settings.threshold, value)


class RivalSettings(StrictModel):
    """The rival test of an accepted recognition.

    Attributes:
        enabled: ask the rivals (when the recogniser has any; `Recognizer.set_rivals`).
        decisive_confidence: from this confidence the target is accepted without asking [0-1].
        min_confidence: a rival counts from this confidence (`identify`'s candidate level) [0-1].
        shared_limit: a rival explaining more than this share of the target's explained
            pixels describes the same region [-].
        coverage: the main colours of a model are those of this share of its S_in points [-].
        min_colour_cover: a rival is asked only if the image's foreground (not the sheet)
            holds enough pixels of its main colours to show at least this share of it, at
            the target's depth (a rival mostly absent from the image cannot be the more
            confident: not worth its search) [-].
        sheet_tolerance: pixels within this of the sheet's hue are the sheet [HSV_FULL steps].
        restarts: cap on a rival search's GA restarts (None: the rival's own
            `propose.restarts`); a rival whose cloth is absent restarts the most.
    """

    enabled: bool = True
    decisive_confidence: float = Field(default=0.999, gt=0.0, le=1.0)
    min_confidence: float = Field(default=0.15, ge=0.0, le=1.0)
    shared_limit: float = Field(default=0.5, gt=0.0, le=1.0)
    coverage: float = Field(default=0.8, gt=0.0, le=1.0)
    min_colour_cover: float = Field(default=0.5, ge=0.0, le=1.0)
    sheet_tolerance: int = Field(default=25, ge=1, le=64)
    restarts: int | None = Field(default=None, ge=0)


@dataclass(frozen=True)
class RivalVerdict:
    """What the rivals said about an accepted recognition.

    Attributes:
        asked: names of the rivals recognised in the pair (empty: none asked).
        winner: the rival that explains the region better ("" if none).
        shared: share of the target's explained pixels the winner explains [-] (NaN: none).
        winner_confidence: the winner's confidence (NaN: none).
    """

    asked: tuple[str, ...] = ()
    winner: str = ""
    shared: float = float("nan")
    winner_confidence: float = float("nan")


def overlapping(
    model: ClothModel, candidates: Sequence[ClothModel], hue_threshold: int, coverage: float = 0.8
) -> list[int]:
    """Indices of the candidates (not `model` itself, by name) whose main colours match one
    of the model's main colours (`hue.colours_match` within `hue_threshold`)."""
    own = main_codes(model, coverage)
    kept = []
    for k, other in enumerate(candidates):
        if other.name == model.name:
            continue
        theirs = main_codes(other, coverage)
        if np.any(colours_match(own[:, None], theirs[None, :], hue_threshold)):
            kept.append(k)
    return kept


@dataclass(frozen=True)
class RivalContext:
    """An accepted recognition the rivals are asked about, and the image they are asked in.

    Attributes:
        model: the target's model (with its photo's texture).
        target: the target's recognition in the pair.
        camera: the (undistorted) right camera the codes are of.
        codes: (H, W) the right image's colour codes.
        fitness: hue threshold and tone settings of the codes.
        settings: the test's limits.
    """

    model: ClothModel
    target: Recognition
    camera: PinholeCamera
    codes: Codes
    fitness: FitnessSettings
    settings: RivalSettings

    def explained_by(self, model: ClothModel, transform_model_to_camera: FloatArray) -> Mask:
        """(H, W) the pixels of the image `model` explains at that pose (`regions.explained`)."""
        _, pixels = explained(model, self.camera, transform_model_to_camera, self.codes, self.fitness)
        return pixels


def judge(context: RivalContext, rivals: Sequence[Rival]) -> RivalVerdict:
    """The rival (if any) that explains the target's region better (module docstring).

    A rival is recognised only if its main colours match more than `shared_limit` of the
    target's explained pixels (else it cannot explain that much of them) and the image's
    foreground holds its colours for at least `min_colour_cover` of it; those are asked in
    order of that share, and the first that explains the region better ends the test.

    Args:
        context: the target, its image and the test's limits.
        rivals: the rivals, each able to recognise itself in the same pair.
    """
    target, settings, hue_threshold = context.target, context.settings, context.fitness.hue_threshold_in
    if context.model.texture_mask is None:
        return RivalVerdict()  # without its photo the target cannot say which pixels it explains
    own = context.explained_by(context.model, target.transform_model_to_camera)
    count = max(int(np.count_nonzero(own)), 1)
    seen = context.codes[own].astype(np.int64)
    present = np.bincount(seen, minlength=COLOUR_CODES)[:COLOUR_CODES]
    palette = np.arange(COLOUR_CODES)
    reachable = []
    for rival in rivals:
        colours = main_codes(rival.model, settings.coverage)
        matching = np.any(colours_match(palette[:, None], colours[None, :], hue_threshold), axis=1)
        share = present[matching].sum() / count
        if share > settings.shared_limit and rival.model.texture_mask is not None:
            reachable.append((share, rival))
    cover = _colour_cover(context, rivals)
    reachable = [
        (share, rival) for share, rival in reachable if cover[rival.model.name] >= settings.min_colour_cover
    ]
    asked: list[str] = []
    for _, rival in sorted(reachable, key=lambda pair: -pair[0]):
        asked.append(rival.model.name)
        answer = rival.recognize_alone()
        if answer.confidence < max(settings.min_confidence, target.confidence):
            continue
        theirs = context.explained_by(rival.model, answer.transform_model_to_camera)
        shared = np.count_nonzero(own & theirs) / count
        if shared > settings.shared_limit and np.count_nonzero(theirs) > count:
            return RivalVerdict(tuple(asked), rival.model.name, float(shared), answer.confidence)
    return RivalVerdict(tuple(asked))


def _colour_cover(context: RivalContext, rivals: Sequence[Rival]) -> dict[str, float]:
    """Per rival, the share of it the image's foreground could show by colour: the sum over
    its main colours c (share p_c of its S_in points) of p_c · min(1, n_c / (p_c · A)), with
    n_c the foreground pixels matching c and A the rival's area in pixels at the target's depth."""
    settings = context.settings
    codes64 = context.codes.astype(np.int64)
    sheet_hue = round(context.model.background_hue) % 256
    sheet = np.asarray(colours_match(codes64, sheet_hue, settings.sheet_tolerance))
    histogram = np.bincount(codes64[~sheet], minlength=COLOUR_CODES + 1)[:COLOUR_CODES]
    palette = np.arange(COLOUR_CODES)
    depth = max(float(context.target.transform_model_to_camera[2, 3]), 1e-3)
    scale = (float(context.camera.camera_matrix[0, 0]) / depth) ** 2
    cover: dict[str, float] = {}
    for rival in rivals:
        area = model_area(rival.model) * scale  # [px]
        codes_in, counts = np.unique(np.asarray(rival.model.hues_in), return_counts=True)
        shares = counts / counts.sum()
        total = 0.0
        for c in main_codes(rival.model, settings.coverage):
            p = float(shares[np.searchsorted(codes_in, c)])
            matching = np.asarray(colours_match(palette, int(c), context.fitness.hue_threshold_in))
            total += p * min(1.0, float(histogram[matching].sum()) / max(p * area, 1.0))
        cover[rival.model.name] = total
    return cover


class Rival(Protocol):
    """A rival as `judge` asks it: its model, and its recognition in the pair at hand."""

    @property
    def model(self) -> ClothModel: ...

    def recognize_alone(self) -> Recognition: ...


__all__ = [
    "Decision",
    "DecisionSettings",
    "Evidence",
    "Rival",
    "RivalContext",
    "RivalSettings",
    "RivalVerdict",
    "confidence",
    "decide",
    "judge",
    "logit",
    "overlapping",
    "ranking",
]
