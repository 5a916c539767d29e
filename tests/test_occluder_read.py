"""The occluder read: a plain sheet of a hue the model has, over the cloth, is hidden, not a disagreement."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import validate
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, pose_error, rotation_about_z, rotation_from_rpy
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.fitness_scores import OFF_IMAGE
from robot_app.vision.occluder_read import (
    CellStatistics,
    OutlineLooks,
    read_occluders,
    same_colour,
)
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.synthetic import (
    OCCLUDER_COLOURS,
    SyntheticCloth,
    occluder_covering,
    render_stereo_pair,
)
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import extended_cloth
from tests.bench_rig import RIG, catalogue_model

BROWN = OCCLUDER_COLOURS["brown"]
RED_YELLOW_STRIPES, VIOLET_RED_TRAPEZOID, RED_CYAN_TSHIRT = 2, 7, 8
model = catalogue_model


def truth_of(rng: np.random.Generator) -> np.ndarray:
    return make_transform(
        rotation_from_rpy(rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), rng.uniform(-np.pi, np.pi)),
        [rng.uniform(-0.06, 0.06), rng.uniform(-0.04, 0.04), rng.uniform(0.56, 0.60)],
    )


def covered_scene(index: int, seed: int, present: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cloth `index` 45 % under a brown sheet (its hue near the print's red), or the same
    sheet where the cloth would lie with the cloth left out: (left, right, truth)."""
    rng = np.random.default_rng(seed)
    truth = truth_of(rng)
    cloth = extended_cloth(index)
    cover = occluder_covering(cloth, truth, 0.45, float(rng.uniform(0, 2 * np.pi)), colour_bgr=BROWN)
    left, right = render_stereo_pair(
        RIG, [(cloth, truth)] if present else [], occluder=cover, rng=rng, camera=CameraRealism.draw(rng)
    )
    return left, right, truth


def recognised(index: int, left: np.ndarray, right: np.ndarray, seed: int, read: bool = True):
    settings = RecognitionSettings.model_validate({"verify": {"occluder_read": read}})
    return Recognizer(model(index), RIG, settings).recognize(left, right, seed=seed)


def within(result, truth: np.ndarray, index: int) -> bool:
    error = pose_error(result.transform_model_to_camera, truth, model(index).symmetry_angles)
    return abs(error.x_mm) < 6 and abs(error.y_mm) < 6 and abs(error.yaw_deg) < 6


SCENES = [(index, seed) for index in (VIOLET_RED_TRAPEZOID, RED_CYAN_TSHIRT) for seed in range(6)]


def test_prints_under_a_sheet_of_a_near_hue_are_found_at_the_right_pose() -> None:
    # brown over red prints: the sheet is not foreign to the model, so without the read its
    # cells counted as seen and disagreeing (confidence 0.77-0.90 at a right pose), and its
    # hue pulled the search 9-13 mm off: 7 of these 12 scenes found within 6 mm / 6 deg
    # without it, 10 with it. Known misses (trapezoid seed 1, t-shirt seed 2): the search
    # ends on the sheet itself, 84 and 140-180 mm off, where no pose near the cloth is
    # searched (the plane search stays within 36 mm).
    right_and_found, without_read = [], []
    for index, seed in SCENES:
        left, right, truth = covered_scene(index, seed)
        result = recognised(index, left, right, seed)
        right_and_found.append(within(result, truth, index) and result.found)
        before = recognised(index, left, right, seed, read=False)
        without_read.append(within(before, truth, index) and before.found)
    assert sum(right_and_found) >= 10, (right_and_found, without_read)
    assert sum(right_and_found) > sum(without_read) + 2, (right_and_found, without_read)


@pytest.mark.parametrize("index", [VIOLET_RED_TRAPEZOID, RED_CYAN_TSHIRT])
def test_the_sheet_alone_is_not_the_cloth(index: int) -> None:
    for seed in range(2):
        left, right, _ = covered_scene(index, seed, present=False)
        assert not recognised(index, left, right, seed).found


