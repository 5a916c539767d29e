"""Full search (Sec. IV, Fig. 13) on rendered scenes with known cloth poses."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from robot_app.geometry import make_transform, rotation_about_z, yaw_of
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.fitness import FitnessEvaluator
from robot_app.vision.full_search import find_peaks, full_search
from robot_app.vision.photo_model import make_model
from robot_app.vision.plots import plot_full_search
from robot_app.vision.synthetic import occluder_covering, render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)


def _evaluator(index: int, placements, occluder=None) -> FitnessEvaluator:
    cloth = synthetic_cloth(index)
    photo, background = render_model_photo(cloth, MODEL_CAMERA, rng=np.random.default_rng(index))
    evaluator = FitnessEvaluator(make_model(photo, MODEL_CAMERA, background), RIG)
    left, right = render_stereo_pair(RIG, placements, occluder=occluder, rng=np.random.default_rng(7))
    evaluator.update(left, right)
    return evaluator


def test_peak_is_at_the_true_position_within_one_step():
    cloth = synthetic_cloth(3)
    truth = make_transform(np.eye(3), [0.0123, -0.0071, 0.58])
    evaluator = _evaluator(3, [(cloth, truth)])
    result = full_search(evaluator, x_range=(-0.04, 0.06), y_range=(-0.05, 0.04), step=0.001)
    assert result.fitness.shape == (len(result.ys), len(result.xs)) == (91, 101)
    assert np.abs(result.best_transform[:2, 3] - truth[:2, 3]).max() <= 0.001
    assert result.best_fitness > 0.85
    assert result.evaluations == evaluator.evaluations == 91 * 101
    # The map is the evaluator's fitness at each grid pose, nothing else.
    rows, cols = np.array([3, 40, 77]), np.array([5, 50, 99])
    poses = np.repeat(np.eye(4)[None], 3, axis=0)
    poses[:, 0, 3], poses[:, 1, 3], poses[:, 2, 3] = result.xs[cols], result.ys[rows], 0.58
    assert np.allclose(result.fitness[rows, cols], evaluator.evaluate(poses))


def test_whole_area_at_a_coarse_step_finds_the_cloth():
    truth = make_transform(np.eye(3), [-0.111, 0.021, 0.58])
    result = full_search(_evaluator(0, [(synthetic_cloth(0), truth)]), step=0.005)
    assert result.xs[0] == pytest.approx(-0.255) and result.xs[-1] == pytest.approx(0.255)
    assert result.ys[0] == pytest.approx(-0.195) and result.ys[-1] == pytest.approx(0.195)
    assert np.abs(result.best_transform[:2, 3] - truth[:2, 3]).max() <= 0.005


def test_searching_yaws_recovers_the_cloths_yaw():
    truth = make_transform(rotation_about_z(np.deg2rad(40)), [0.02, 0.01, 0.58])
    evaluator = _evaluator(12, [(synthetic_cloth(12), truth)])  # L-shape: no symmetry
    yaws = np.deg2rad(np.arange(-180, 180, 10))
    result = full_search(evaluator, (-0.01, 0.05), (-0.02, 0.04), step=0.002, yaws=yaws)
    assert np.rad2deg(yaw_of(result.rotation)) == pytest.approx(40, abs=1e-6)
    assert np.abs(result.best_transform[:2, 3] - truth[:2, 3]).max() <= 0.002
    assert result.best_yaws is not None and result.best_yaws.shape == result.fitness.shape
    assert result.evaluations == result.fitness.size * len(yaws)


def test_two_copies_give_two_peaks_at_their_positions():
    cloth = synthetic_cloth(3)
    a = make_transform(np.eye(3), [-0.11, 0.02, 0.58])
    b = make_transform(np.eye(3), [0.09, -0.03, 0.58])
    result = full_search(_evaluator(3, [(cloth, a), (cloth, b)]), step=0.002)
    peaks = find_peaks(result, min_separation=0.05, min_fitness=0.5)
    assert len(peaks) == 2
    found = sorted((p.x, p.y) for p in peaks)
    assert np.allclose(found, [a[:2, 3], b[:2, 3]], atol=0.002)


def test_the_models_cloth_is_the_highest_peak_among_two_cloths():
    target = make_transform(np.eye(3), [-0.11, 0.02, 0.58])
    other = make_transform(rotation_about_z(0.3), [0.09, 0.02, 0.58])
    evaluator = _evaluator(3, [(synthetic_cloth(3), target), (synthetic_cloth(9), other)])
    result = full_search(evaluator, step=0.003)
    peaks = find_peaks(result, min_separation=0.05, min_fitness=0.2)
    assert np.allclose(peaks[0][:2], target[:2, 3], atol=0.003)
    assert all(p.fitness < peaks[0].fitness for p in peaks[1:])


def test_a_partly_hidden_cloth_still_peaks_at_its_position_with_lower_fitness():
    cloth = synthetic_cloth(3)
    truth = make_transform(np.eye(3), [0.0, 0.0, 0.58])
    occluder = occluder_covering(cloth, truth, fraction=0.45)
    window = {"x_range": (-0.03, 0.03), "y_range": (-0.03, 0.03), "step": 0.001}
    clear = full_search(_evaluator(3, [(cloth, truth)]), **window)
    hidden = full_search(_evaluator(3, [(cloth, truth)], occluder), **window)
    assert np.abs(hidden.best_transform[:2, 3]).max() <= 0.008
    assert 0.2 < hidden.best_fitness < clear.best_fitness - 0.2


def test_plots_are_written(tmp_path):
    truth = make_transform(np.eye(3), [0.0, 0.0, 0.58])
    result = full_search(_evaluator(0, [(synthetic_cloth(0), truth)]), step=0.01)
    individuals = np.repeat(truth[None], 5, axis=0)
    individuals[:, 0, 3] += np.linspace(-0.01, 0.01, 5)
    plot_full_search(result, tmp_path / "a.png", tmp_path / "b.png", individuals, title="No.1")
    for name in ("a.png", "b.png"):
        image = cv2.imread(str(tmp_path / name))
        assert image is not None and min(image.shape[:2]) > 300


def test_bad_arguments_are_programming_errors():
    # the commands check the user's --step, --depth and bounds before they call these
    evaluator = _evaluator(0, [])
    with pytest.raises(ValueError, match="rotation"):
        full_search(evaluator, rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="x_range"):
        full_search(evaluator, x_range=(0.1, -0.1))
    with pytest.raises(ValueError, match="yaws"):
        full_search(evaluator, yaws=[])
    with pytest.raises(ValueError, match="step"):
        full_search(evaluator, step=0.0)
    result = full_search(evaluator, (-0.01, 0.01), (-0.01, 0.01), step=0.01)
    with pytest.raises(ValueError, match="min_separation"):
        find_peaks(result, min_separation=0.0, min_fitness=0.0)
