"""A periodic print's periods, and the propose stage's move from a neighbouring peak to the truth."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.photo_model import make_model
from robot_app.vision.print_periods import PeriodSettings, print_periods
from robot_app.vision.propose import Candidate, Proposer
from robot_app.vision.recognizer import RecognitionSettings
from robot_app.vision.refinement import Refiner
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_prints import extended_cloth

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
POSE = make_transform(rotation_from_rpy(0.03, -0.02, 0.7), [0.02, -0.01, 0.58])
RED_PLAIN, CHECKS, ASTRONAUT = 0, 4, 13
CHECK_CELL = (0.22 / 8, 0.18 / 6)  # [m] the violet-yellow checks' cell (synthetic_catalogue)


def model_of(index: int) -> ClothModel:
    cloth = extended_cloth(index)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    return make_model(photo, MODEL_CAMERA, background, name=cloth.name)


@pytest.fixture(scope="module")
def checks() -> ClothModel:
    return model_of(CHECKS)


def test_the_checks_repeat_by_their_cell_lattice(checks: ClothModel) -> None:
    maps = print_periods(checks, PeriodSettings())
    shifts = maps[maps[:, 0, 0] > 0.5, :2, 3]  # the translations
    assert len(shifts) >= 4
    for shift in shifts:  # a shift by (i, j) cells with i + j even maps the checks onto themselves
        cells = np.abs(shift) / np.array(CHECK_CELL)
        steps = np.round(cells)
        assert np.all(np.abs(cells - steps) * np.array(CHECK_CELL) < 0.003), shift
        assert int(steps.sum()) % 2 == 0, shift
    assert np.all(np.diff(np.linalg.norm(maps[:, :2, 3], axis=1)) >= 0)  # shortest first


@pytest.mark.parametrize("index", [RED_PLAIN, ASTRONAUT])
def test_a_plain_cloth_and_a_photograph_have_no_period(index: int) -> None:
    assert len(print_periods(model_of(index), PeriodSettings())) == 0


@pytest.mark.parametrize("turn", ["shift", "half turn", "quarter turn"])
def test_a_pose_one_period_off_is_moved_back_to_the_truth(checks: ClothModel, turn: str) -> None:
    left, right = render_stereo_pair(RIG, [(extended_cloth(CHECKS), POSE)], rng=np.random.default_rng(3))
    settings = RecognitionSettings()
    evaluator = FitnessEvaluator(checks, RIG, settings.fitness, settings.search)
    evaluator.update(left, right)
    proposer = Proposer(evaluator, settings.propose, Refiner(settings.refine))
    fitness = proposer.fitness()
    cosine = proposer.print_maps[:, 0, 0]
    kind = {"shift": cosine > 0.5, "half turn": cosine < -0.5, "quarter turn": np.abs(cosine) < 0.5}[turn]
    period = proposer.print_maps[kind][0]
    off = POSE @ np.linalg.inv(period)  # the print matches, the outline is off
    rng = np.random.default_rng(0)
    start = proposer.refiner.polish(off, fitness, None, proposer.limits(), rng).transform_model_to_camera
    stuck = Candidate(start, float(fitness(start)[0]))
    before = pose_error(stuck.transform_model_to_camera, POSE, tuple(checks.symmetry_angles))
    assert np.hypot(before.x_mm, before.y_mm) > 10.0 or abs(before.yaw_deg) > 45  # on the neighbouring peak
    moved = proposer._across_periods(stuck, rng, np.zeros((0, 3)))
    error = pose_error(moved.transform_model_to_camera, POSE, tuple(checks.symmetry_angles))
    assert np.hypot(error.x_mm, error.y_mm) < 2.0 and abs(error.yaw_deg) < 1.0
    assert moved.search_fitness > stuck.search_fitness
    settings_off = settings.propose.model_copy(update={"periods": PeriodSettings(enabled=False)})
    alone = Proposer(evaluator, settings_off, Refiner(settings.refine))
    assert alone._across_periods(stuck, rng, np.zeros((0, 3))) is stuck  # off: the GA's end alone
