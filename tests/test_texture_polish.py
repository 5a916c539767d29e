"""Refine stage on the texture: the yaw of a print whose outline barely holds it."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.config import validate
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, pose_error, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.photo_model import make_model
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.refinement import RefinementSettings
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_camera import CameraRealism
from robot_app.vision.synthetic_prints import extended_cloth
from robot_app.vision.texture_polish import in_plane, texture_polish, yaw_weakly_held
from tests.bench_rig import bench_flat_pose

CAMERA = PinholeCamera.from_fov((640, 480), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
MODEL_CAMERA = ModelCamera(CAMERA, 0.40)
AMBER_CAT_ELLIPSE = 15  # a brown photograph on an ellipse: the hue fitness barely holds its yaw
# The flat scenes of the recognition bench's calibration seeds (`bench_recognition.py --seed 1 /
# --seed 2 --kinds flat`) in which the polish on the hue fitness alone ended 1.0-4.5° off in yaw:
# (seed, scene index)
SCENES = [(1, 55), (1, 75), (1, 115), (1, 195), (2, 75), (2, 115), (2, 155)]


def bench_flat_scene(model: ClothModel, seed: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, truth) of the bench's flat scene `k` of `--seed seed` (its `random_pose`,
    then its camera drawn from the realistic ranges and the pair rendered, from the same RNG)."""
    rng = np.random.default_rng([seed, sum(map(ord, "flat")), k])
    truth = bench_flat_pose(rng, model)
    cloth = extended_cloth(AMBER_CAT_ELLIPSE)
    left, right = render_stereo_pair(RIG, [(cloth, truth)], rng=rng, camera=CameraRealism.draw(rng))
    return left, right, truth


@pytest.fixture(scope="module")
def amber_cat() -> ClothModel:
    cloth = extended_cloth(AMBER_CAT_ELLIPSE)
    photo, background = render_model_photo(cloth, MODEL_CAMERA)
    return make_model(photo, MODEL_CAMERA, background, name=cloth.name)


def yaw_errors(model: ClothModel, settings: RecognitionSettings) -> tuple[list[float], list[float]]:
    """|yaw error| [deg] and largest x-y error [mm] of each of `SCENES` recognised."""
    recognizer = Recognizer(model, RIG, settings)
    yaws, positions = [], []
    for seed, k in SCENES:
        left, right, truth = bench_flat_scene(model, seed, k)
        result = recognizer.recognize(left, right, seed=k)
        assert result.found
        error = pose_error(result.transform_model_to_camera, truth, tuple(model.symmetry_angles))
        yaws.append(abs(error.yaw_deg))
        positions.append(max(abs(error.x_mm), abs(error.y_mm)))
    return yaws, positions


def test_an_elliptic_print_is_recognised_within_the_flat_yaw_goal(amber_cat: ClothModel) -> None:
    # issue 15's flat goal: yaw within ±1.5° (the goal is on mean±3σ; here every scene). With
    # `refine.texture_yaw_flat_below: null` (the hue fitness alone) 3 of the 7 ended 1.52, 2.10
    # and 4.46° off and up to 5.0 mm in x-y; with the texture polish at most 0.6° and 1.7 mm
    # (x-y not asserted per scene: its goal is on the spread over the bench's scenes).
    yaws, _ = yaw_errors(amber_cat, RecognitionSettings())
    assert max(yaws) <= 1.5, yaws


def test_the_hue_fitness_holds_the_yaw_of_a_round_outline_weakly_and_of_a_square_firmly() -> None:
    # outline points scored by their closeness (1 mm) to the outline where the image shows it:
    # a circle turned about its centre lies on itself, a square's corners move off it
    def fitness_of(distance, points: np.ndarray):
        def fitness(poses: np.ndarray) -> np.ndarray:
            moved = np.einsum("pij,nj->pni", poses[:, :2, :2], points) + poses[:, None, :2, 3]
            return np.exp(-(distance(moved) ** 2) / 1e-6).mean(axis=1)

        return fitness

    def circle(p: np.ndarray) -> np.ndarray:
        return np.abs(np.linalg.norm(p, axis=-1) - 0.1)

    def square(p: np.ndarray) -> np.ndarray:
        return np.abs(np.max(np.abs(p), axis=-1) - 0.1)

    angle = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    on_circle = np.column_stack([0.1 * np.cos(angle), 0.1 * np.sin(angle)])
    side = np.linspace(-0.1, 0.1, 100)
    on_square = np.vstack([np.column_stack([side, np.full(100, e)]) for e in (-0.1, 0.1)]
                          + [np.column_stack([np.full(100, e), side]) for e in (-0.1, 0.1)])  # fmt: skip
    pose, turn, shift = np.eye(4), np.deg2rad(1.0), 0.001
    assert yaw_weakly_held(pose, fitness_of(circle, on_circle), turn, shift, 0.6)
    assert not yaw_weakly_held(pose, fitness_of(square, on_square), turn, shift, 0.6)
    # a pose off the peak (a shift does not lower the fitness) is not judged
    off_peak = pose @ in_plane(0.003, 0.0, 0.0)
    assert not yaw_weakly_held(off_peak, fitness_of(circle, on_circle), turn, shift, 0.6)


def test_the_pattern_search_climbs_to_the_peak_of_the_agreement_in_the_cloth_plane() -> None:
    start = make_transform(rotation_from_rpy(0.05, -0.02, 0.7), [0.02, -0.01, 0.58])
    peak = start @ in_plane(0.0013, -0.0008, np.deg2rad(1.2))

    def agreement(poses: np.ndarray) -> np.ndarray:
        off = np.linalg.inv(peak) @ poses
        yaw = np.arctan2(off[:, 1, 0], off[:, 0, 0])
        return 1.0 - 1e4 * np.sum(off[:, :2, 3] ** 2, axis=1) - 0.5 * yaw**2

    end = texture_polish(start, agreement, 0.001, np.deg2rad(0.5), 0.00025, 50)
    error = pose_error(end.transform_model_to_camera, peak)
    assert max(abs(error.x_mm), abs(error.y_mm)) <= 0.25 and abs(error.yaw_deg) <= 0.15
    assert end.appearance == pytest.approx(float(agreement(end.transform_model_to_camera[None])[0]))
    # nothing agrees better than the peak itself: it is kept (scored once, six neighbours a round
    # for three rounds, then the parabolas' vertex)
    kept = texture_polish(peak, agreement, 0.001, np.deg2rad(0.5), 0.00025, 50)
    np.testing.assert_allclose(kept.transform_model_to_camera, peak)
    assert kept.evaluations == 1 + 6 * 3 + 1


def test_the_texture_polish_settings_are_checked() -> None:
    with pytest.raises(ConfigError):
        validate(RefinementSettings, {"texture_yaw_flat_below": 0.0})
    with pytest.raises(ConfigError):
        validate(RefinementSettings, {"texture_iterations": 0})
    assert validate(RefinementSettings, {"texture_yaw_flat_below": None}).texture_yaw_flat_below is None