def plain(cloth: SyntheticCloth, colour: tuple[int, int, int], scale: float = 1.0) -> SyntheticCloth:
    """A plain cloth of `colour`: `cloth`'s outline, or a rectangle `scale` times its size."""
    if scale == 1.0:
        texture = np.empty_like(cloth.texture_bgr)
        texture[:] = colour
        return SyntheticCloth("plain", texture, cloth.alpha, cloth.size)
    size = (cloth.size[0] * scale, cloth.size[1] * scale)
    shape = (round(size[1] * 1000), round(size[0] * 1000))
    texture = np.empty((*shape, 3), np.uint8)
    texture[:] = colour
    return SyntheticCloth("plain", texture, np.ones(shape, bool), size)


@pytest.mark.parametrize(("colour", "scale"), [("red", 1.0), ("red", 1.4), ("yellow", 1.4)])
def test_a_plain_cloth_of_one_colour_of_a_print_is_still_rejected(colour: str, scale: float) -> None:
    # one of the stripes' colours, plain: its missing print is not excused, whether the plain
    # cloth ends on the print's outline (nothing is read: its outline pairs show the sheet) or
    # goes on past it everywhere (read as an occluder around the model's own colour, whose
    # outline pairs show that colour going on past the outline: an early version hid those
    # outer points with the occluder and accepted the yellow one at 0.61). A plain cloth of
    # the stripes' outline in their yellow is accepted, at 0.62-0.70, with and without the
    # read: the single-model decision's known limit (`decide.py`).
    cloth = extended_cloth(RED_YELLOW_STRIPES)
    colours = cloth.texture_bgr[cloth.alpha].astype(int)
    pick = (
        colours[:, 2] - colours[:, 1]
        if colour == "red"
        else colours[:, 1] + colours[:, 2] - 2 * colours[:, 0]
    )
    plain_colour = tuple(int(c) for c in colours[np.argmax(pick)])
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        pose = make_transform(rotation_about_z(rng.uniform(-np.pi, np.pi)), [0.0, 0.0, 0.58])
        left, right = render_stereo_pair(
            RIG, [(plain(cloth, plain_colour, scale), pose)], rng=rng, camera=CameraRealism.draw(rng)
        )
        assert not recognised(RED_YELLOW_STRIPES, left, right, seed).found


def test_a_right_pose_is_decided_on_the_sheet_read_as_hidden() -> None:
    # without the read the sheet's cells count as seen and disagreeing (half the compared
    # cells); read as hidden, they leave the evidence: everything in view agrees, the visible
    # fraction is what the sheet leaves, and the confidence does not fall
    settings = RecognitionSettings()
    left, right, truth = covered_scene(VIOLET_RED_TRAPEZOID, 4)
    recognizer = Recognizer(model(VIOLET_RED_TRAPEZOID), RIG, settings)
    recognizer._take(left, right)
    plain = recognizer.verifier.verify(truth)[0]
    read, masks = recognizer.verifier.read_occluders(truth)
    assert masks is not None and 0.35 < read.occluded < 0.55
    assert plain.agreeing < 0.6 < 0.9 < read.agreeing
    assert read.visible_fraction == pytest.approx(plain.visible_fraction - read.occluded)
    assert read.outline == pytest.approx(plain.outline, abs=0.02)
    off = RecognitionSettings.model_validate({"verify": {"occluder_read": False}})
    recognizer_off = Recognizer(model(VIOLET_RED_TRAPEZOID), RIG, off)
    recognizer_off._take(left, right)
    assert recognizer_off.verifier.read_occluders(truth)[1] is None


