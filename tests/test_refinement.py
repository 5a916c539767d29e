"""Local refinement: the compass search and the CMA-ES on the continuous pose."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robot_app.config import validate
from robot_app.errors import ConfigError
from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import ModelCamera, PinholeCamera, StereoRig
from robot_app.vision.fitness import FitnessEvaluator, KernelFitness
from robot_app.vision.photo_model import make_model
from robot_app.vision.poses import AvoidedPoses, PoseLimits, moved
from robot_app.vision.refinement import RefinementSettings, Refiner
from robot_app.vision.refinement import cma_search as cma_search_compiled
from robot_app.vision.refinement import compass_search as compass_search_compiled
from robot_app.vision.synthetic import render_model_photo, render_stereo_pair
from robot_app.vision.synthetic_catalogue import synthetic_cloth
from tests.vision_oracles import cma_search, compass_search

START = make_transform(rotation_from_rpy(0.05, -0.03, 0.7), [0.02, -0.01, 0.58])
# The optimum, in the refinement's coordinates (dx, dy, depth along the ray [m], rotation [rad]):
OPTIMUM = np.array([0.003, -0.002, 0.012, 0.02, -0.015, 0.01])
SCALE = RefinementSettings().steps()


def ridge_score(poses: np.ndarray) -> np.ndarray:
    """A narrow ridge where depth and the rotation about the camera x axis must change
    together (as a tilted cloth seen a little farther fills nearly the same pixels), in
    units of the compass steps; peak 1.0 at `OPTIMUM`."""
    target = moved(START, OPTIMUM)
    d_position = (poses[:, :3, 3] - target[:3, 3]) / SCALE[:3]
    d_rotation = Rotation.from_matrix(poses[:, :3, :3] @ target[:3, :3].T).as_rotvec() / SCALE[3:]
    along = d_position[:, 2] + d_rotation[:, 0]
    across = d_position[:, 2] - d_rotation[:, 0]
    q = (d_position[:, :2] ** 2).sum(axis=1) + 0.1 * along**2 + 10 * across**2
    return 1.0 / (1.0 + q + (d_rotation[:, 1:] ** 2).sum(axis=1))


@pytest.mark.parametrize("seed", range(5))
def test_cma_climbs_a_coupled_ridge_to_the_optimum(seed: int) -> None:
    pose, score = cma_search(START, ridge_score, RefinementSettings(), np.random.default_rng(seed))
    assert score == pytest.approx(float(ridge_score(pose[None])[0]))
    assert score > 0.97
    assert np.linalg.norm(pose[:3, 3] - moved(START, OPTIMUM)[:3, 3]) < 1e-3


TRUTH = make_transform(rotation_from_rpy(0.12, -0.05, 1.1), [0.03, -0.02, 0.57])


@pytest.fixture(scope="module")
def evaluator() -> FitnessEvaluator:
    """The fitness of a synthetic stripe cloth at `TRUTH` (320 x 240 pair)."""
    camera = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
    rig = StereoRig(camera, camera, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))
    model_camera = ModelCamera(PinholeCamera.from_fov((640, 480), np.deg2rad(48)), 0.40)
    photo, background = render_model_photo(synthetic_cloth(2), model_camera)
    model = make_model(photo, model_camera, background)
    left, right = render_stereo_pair(rig, [(synthetic_cloth(2), TRUTH)], rng=np.random.default_rng(3))
    evaluator = FitnessEvaluator(model, rig)
    evaluator.update(left, right)
    return evaluator


def test_cma_takes_a_real_fitness_from_a_displaced_start_to_the_true_pose(evaluator) -> None:
    truth = TRUTH

    fitness_at, fine = KernelFitness(evaluator), KernelFitness(evaluator, subpixel=True)
    start = moved(truth, [0.003, -0.002, 0.008, 0.03, 0.0, 0.02])  # 8 mm deeper, 1.7° off in tilt
    for seed in range(3):
        result = cma_search_compiled(
            start, fitness_at, RefinementSettings(), np.random.default_rng(seed), _limits(False), fine
        )
        pose, fitness = result.transform_model_to_camera, result.score
        assert fitness > float(fine(start[None])[0])
        assert np.all(np.abs(pose[:2, 3] - truth[:2, 3]) < 0.001)
        assert abs(pose[2, 3] - truth[2, 3]) < 0.003


# Two avoided regions beside the true pose: one at any yaw, one (holding the true pose)
# within 45° of the cloth's own yaw.
AVOID = AvoidedPoses(
    np.array([[TRUTH[0, 3] + 0.006, TRUTH[1, 3] - 0.004, np.nan], [TRUTH[0, 3] - 0.002, TRUTH[1, 3], 1.3]]),
    0.004,
    float(np.deg2rad(45.0)),
)


def _limits(tight: bool) -> PoseLimits:
    # tight: bounds that reject part of the samples (and the z range the start is in).
    low, high = np.array([-0.25, -0.2, 0.5]), np.array([0.25, 0.2, 0.579 if tight else 0.65])
    return PoseLimits(low, high, float(np.cos(np.deg2rad(8.0 if tight else 20.0))), np.inf)


@pytest.mark.parametrize(
    ("tight", "avoid", "stride"), [(False, None, 1), (True, None, 1), (False, AVOID, 1), (False, None, 2)]
)
def test_compiled_cma_is_the_python_cma_bit_for_bit(evaluator, tight: bool, avoid, stride: int) -> None:
    # stride: the nearest-pixel iterations score every 2nd point, the sub-pixel ones all
    limits = _limits(tight)
    settings = RefinementSettings()
    start = moved(TRUTH, [0.003, -0.002, 0.008, 0.03, 0.0, 0.02])
    before = evaluator.evaluations
    fitness = KernelFitness(evaluator, stride=stride, search=True, avoid=avoid)
    fine = KernelFitness(evaluator, search=True, subpixel=True)
    result = cma_search_compiled(start, fitness, settings, np.random.default_rng(5), limits, fine)
    compiled = (result.transform_model_to_camera, result.score)
    counted = evaluator.evaluations - before

    def allowed(poses: np.ndarray) -> np.ndarray:
        return limits.allows(poses, avoid)

    before = evaluator.evaluations
    python = cma_search(
        start,
        KernelFitness(evaluator, stride=stride, search=True),
        settings,
        np.random.default_rng(5),
        allowed,
        fine,
    )
    # the compiled loop runs under fastmath: the same steps, rounded in another order
    np.testing.assert_allclose(compiled[0], python[0], rtol=0.0, atol=1e-12)
    assert compiled[1] == pytest.approx(python[1], abs=1e-12) and counted == evaluator.evaluations - before
    assert allowed(compiled[0][None])[0] or np.array_equal(compiled[0], start)
    if avoid is not None:  # the true pose is avoided: it ended elsewhere
        assert np.linalg.norm(compiled[0][:2, 3] - TRUTH[:2, 3]) > 0.001


@pytest.mark.parametrize(
    ("tight", "avoid", "subpixel"), [(False, None, True), (True, None, False), (False, AVOID, True)]
)
def test_compiled_compass_is_the_python_compass(evaluator, tight: bool, avoid, subpixel: bool) -> None:
    limits = _limits(tight)
    settings = RefinementSettings()
    start = moved(TRUTH, [0.003, -0.002, 0.008, 0.03, 0.0, 0.02])
    fitness = KernelFitness(evaluator, search=True, subpixel=subpixel, avoid=avoid)
    before = evaluator.evaluations
    result = compass_search_compiled(start, fitness, settings, 30, limits)
    compiled = (result.transform_model_to_camera, result.score)
    counted = evaluator.evaluations - before
    before = evaluator.evaluations
    python = compass_search(start, fitness, settings, 30, lambda poses: limits.allows(poses, avoid))
    # the compiled loop runs under fastmath: the same steps, rounded in another order
    np.testing.assert_allclose(compiled[0], python[0], rtol=0.0, atol=1e-12)
    assert compiled[1] == pytest.approx(python[1], abs=1e-12) and counted == evaluator.evaluations - before
    assert compiled[1] >= float(fitness(start[None])[0])
    if tight:  # the start (tilted ~9°) is outside: the neighbours that are inside are worse
        return
    assert limits.allows(compiled[0][None], avoid)[0] and compiled[1] > float(fitness(start[None])[0])
    if avoid is None:
        assert np.all(np.abs(compiled[0][:2, 3] - TRUTH[:2, 3]) < 0.001)


def test_cma_same_seed_same_result_and_never_leaves_the_allowed_set() -> None:
    settings = RefinementSettings()
    limit = START[0, 3] + 0.001  # the optimum lies beyond: x must stay below this

    def allowed(poses: np.ndarray) -> np.ndarray:
        return poses[:, 0, 3] <= limit

    a, score_a = cma_search(START, ridge_score, settings, np.random.default_rng(4), allowed)
    b, score_b = cma_search(START, ridge_score, settings, np.random.default_rng(4), allowed)
    assert np.array_equal(a, b) and score_a == score_b
    assert a[0, 3] <= limit
    assert score_a > float(ridge_score(START[None])[0])


def test_cma_ranks_by_the_fine_score_at_the_end_and_reports_it() -> None:
    settings = RefinementSettings(cma_iterations=20, cma_fine_iterations=5)
    calls = {"coarse": 0, "fine": 0}

    def coarse(poses: np.ndarray) -> np.ndarray:
        calls["coarse"] += len(poses)
        return ridge_score(poses)

    def fine(poses: np.ndarray) -> np.ndarray:
        calls["fine"] += len(poses)
        return ridge_score(poses) - 0.5  # another scale: the reported score must be this one

    pose, score = cma_search(START, coarse, settings, np.random.default_rng(1), None, fine)
    assert calls["coarse"] > 0 and calls["fine"] > 0
    assert score == pytest.approx(float(fine(pose[None])[0]))


def test_cma_returns_the_start_when_nothing_is_better() -> None:
    def flat(poses: np.ndarray) -> np.ndarray:
        return -np.abs(poses[:, 0, 3] - START[0, 3]) * 1e3  # best exactly at the start

    pose, score = cma_search(START, flat, RefinementSettings(cma_iterations=5), np.random.default_rng(0))
    assert np.array_equal(pose, START) and score == 0.0


def test_settings_are_validated() -> None:
    for key, value in (("cma_population", 2), ("method", "newton"), ("cma_sigma", 0.0)):
        with pytest.raises(ConfigError) as bad:
            validate(RefinementSettings, {key: value})
        assert (bad.value.key, bad.value.value) == (key, value)


def test_a_disabled_refiner_returns_the_pose_unscored() -> None:
    refiner = Refiner(RefinementSettings(enabled=False))
    result = refiner.polish(START, None, None, None, np.random.default_rng(0))  # type: ignore[arg-type]
    assert np.array_equal(result.transform_model_to_camera, START) and result.evaluations == 0
