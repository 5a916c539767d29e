"""A folded-over corner: found as the model's disagreeing half-plane and polished without."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import RecognitionSettings
from robot_app.vision.refinement import CORNER_MARGIN, disagreeing_corner
from robot_app.vision.synthetic import SyntheticCloth, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_prints import extended_cloth, folded_corner
from tests.bench_rig import bench_flat_pose

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
POSE = make_transform(rotation_from_rpy(0.04, -0.03, 2.2), [-0.03, 0.02, 0.575])
VIOLET_RED_TRAPEZOID = 7


@pytest.fixture(scope="module")
def model() -> ClothModel:
    cloth = extended_cloth(VIOLET_RED_TRAPEZOID)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    return make_model(photo, MODEL_CAMERA, background, name=cloth.name)


def evaluator_on(model: ClothModel, fold: float | None) -> FitnessEvaluator:
    cloth = extended_cloth(VIOLET_RED_TRAPEZOID)
    if fold is not None:
        cloth = folded_corner(cloth, 0.18, fold)
    left, right = render_stereo_pair(RIG, [(cloth, POSE)], rng=np.random.default_rng(5))
    settings = RecognitionSettings()
    evaluator = FitnessEvaluator(model, RIG, settings.fitness, settings.search)
    evaluator.update(left, right)
    return evaluator


def test_the_flat_cloth_has_no_disagreeing_corner(model: ClothModel) -> None:
    agree, disagree = evaluator_on(model, None).point_agreement(POSE)
    assert disagree.sum() < 0.05 * agree.sum()
    assert disagreeing_corner(model.points_in, model.points_out, agree, disagree, 0.6) is None


@pytest.mark.parametrize("fold", [0.5, 2.0, 4.0])
def test_the_folded_corner_is_the_disagreeing_half_plane(model: ClothModel, fold: float) -> None:
    evaluator = evaluator_on(model, fold)
    agree, disagree = evaluator.point_agreement(POSE)
    hidden = disagreeing_corner(model.points_in, model.points_out, agree, disagree, 0.6)
    assert hidden is not None
    inside = hidden[: len(model.points_in)]
    # nearly every disagreeing look is in the corner, and the corner (margin aside) is
    # not much bigger than the fold's twice 18 % (the flap and where it came from)
    assert disagree[inside].sum() > 0.9 * disagree.sum()
    assert 0.15 < inside.mean() < 0.36 + 2 * CORNER_MARGIN / float(np.sqrt(np.prod(model.extent)))
    # without the corner the true pose matches nearly perfectly, and better than with it
    trimmed = KernelFitness(evaluator, search=True, hidden=hidden)(POSE)[0]
    whole = KernelFitness(evaluator, search=True)(POSE)[0]
    assert trimmed > 0.9 and trimmed > whole + 0.05


def test_hiding_no_point_is_the_plain_fitness_and_hidden_needs_every_point(model: ClothModel) -> None:
    evaluator = evaluator_on(model, 2.0)
    poses = np.array([POSE, POSE @ make_transform(rotation_from_rpy(0, 0, 0.1), [0.004, 0.0, 0.0])])
    none = np.zeros(evaluator.n_points, dtype=bool)
    for subpixel in (False, True):
        plain = KernelFitness(evaluator, search=True, subpixel=subpixel)(poses)
        masked = KernelFitness(evaluator, search=True, subpixel=subpixel, hidden=none)(poses)
        np.testing.assert_allclose(masked, plain)
    with pytest.raises(ValueError):
        KernelFitness(evaluator, search=True, hidden=none[:-1])
    with pytest.raises(ValueError):
        KernelFitness(evaluator, search=True, stride=2, hidden=none)


def test_the_polish_without_the_corner_settles_on_the_true_pose(model: ClothModel) -> None:
    from robot_app.vision.poses import PoseLimits
    from robot_app.vision.refinement import Refiner

    evaluator = evaluator_on(model, 2.0)
    agree, disagree = evaluator.point_agreement(POSE)
    hidden = disagreeing_corner(model.points_in, model.points_out, agree, disagree, 0.6)
    assert hidden is not None
    start = POSE @ make_transform(rotation_from_rpy(0, 0, 0.03), [0.006, -0.005, 0.0])
    limits = PoseLimits(np.array([-1.0, -1.0, 0.3]), np.array([1.0, 1.0, 1.0]), 0.5, np.inf)
    refiner = Refiner(RecognitionSettings().refine)
    fitness = KernelFitness(evaluator, search=True, hidden=hidden)
    fine = KernelFitness(evaluator, search=True, subpixel=True, hidden=hidden)
    pose = refiner.polish(start, fitness, fine, limits, np.random.default_rng(0)).transform_model_to_camera
    e = pose_error(pose, POSE, ())
    assert abs(e.x_mm) < 2 and abs(e.y_mm) < 2 and abs(e.yaw_deg) < 1


def test_corner_cuts_hide_the_share_farthest_along_evenly_spaced_directions(model: ClothModel) -> None:
    from robot_app.vision.refinement import corner_cuts

    masks = corner_cuts(model.points_in, model.points_out, 8, 0.35)
    n_in = len(model.points_in)
    assert len(masks) == 8 and all(m.shape == (n_in + len(model.points_out),) for m in masks)
    for k, mask in enumerate(masks):
        direction = np.array([np.cos(k * np.pi / 4), np.sin(k * np.pi / 4)])
        along_in, along_out = model.points_in[:, :2] @ direction, model.points_out[:, :2] @ direction
        assert 0.34 < mask[:n_in].mean() < 0.37
        # one straight line cuts both point sets: everything hidden lies beyond everything kept
        hidden = np.concatenate([along_in[mask[:n_in]], along_out[mask[n_in:]]])
        kept = np.concatenate([along_in[~mask[:n_in]], along_out[~mask[n_in:]]])
        assert kept.max() < hidden.min()
    assert len({m.tobytes() for m in masks}) == 8


def test_a_fold_that_pulls_the_hue_peak_off_the_cloth_is_recognised_with_a_tried_corner_hidden() -> None:
    """The bench's folded violet ellipse (`bench_recognition.py` test seeds, folded scene 29):
    a plain print whose 10-20 % fold pulls the hue fitness's peak 15 mm and 14° off; a
    tried corner hidden takes the pose back onto the truth (without: the pose stays off).
    Since session 12 the search on the stereo plane (every yaw, 128 poses ranked by the
    texture) also finds it without the corners; the test holds that search at its earlier
    settings (16° around the turns, 16 ranked) to see the corners' effect, and checks the
    defaults too."""
    from robot_app.vision.recognizer import Recognizer
    from robot_app.vision.synthetic_camera import CameraRealism

    cloth = extended_cloth(9)
    ellipse = _model_of(cloth)
    rng = np.random.default_rng([0, sum(map(ord, "folded")), 29])
    truth = bench_flat_pose(rng, ellipse)
    folded = folded_corner(cloth, float(rng.uniform(0.1, 0.2)), float(rng.uniform(0, 2 * np.pi)))
    left, right = render_stereo_pair(RIG, [(folded, truth)], rng=rng, camera=CameraRealism.draw(rng))
    earlier = {"research": {"yaw_range": 16.0, "shortlist": 16}}
    errors = {}
    for name, tree in (
        ("without", {"refine": {"corner_hypotheses": 0}, "depth": earlier}),
        ("with", {"refine": {"corner_hypotheses": 8}, "depth": earlier}),
        ("defaults", {}),
    ):
        settings = RecognitionSettings.model_validate(tree)
        result = Recognizer(ellipse, RIG, settings).recognize(left, right, seed=29)
        e = pose_error(result.transform_model_to_camera, truth, tuple(ellipse.symmetry_angles))
        errors[name] = max(abs(e.x_mm), abs(e.y_mm), abs(e.yaw_deg))
    assert errors["without"] > 6.0  # the recogniser without it: off (the test can fail)
    assert errors["with"] < 3.0
    assert errors["defaults"] < 3.0


def _model_of(cloth: SyntheticCloth) -> ClothModel:
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    return make_model(photo, MODEL_CAMERA, background, name=cloth.name)


def test_a_look_alike_fitted_in_part_with_a_corner_hidden_is_not_accepted() -> None:
    """The bench's 20x20 identification scene of cloth 6 (cyan_rounded, test seeds) searched
    with the patchwork model (11): the patchwork is not there. With a third of it hidden,
    its kept part fits the cyan cloth's colours well enough for the earlier rule (margin
    alone, `corner_hypothesis_explained: 0`: accepted at 0.84), but not as well as a flat
    cloth scores, so the corner is not adopted and the patchwork is not found."""
    from robot_app.vision.recognizer import Recognizer
    from robot_app.vision.synthetic_camera import CameraRealism

    patchwork = _model_of(extended_cloth(11))
    cyan = extended_cloth(6)
    rng = np.random.default_rng([0, sum(map(ord, "identification20")), 6])
    pose = bench_flat_pose(rng, _model_of(cyan))
    left, right = render_stereo_pair(RIG, [(cyan, pose)], rng=rng, camera=CameraRealism.draw(rng))
    settings = RecognitionSettings.model_validate({"refine": {"corner_hypotheses": 8}})
    # the patchwork is not there: the rule in force rejects it. Whether the earlier rule
    # (`corner_hypothesis_explained: 0`) accepted it depends on the last bits of the search's
    # arithmetic (it did where this was written, not on session 14's AVX-512 machine), so that
    # contrast is not tested; before session 19 the test skipped where it did not show
    assert not Recognizer(patchwork, RIG, settings).recognize(left, right, seed=11 * 20 + 6).found


def test_a_covered_cloth_is_not_taken_for_a_folded_one_where_no_fold_explains_best() -> None:
    """The bench's 45 % covered yellow square (test seeds, covered scene 21): its pose scores
    below the level, so corners are tried; the best end has no disagreeing corner (the pose
    polished again), and the next one, a square shifted 65 mm with half of it "folded" onto
    the bare sheet, scores 0.97 with its corner hidden. The cloth is not taken as folded:
    the pose stays (a variant that passed over the end without a corner took it 65 mm off)."""
    from robot_app.vision.recognizer import Recognizer
    from robot_app.vision.synthetic import OCCLUDER_COLOURS, occluder_covering
    from robot_app.vision.synthetic_camera import CameraRealism

    cloth = extended_cloth(1)
    square = _model_of(cloth)
    rng = np.random.default_rng([0, sum(map(ord, "covered")), 21])
    truth = bench_flat_pose(rng, square)
    colour = list(OCCLUDER_COLOURS.values())[int(rng.integers(len(OCCLUDER_COLOURS)))]
    sheet = occluder_covering(cloth, truth, 0.45, float(rng.uniform(0, 2 * np.pi)), colour_bgr=colour)
    left, right = render_stereo_pair(
        RIG, [(cloth, truth)], occluder=sheet, rng=rng, camera=CameraRealism.draw(rng)
    )
    settings = RecognitionSettings.model_validate({"refine": {"corner_hypotheses": 8}})
    result = Recognizer(square, RIG, settings).recognize(left, right, seed=21)
    e = pose_error(result.transform_model_to_camera, truth, tuple(square.symmetry_angles))
    assert result.found and max(abs(e.x_mm), abs(e.y_mm)) < 3.0


def test_a_folded_periodic_print_is_not_left_half_turned_by_the_folds_polish() -> None:
    # the recognition bench's folded scene 97 (violet_cells, a fine periodic print): the GA
    # ended 34 mm off, the texture preferred its half turn, and the polish with the folded
    # corner hidden then settled half-turned on the truth's centre (0.4 mm, 180°), where the
    # interior matches as well; the fold polish's end is now compared with its own turns
    from robot_app.vision.recognizer import Recognizer
    from robot_app.vision.synthetic_camera import CameraRealism

    violet_cells = 17
    rng = np.random.default_rng([0, sum(map(ord, "folded")), 97])
    cloth = extended_cloth(violet_cells)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    model = make_model(photo, MODEL_CAMERA, background, name=cloth.name)
    radius = 0.5 * float(np.hypot(*model.extent))  # the bench's `random_pose`
    half = (max(0.255 - radius, 0.0), max(0.195 - radius, 0.0))
    tilt, direction = np.deg2rad(10.0) * np.sqrt(rng.uniform()), rng.uniform(0, 2 * np.pi)
    R = rotation_from_rpy(tilt * np.cos(direction), tilt * np.sin(direction), rng.uniform(-np.pi, np.pi))
    t = [rng.uniform(-half[0], half[0]), rng.uniform(-half[1], half[1]), 0.58 + rng.uniform(-0.03, 0.03)]
    truth = make_transform(R, t)
    folded = folded_corner(cloth, float(rng.uniform(0.1, 0.2)), float(rng.uniform(0, 2 * np.pi)))
    left, right = render_stereo_pair(RIG, [(folded, truth)], rng=rng, camera=CameraRealism.draw(rng))
    result = Recognizer(model, RIG).recognize(left, right, seed=97)
    error = pose_error(result.transform_model_to_camera, truth, tuple(model.symmetry_angles))
    assert max(abs(error.x_mm), abs(error.y_mm)) < 6.0 and abs(error.yaw_deg) < 6.0
    assert result.found