def test_hidden_pixels_read_off_the_image_and_come_back() -> None:
    settings = RecognitionSettings()
    left, right, truth = covered_scene(VIOLET_RED_TRAPEZOID, 0)
    evaluator = FitnessEvaluator(model(VIOLET_RED_TRAPEZOID), RIG, settings.fitness, settings.search)
    evaluator.update(left, right)
    before = evaluator.evaluate(truth, search=True)
    codes = tuple(c.copy() for c in evaluator.codes)
    mask = np.zeros((480, 640), dtype=bool)
    mask[100:200, 300:400] = True
    with evaluator.pixels_hidden((mask, np.zeros_like(mask))):
        framed = evaluator.codes[0].reshape(483, 643)
        assert (framed[101:201, 301:401] == OFF_IMAGE).all()
        assert (evaluator.codes[1] == codes[1]).all()
    assert all((a == b).all() for a, b in zip(evaluator.codes, codes, strict=True))
    assert evaluator.evaluate(truth, search=True) == pytest.approx(before)
    with pytest.raises(ValueError), evaluator.pixels_hidden((mask[:10], mask)):
        pass


def _statistics(colours: np.ndarray, scores: np.ndarray) -> CellStatistics:
    n = len(scores)
    weights = np.full((2, n), 20.0)
    return CellStatistics(
        np.tile(scores, (2, 1)),
        weights,
        weights.copy(),
        weights.copy(),
        np.tile(colours, (2, 1, 1)),
        np.full((2, n), 3.0),
        np.full((2, n), 20.0),
    )


def _looks(cells: np.ndarray, inner: np.ndarray, outer: np.ndarray, on_sheet: bool) -> OutlineLooks:
    n = len(cells)
    return OutlineLooks(cells, np.ones(n, bool), inner, outer, np.full(n, on_sheet))


def test_a_plain_disagreeing_region_is_an_occluder_only_if_it_goes_on_past_the_outline() -> None:
    # a row of four cells: two agree, two are plain brown and disagree; six outline pairs
    # lie on the brown cells
    brown, green, red = np.array([45.0, 75, 125]), np.array([40.0, 160, 60]), np.array([30.0, 30, 200])
    colours = np.array([red, red, brown, brown])
    statistics = _statistics(colours, np.array([0.9, 0.9, -0.5, -0.5]))
    neighbours = [np.array([1]), np.array([0, 2]), np.array([1, 3]), np.array([2])]
    cells = np.array([2, 2, 2, 3, 3, 3])
    inner = np.tile(brown, (6, 1))
    kwargs = dict(agree_level=0.5, plain=8.0, chroma_tolerance=0.05, brightness_tolerance=0.35,
                  min_pairs=4, continued=0.5)  # fmt: skip
    goes_on = read_occluders(statistics, (_looks(cells, inner, inner, False),) * 2, neighbours, **kwargs)
    assert goes_on.hidden.tolist() == [[False, False, True, True]] * 2
    assert np.allclose(goes_on.colours[0][0], brown)
    ends = read_occluders(
        statistics, (_looks(cells, inner, np.tile(green, (6, 1)), True),) * 2, neighbours, **kwargs
    )
    assert not ends.any  # a print's own plain part: the sheet lies past its outline
    other = read_occluders(
        statistics, (_looks(cells, inner, np.tile(red, (6, 1)), False),) * 2, neighbours, **kwargs
    )
    assert not other.any  # another colour past the outline: not the same region
    assert same_colour(brown, brown * 1.2, 0.05, 0.35) and not same_colour(brown, red, 0.05, 0.35)


def test_the_occluder_settings_are_validated() -> None:
    with pytest.raises(ConfigError):
        validate(RecognitionSettings, {"depth": {"research": {"occluder_min_share": 1.5}}})
    with pytest.raises(ConfigError):
        validate(RecognitionSettings, {"verify": {"occluder_continued": 0.0}})
    off = validate(RecognitionSettings, {"depth": {"research": {"occluder_min_share": None}}})
    assert off.depth.research.occluder_min_share is None
