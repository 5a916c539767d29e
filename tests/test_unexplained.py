"""What one compact cause cannot explain (robot_app/vision/unexplained.py): disagreement
scattered over the model, on point grids with known looks and on rendered scenes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.decide import DecisionSettings, Evidence, logit, ranking
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.hue import COLOUR_CODES, LIGHT
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import RecognitionSettings
from robot_app.vision.synthetic import occluder_covering, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_prints import extended_cloth, folded_corner
from robot_app.vision.unexplained import DisagreementShape, PointLooks, point_looks
from robot_app.vision.verify import Verifier

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
POSE = make_transform(rotation_from_rpy(0.03, -0.02, 0.7), [0.02, -0.01, 0.58])
YELLOW_DOTS_ON_CYAN, CYAN_ROUNDED = 5, 6
_MODELS: dict[int, ClothModel] = {}


def model(index: int) -> ClothModel:
    if index not in _MODELS:
        photo, background = render_model_photo(extended_cloth(index), MODEL_CAMERA)
        _MODELS[index] = make_model(photo, MODEL_CAMERA, background, name=extended_cloth(index).name)
    return _MODELS[index]


def verifier_on(index: int, left: np.ndarray, right: np.ndarray) -> Verifier:
    settings = RecognitionSettings()
    evaluator = FitnessEvaluator(model(index), RIG, settings.fitness, settings.search)
    evaluator.update(left, right)
    verifier = Verifier(model(index), evaluator, settings.search, settings.verify)
    verifier.update(left, right)
    return verifier


GRID = np.array([(x, y) for x in np.linspace(-0.1, 0.1, 21) for y in np.linspace(-0.08, 0.08, 17)])


def looks(match: np.ndarray, sheet: np.ndarray | None = None, other: np.ndarray | None = None) -> PointLooks:
    """Looks of the GRID points, each seen in both images (2 looks)."""
    zero = np.zeros(len(GRID))
    sheet = zero if sheet is None else sheet
    other = zero if other is None else other
    return PointLooks(2.0 * match, 2.0 * sheet, 2.0 * other, zero)


def test_point_looks_tells_own_colour_sheet_other_colour_and_hidden_apart() -> None:
    foreign = np.zeros(COLOUR_CODES + 1, bool)
    foreign[[170, COLOUR_CODES]] = True  # a blue occluder, and off the image
    sheet = np.zeros(COLOUR_CODES + 1, bool)
    sheet[91] = True
    codes = np.array([[135, 91, 37, 170], [140, 91, COLOUR_CODES, LIGHT]])
    result = point_looks(codes, [135, 135, 135, 37], foreign, sheet, 30)
    assert result.match.tolist() == [2, 0, 0, 0]
    assert result.sheet.tolist() == [0, 2, 0, 0]
    assert result.other.tolist() == [0, 0, 1, 1]  # yellow where cyan is due; LIGHT where yellow is
    assert result.hidden.tolist() == [0, 0, 1, 1]


def test_agreement_everywhere_leaves_nothing_unexplained() -> None:
    result = DisagreementShape(GRID).unexplained(looks(np.ones(len(GRID))))
    assert result.scattered == 0.0


def test_one_compact_disagreeing_region_is_explained_and_scattered_dots_are_not() -> None:
    shape = DisagreementShape(GRID)
    corner = GRID @ np.array([np.cos(0.5), np.sin(0.5)]) > 0.05  # a sheet of the model's colour
    compact = shape.unexplained(looks(~corner, other=corner))
    dots = (np.arange(len(GRID)) % 4) == 0  # a quarter of the points, all over the model
    scattered = shape.unexplained(looks(~dots, other=dots))
    assert corner.mean() > 0.15
    assert compact.scattered < 0.02
    assert scattered.scattered > 0.15


def test_the_texture_looks_are_taken_over_the_colours_when_given() -> None:
    shape = DisagreementShape(GRID)
    dots = (np.arange(len(GRID)) % 4) == 0
    # by hue the dots agree (a sheet of one of the print's colours), by texture they do not
    by_texture = shape.unexplained(looks(np.ones(len(GRID))), (2.0 * ~dots, 2.0 * dots))
    assert by_texture.scattered > 0.15


def test_the_whether_terms_change_the_confidence_but_not_the_ranking() -> None:
    settings = DecisionSettings(weight_scattered=-8.0, weight_outline_below_knee=-10.0)
    plain = Evidence(0.9, 0.8, 0.9, 0.0, True, 0.9, 0.9)
    against = Evidence(0.9, 0.8, 0.9, 0.0, True, 0.9, 0.5, scattered=0.2)
    assert ranking(settings, against) == pytest.approx(ranking(settings, plain))
    drop = 8.0 * 0.2 + 10.0 * (settings.outline_knee - 0.5) + settings.weight_outline * 0.4
    assert logit(settings, plain) - logit(settings, against) == pytest.approx(drop)


def test_a_dots_model_on_a_plain_cloth_of_its_ground_colour_disagrees_scattered() -> None:
    plain = render_stereo_pair(RIG, [(extended_cloth(CYAN_ROUNDED), POSE)], rng=np.random.default_rng(1))
    own = render_stereo_pair(RIG, [(extended_cloth(YELLOW_DOTS_ON_CYAN), POSE)], rng=np.random.default_rng(1))
    on_plain = verifier_on(YELLOW_DOTS_ON_CYAN, *plain).unexplained(POSE)
    on_own = verifier_on(YELLOW_DOTS_ON_CYAN, *own).unexplained(POSE)
    assert on_plain.scattered > 0.2
    assert on_own.scattered < 0.03


def test_a_folded_corner_and_a_sheet_of_the_cloths_own_colour_are_not_scattered() -> None:
    cloth = extended_cloth(YELLOW_DOTS_ON_CYAN)
    folded = render_stereo_pair(RIG, [(folded_corner(cloth, 0.18, 0.3), POSE)], rng=np.random.default_rng(2))
    sheet = occluder_covering(cloth, POSE, 0.45, 1.0, colour_bgr=(200, 170, 20))  # a cyan sheet
    covered = render_stereo_pair(RIG, [(cloth, POSE)], occluder=sheet, rng=np.random.default_rng(2))
    # cells along the fold line or the sheet's edge agree in part: some residue, well below
    # the dots model on a plain cloth (> 0.2)
    assert verifier_on(YELLOW_DOTS_ON_CYAN, *folded).unexplained(POSE).scattered < 0.15
    assert verifier_on(YELLOW_DOTS_ON_CYAN, *covered).unexplained(POSE).scattered < 0.15


def test_an_unmeasured_outline_pays_no_knee() -> None:
    # its stand-in (outline_unmeasured, 0.5) lies below the knee, but nothing was measured
    unmeasured = Evidence(0.98, 0.9, 0.99, 0.0, True, 0.9, float("nan"))
    steep = DecisionSettings(weight_outline_below_knee=-10.0)
    flat = DecisionSettings(weight_outline_below_knee=0.0)
    assert logit(steep, unmeasured) == pytest.approx(logit(flat, unmeasured))
    assert logit(steep, replace(unmeasured, outline=0.5)) < logit(flat, replace(unmeasured, outline=0.5))
