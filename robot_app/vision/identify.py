"""Identification: which of many known cloths lie in a stereo pair, where, and which on top.

One model's decision alone is not enough among many models: a plain or patterned model
lying on part of another cloth whose rest is one foreign colour can look like an
occluded cloth of its own (the identification matrix's false accepts), and a cloth of
the same hue family fits nearly as well as the right one. So every model is recognised
in the pair, and the recognitions are compared region by region (`regions.py`):

0. a model whose main colours (those of 80 % of its S_in points) cover less of the
   image's foreground than `prefilter` of the model's own area at the search depth is not
   looked for (it cannot be there but for a sliver; when what lies on it is gone, it is);
1. each recognition at least `candidate_confidence` confident is a candidate, with its
   footprint and the pixels it explains;
2. candidates are taken most confident first; one whose explained pixels are more than
   `shared_limit` explained by a candidate taken before describes the same cloth region
   and is dropped (the best model per region);
3. foreground pixels (not the green sheet) that no kept detection explains form, where
   they gather into large enough regions, *unknown* regions: a cloth that matches no
   model, or one not recognised (too hidden), or a part of a cloth its model does not
   show (a folded corner's back);
4. of two kept detections whose footprints overlap, the one whose outline inside the
   other's footprint is an edge in the image lies on top (`regions.outline_contrast`: its
   median colour step is `edge_ratio` times the other's); where neither edge says so
   clearly (alike colours, too short an edge), the one explaining more of the overlap
   (equal: the nearer to the camera). Explained pixels alone mislead where the lower
   cloth's plain colour agrees with the upper one's: a white ground under a grey print
   explained the grey as its own, and the hidden cloth was picked from under the other
   (held-out bench episode 668). A detection that nothing lies on and that no unknown
   region covers more than `unknown_cover` of is *free*, and the preferred pick is the
   most confident free one.

Kept detections below the recogniser's own threshold are still candidates for a closer
look (the pick loop searches again and decides); `Detection.found` says which.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, replace

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.exposure import sheet_gains
from robot_app.vision.hue import COLOUR_CODES, colours_match
from robot_app.vision.recognition import Recognition
from robot_app.vision.recognizer import Recognizer
from robot_app.vision.regions import (
    Mask,
    explained,
    image_codes,
    lab_image,
    main_codes,
    model_area,
    outline_contrast,
    sheet_mask,
    undistorted,
)
from robot_app.vision.search_again import Identified, search_again


class IdentifySettings(StrictModel):
    """How recognitions of many models become detections.

    Attributes:
        candidate_confidence: recognitions from this confidence are candidates [0-1].
        shared_limit: a candidate whose explained pixels are more than this share
            explained by a more confident detection describes the same cloth [-].
        sheet_tolerance: sheet pixels are within this of the sheet's hue [HSV_FULL steps].
        sheet_min_saturation: ... and at least this saturated [0-255].
        min_unknown_area: foreground not covered by any detection counts as an unknown
            region from this share of the image's pixels [-].
        explained_margin: a detection's explained pixels are widened by this [px] before
            the foreground they leave is looked at (edges, blur).
        unknown_cover: a detection an unknown region covers more than this share of is not
            free (something unrecognised may lie on it) [-].
        prefilter: share of a model's area its main colours must cover in the foreground
            for it to be searched (0: search every model) [-].
        edge_ratio: which of two overlapping detections lies on top is the one whose outline
            inside the other's footprint steps in colour this many times more than the
            other's does (None: by the explained pixels alone) [-].
        edge_offset: the outline's colour step is between the points this far inside and
            outside it [px of the right image].
        edge_min_points: an outline running over fewer pixels inside the other footprint
            than this says nothing [px].
        search_again: a model not kept whose search ended on a cloth already identified
            (more than `shared_limit` of its explained pixels are a kept detection's) is
            searched once more with the kept detections painted over in a colour foreign
            to it (`search_again`).
    """

    candidate_confidence: float = Field(0.15, ge=0.0, le=1.0)
    shared_limit: float = Field(0.5, gt=0.0, le=1.0)
    sheet_tolerance: int = Field(25, ge=1, le=64)
    sheet_min_saturation: int = Field(40, ge=0, le=255)
    min_unknown_area: float = Field(0.01, gt=0.0, le=1.0)
    explained_margin: int = Field(2, ge=0, le=20)
    unknown_cover: float = Field(0.1, ge=0.0, le=1.0)
    prefilter: float = Field(0.15, ge=0.0, le=1.0)
    edge_ratio: float | None = Field(1.5, gt=1.0)
    edge_offset: float = Field(3.0, gt=0.0, le=20.0)
    edge_min_points: int = Field(25, ge=1)
    search_again: bool = False


@dataclass(frozen=True)
class Detection:
    """One known cloth recognised in a pair.

    Attributes:
        name: the model's name (e.g. "No.3").
        recognition: the model's recognition (pose ^CR T_M, confidence, visible fraction).
        footprint: (H, W) where the cloth would cover the right image, fully visible.
        explained: (H, W) its footprint pixels that agree with the model.
    """

    name: str
    recognition: Recognition
    footprint: Mask
    explained: Mask

    @property
    def found(self) -> bool:
        """The recogniser's own decision."""
        return self.recognition.found

    @property
    def confidence(self) -> float:
        return self.recognition.confidence

    @property
    def transform_model_to_camera(self) -> FloatArray:
        return self.recognition.transform_model_to_camera


@dataclass(frozen=True)
class UnknownRegion:
    """Foreground that no detection covers.

    Attributes:
        centroid: (u, v) in the right image [px].
        area: pixels.
        mask: (H, W) its pixels.
    """

    centroid: tuple[float, float]
    area: int
    mask: Mask


@dataclass(frozen=True)
class Identification:
    """What `identify` made of a pair.

    Attributes:
        detections: one per cloth region, most confident first.
        dropped: (model, detection it lost to) for candidates of an already taken region.
        above: (upper, lower) names of detections lying on others.
        unknown: foreground regions no detection explains, largest first.
        covered: names of detections an unknown region covers more than `unknown_cover` of.
        skipped: models not searched (step 0).
        recognitions: every model's recognition, by name (the second search's for those
            searched again).
        searched_again: models searched a second time (`IdentifySettings.search_again`).
    """

    detections: tuple[Detection, ...]
    dropped: tuple[tuple[str, str], ...]
    above: tuple[tuple[str, str], ...]
    unknown: tuple[UnknownRegion, ...]
    recognitions: Mapping[str, Recognition]
    covered: tuple[str, ...] = ()
    skipped: tuple[str, ...] = ()
    searched_again: tuple[str, ...] = ()

    def free(self) -> tuple[Detection, ...]:
        """Detections nothing lies on (known or unknown), most confident first."""
        lower = {low for _, low in self.above} | set(self.covered)
        return tuple(d for d in self.detections if d.name not in lower)

    def lying_on(self, name: str) -> tuple[str, ...]:
        """Names of the detections lying on `name`."""
        return tuple(up for up, low in self.above if low == name)

    def preferred(self) -> Detection | None:
        """The cloth to pick first: the most confident free detection; without one (a
        ring of overlaps), the most visible."""
        free = self.free()
        if free:
            return free[0]
        if not self.detections:
            return None
        return max(self.detections, key=lambda d: d.recognition.visible_fraction)

    def get(self, name: str) -> Detection | None:
        return next((d for d in self.detections if d.name == name), None)


def identify(
    recognizers: Mapping[str, Recognizer],
    image_left_bgr: npt.NDArray[np.uint8],
    image_right_bgr: npt.NDArray[np.uint8],
    settings: IdentifySettings | None = None,
    *,
    seed: int = 0,
    on_recognition: Callable[[str, Recognition], None] | None = None,
) -> Identification:
    """Recognises every model in the pair and keeps the best model per cloth region.

    Args:
        recognizers: model name -> its recogniser (all on the same rig).
        image_left_bgr, image_right_bgr: the stereo pair.
        settings: see `IdentifySettings`.
        seed: seed of every model's one-shot recognition.
        on_recognition: called after each model's recognition (progress, safe points).

    Raises:
        InputError: images of the wrong type or size.
        ValueError: no recogniser.
    """
    if not recognizers:
        raise ValueError("identify needs at least one recogniser")
    s = settings or IdentifySettings()
    searched = _worth_searching(recognizers, image_right_bgr, s)
    recognitions: dict[str, Recognition] = {}
    for name in searched:
        recognitions[name] = recognizers[name].recognize(image_left_bgr, image_right_bgr, seed=seed)
        if on_recognition is not None:
            on_recognition(name, recognitions[name])
    skipped = tuple(name for name in recognizers if name not in searched)
    found = resolve(recognizers, recognitions, image_right_bgr, s)
    again = _caught_by_kept(recognizers, found, image_right_bgr, s) if s.search_again else []
    looked: dict[str, Recognition] = {}
    if again:
        identified = [
            Identified(recognizers[d.name].model, d.transform_model_to_camera, d.explained)
            for d in found.detections
        ]
        looked = search_again(
            {n: recognizers[n] for n in again},
            identified,
            image_left_bgr, image_right_bgr, margin=s.explained_margin, seed=seed + 1,
            on_recognition=on_recognition,
        )  # fmt: skip
        recognitions.update(looked)  # their first poses lay on kept detections: never kept
        found = resolve(recognizers, recognitions, image_right_bgr, s)
    return replace(found, skipped=skipped, searched_again=tuple(looked))


def _caught_by_kept(
    recognizers: Mapping[str, Recognizer],
    found: Identification,
    image_right_bgr: npt.NDArray[np.uint8],
    s: IdentifySettings,
) -> list[str]:
    """The searched models not kept whose search ended on a kept detection (more than
    `shared_limit` of the pixels their pose explains are a kept detection's: a white
    cloth's search drawn onto a whiter one, bench episode 88, session 23) and whose main
    colours the foreground no kept detection explains still shows for `prefilter` of
    their area (step 0 again, on what is left: else there is nothing to look for)."""
    kept = {d.name for d in found.detections}
    if not kept:
        return []
    first = next(iter(recognizers.values()))
    codes, sheet = codes_and_sheet(first, image_right_bgr, s)
    taken = np.zeros(codes.shape, dtype=bool)
    for d in found.detections:
        taken |= d.explained
    size = 2 * s.explained_margin + 1
    grown = cv2.dilate(taken.astype(np.uint8), np.ones((size, size), np.uint8)) > 0
    left = set(_colours_cover(recognizers, codes, ~sheet & ~grown, s.prefilter))
    caught = []
    for name, r in found.recognitions.items():
        model = recognizers[name].model
        if name in kept or name not in left or model.texture_mask is None:
            continue
        _, agree = explained(
            model, first.rig.right, r.transform_model_to_camera, codes, first.settings.fitness
        )
        own = int(np.count_nonzero(agree))
        if own and np.count_nonzero(agree & taken) / own > s.shared_limit:
            caught.append(name)
    return caught


def _worth_searching(
    recognizers: Mapping[str, Recognizer], image_right_bgr: npt.NDArray[np.uint8], s: IdentifySettings
) -> list[str]:
    """The models whose main colours cover at least `prefilter` of their area in the
    image's foreground (step 0)."""
    names = list(recognizers)
    if s.prefilter <= 0:
        return names
    codes, sheet = codes_and_sheet(recognizers[names[0]], image_right_bgr, s)
    return _colours_cover(recognizers, codes, ~sheet, s.prefilter)


def codes_and_sheet(
    recognizer: Recognizer, image_right_bgr: npt.NDArray[np.uint8], s: IdentifySettings
) -> tuple[npt.NDArray[np.uint16], Mask]:
    """The right image's colour codes (undistorted, after the sheet's exposure gains) and
    its green-sheet pixels, as every model's recogniser on the rig reads them."""
    image = undistorted(image_right_bgr, recognizer.rig.right)
    gains = sheet_gains(image, recognizer.model, recognizer.settings.exposure)
    codes = image_codes(image, gains, recognizer.settings.fitness)
    sheet = sheet_mask(image, recognizer.model.background_hue, s.sheet_tolerance, s.sheet_min_saturation)
    return codes, sheet


def _colours_cover(
    recognizers: Mapping[str, Recognizer], codes: npt.NDArray[np.uint16], where: Mask, share: float
) -> list[str]:
    """The models whose main colours cover at least `share` of their area (at the search
    depth) among the pixels `where` of the image whose colour `codes` are given."""
    present = np.bincount(codes[where].astype(np.int64), minlength=COLOUR_CODES)
    kept = []
    for name, recognizer in recognizers.items():
        model = recognizer.model
        camera = recognizer.rig.right
        depth = float(np.mean(recognizer.settings.propose.bounds.z))
        area = model_area(model) * (camera.camera_matrix[0, 0] / depth) ** 2  # [px]
        matching = colours_match(
            np.arange(COLOUR_CODES)[:, None],
            main_codes(model)[None, :],
            recognizer.settings.fitness.hue_threshold_in,
        )
        if int(present[np.any(matching, axis=1)].sum()) >= share * area:
            kept.append(name)
    return kept


def resolve(
    recognizers: Mapping[str, Recognizer],
    recognitions: Mapping[str, Recognition],
    image_right_bgr: npt.NDArray[np.uint8],
    settings: IdentifySettings | None = None,
) -> Identification:
    """Steps 1-4 of the module docstring on recognitions already made (of the same pair)."""
    s = settings or IdentifySettings()
    first = next(iter(recognizers.values()))
    camera = first.rig.right
    fitness = first.settings.fitness
    codes, sheet = codes_and_sheet(first, image_right_bgr, s)
    candidates = sorted(
        (name for name, r in recognitions.items() if r.confidence >= s.candidate_confidence),
        key=lambda name: -recognitions[name].confidence,
    )
    kept: list[Detection] = []
    dropped: list[tuple[str, str]] = []
    for name in candidates:
        model = recognizers[name].model
        if model.texture_mask is None:
            continue  # a model without its photo cannot say which pixels it explains
        r = recognitions[name]
        area, agree = explained(model, camera, r.transform_model_to_camera, codes, fitness)
        own = max(int(np.count_nonzero(agree)), 1)
        rival = next((d for d in kept if np.count_nonzero(agree & d.explained) / own > s.shared_limit), None)
        if rival is not None:
            dropped.append((name, rival.name))
            continue
        kept.append(Detection(name, r, area, agree))
    lab = lab_image(undistorted(image_right_bgr, camera)) if s.edge_ratio is not None else None
    above = tuple(
        pair for i, a in enumerate(kept) for b in kept[i + 1 :] if (pair := _upper(a, b, lab, s)) is not None
    )
    unknown = _unknown(sheet, kept, s)
    covered = tuple(
        d.name
        for d in kept
        if sum(np.count_nonzero(u.mask & d.footprint) for u in unknown)
        > s.unknown_cover * max(int(np.count_nonzero(d.footprint)), 1)
    )
    return Identification(tuple(kept), tuple(dropped), above, unknown, dict(recognitions), covered)


def _upper(
    a: Detection, b: Detection, image_lab: FloatArray | None, s: IdentifySettings
) -> tuple[str, str] | None:
    """(upper, lower) if the footprints of a and b overlap (step 4 of the module
    docstring); None if they do not."""
    overlap = a.footprint & b.footprint
    if not np.any(overlap):
        return None
    if image_lab is not None and s.edge_ratio is not None:
        inset = int(np.ceil(s.edge_offset)) + 1  # clear of the other's own edge

        def step(edge_of: Detection, inside: Detection) -> float:
            return outline_contrast(
                image_lab, edge_of.footprint, inside.footprint, s.edge_offset, inset, s.edge_min_points
            )

        step_a, step_b = step(a, b), step(b, a)
        if step_a > s.edge_ratio * step_b:  # False with NaN
            return (a.name, b.name)
        if step_b > s.edge_ratio * step_a:
            return (b.name, a.name)
    shown_a = np.count_nonzero(a.explained & overlap)
    shown_b = np.count_nonzero(b.explained & overlap)
    if shown_a == shown_b:  # both look alike there: the nearer one lies on top
        a_nearer = a.transform_model_to_camera[2, 3] <= b.transform_model_to_camera[2, 3]
        return (a.name, b.name) if a_nearer else (b.name, a.name)
    return (a.name, b.name) if shown_a > shown_b else (b.name, a.name)


def without(
    ident: Identification, names: Collection[str], sheet: Mask, settings: IdentifySettings | None = None
) -> Identification:
    """`ident` with the detections `names` taken out: the foreground they explained is
    unknown again where no other detection explains it (`unknown` recomputed from the
    right image's `sheet` pixels, as `identify` does), and no pair `above` or `covered`
    names them."""
    s = settings or IdentifySettings()
    gone = set(names)
    kept = [d for d in ident.detections if d.name not in gone]
    return replace(
        ident,
        detections=tuple(kept),
        above=tuple((up, low) for up, low in ident.above if up not in gone and low not in gone),
        covered=tuple(name for name in ident.covered if name not in gone),
        unknown=_unknown(sheet, kept, s),
    )


def _unknown(sheet: Mask, kept: list[Detection], s: IdentifySettings) -> tuple[UnknownRegion, ...]:
    foreground = np.asarray(~sheet, dtype=np.uint8)
    union = np.zeros(sheet.shape, np.uint8)
    for d in kept:
        union |= d.explained.astype(np.uint8)
    size = 2 * s.explained_margin + 1
    explained_any = np.asarray(cv2.dilate(union, np.ones((size, size), np.uint8)), dtype=np.uint8)
    unexplained = (foreground & (1 - explained_any)).astype(np.uint8)
    rest = np.asarray(
        cv2.morphologyEx(unexplained, cv2.MORPH_OPEN, np.ones((5, 5), np.uint8)), dtype=np.uint8
    )
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(rest, connectivity=8)
    smallest = s.min_unknown_area * sheet.size
    regions = [
        UnknownRegion(
            (float(centroids[k][0]), float(centroids[k][1])), int(stats[k, cv2.CC_STAT_AREA]), labels == k
        )
        for k in range(1, count)
        if stats[k, cv2.CC_STAT_AREA] >= smallest
    ]
    return tuple(sorted(regions, key=lambda region: -region.area))


__all__ = [
    "Detection",
    "Identification",
    "IdentifySettings",
    "UnknownRegion",
    "codes_and_sheet",
    "identify",
    "resolve",
    "without",
]
