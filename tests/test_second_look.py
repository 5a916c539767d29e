"""SEARCH's two looks: the first look's pose checked on the second look's frame.

A periodic print (No.4's checks) fits a pose shifted by one period nearly as well, and
the second look's GA may settle there: a still cloth then seems to move. The real
`ClothTracker` and `VisionPipeline` run on fake frames and a fake recogniser.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control import VisionPipeline, cloth_tracker
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.vision_pipeline import VisionResult
from robot_app.geometry import invert_transform, make_transform
from tests.fake_tracking import Frame, tracker_and_pipeline

CAMERA = make_transform(np.eye(3), [0.4, 0.1, 0.5])  # Σ_CR in Σ_W, still at the observation pose


class FakeRecognizer:
    """`check` returns the expected pose moved by `polish` (in Σ_CR) with the next of
    `check_fitness` (the first look's pose on the second frame, then the second's on the first)."""

    def __init__(self, check_fitness: tuple[float, float], polish: np.ndarray | None = None) -> None:
        self.check_fitness = list(check_fitness)
        self.polish = np.eye(4) if polish is None else polish
        self.checked: list[np.ndarray] = []
        self.population = np.eye(4)[None]
        self.model = SimpleNamespace(symmetry_angles=(), grasp_point=np.zeros(3))
        self.rig, self.settings = None, SimpleNamespace(fitness=None)

    def check(self, left: np.ndarray, right: np.ndarray, pose: np.ndarray, *, seed: int) -> SimpleNamespace:
        self.checked.append(pose)
        return recognition(self.polish @ pose, self.check_fitness.pop(0))


def recognition(pose_in_camera: np.ndarray, fitness: float) -> SimpleNamespace:
    return SimpleNamespace(
        transform_model_to_camera=pose_in_camera, found=True, fitness=fitness, evaluations=1, confidence=1.0
    )


def look(t: float, x: float, fitness: float) -> VisionResult:
    """A one-shot look exposed at `t` [s] that found Σ_M at world x [m] (y 0.1, z 0)."""
    frame = Frame(t, t + 0.05, False, CAMERA)
    world = make_transform(np.eye(3), [x, 0.1, 0.0])
    result = recognition(invert_transform(CAMERA) @ world, fitness)
    return VisionResult(frame, result, world, "search", t + 0.05, t + 0.11, 0.0)  # type: ignore[arg-type]


def two_looks(
    second_x: float, second_fitness: float, recognizer: FakeRecognizer, first_fitness: float = 0.90
) -> tuple[ClothTracker, VisionPipeline]:
    cell = SimpleNamespace(time=0.5, dt=0.005)
    tracker, pipeline = tracker_and_pipeline(cell, recognizer, "search")
    first, second = look(0.30, 0.40, first_fitness), look(0.42, second_x, second_fitness)
    tracker.filter.reset(first.transform_model_to_world, first.capture.time)  # as take_search does
    on_second = pipeline.check(second.capture, first.transform_model_to_world, seed=0)
    on_first = pipeline.check(first.capture, second.transform_model_to_world, seed=0)
    assert on_second.mode == "check" and on_second.capture is second.capture
    assert on_second.available_time >= cell.time + 0.06  # it waits for the recogniser like a search
    assert on_first.available_time >= on_second.available_time + 0.06  # one recogniser: in turn
    expected = invert_transform(CAMERA) @ first.transform_model_to_world  # the pose in the second's camera
    np.testing.assert_allclose(recognizer.checked[0], expected)
    tracker.take_second_look(first, second, (on_second, on_first))
    return tracker, pipeline


def test_a_second_look_on_a_neighbouring_peak_does_not_make_a_still_cloth_move() -> None:
    # the second look settled 20 mm off (one period) with a worse fit; the first look's
    # pose fits the second frame better: the cloth is still, at the first look's place
    tracker, pipeline = two_looks(0.42, 0.82, FakeRecognizer(check_fitness=(0.90, 0.80)))
    estimate = tracker.estimate_at(0.42)
    assert np.linalg.norm(estimate.velocity[:2]) < 1e-6
    assert abs(estimate.x - 0.40) < 1e-6
    rows = tracker.recognitions
    assert [r.mode for r in rows] == ["check", "search", "check"]
    assert [r.accepted for r in rows] == [False, False, True]
    assert pipeline._reseed is not None  # tracking starts from the filter, not the second look's peak


def test_a_first_look_on_a_worse_peak_gives_way_to_the_second(monkeypatch: pytest.MonkeyPatch) -> None:
    # the first look settled 12 mm off (fit 0.82); the second look's pose fits the first
    # frame better (0.92): the cloth is still, where the second look saw it, and the grasp
    # point is chosen in the second look's view
    chosen: list[np.ndarray] = []
    point = np.array([0.01, 0.02, 0.0])
    monkeypatch.setattr(
        cloth_tracker, "visible_grasp_point", lambda model, rig, T, *rest: chosen.append(T) or point
    )
    tracker, pipeline = two_looks(0.412, 0.93, FakeRecognizer(check_fitness=(0.84, 0.92)), first_fitness=0.82)
    estimate = tracker.estimate_at(0.42)
    assert np.linalg.norm(estimate.velocity[:2]) < 1e-6
    assert abs(estimate.x - 0.412) < 1e-6
    assert [r.accepted for r in tracker.recognitions] == [True, True, False]
    assert pipeline._reseed is None  # the kept poses are the second look's: the right peak
    assert len(chosen) == 1 and abs(chosen[0][0, 3] - (0.412 - 0.4)) < 1e-9  # in Σ_CR: x 12 mm
    np.testing.assert_array_equal(tracker.grasp_point_model, point)


def test_a_moving_cloth_keeps_the_velocity_of_its_two_looks() -> None:
    # the cloth moved 6 mm (50 mm/s): the first look's pose, polished on the second frame,
    # fits it worse than the second look does, and the second look gives the velocity
    tracker, pipeline = two_looks(0.406, 0.90, FakeRecognizer(check_fitness=(0.70, 0.72)))
    estimate = tracker.estimate_at(0.42)
    np.testing.assert_allclose(estimate.velocity[:2], [0.05, 0.0], atol=1e-6)
    assert [r.accepted for r in tracker.recognitions] == [False, True, False]
    assert pipeline._reseed is None


def test_a_check_that_follows_the_moved_cloth_gives_its_velocity() -> None:
    # the polish climbed onto the moved cloth (6 mm in x) and fits as well as the second look
    polish = make_transform(np.eye(3), [0.006, 0.0, 0.0])  # Σ_CR's x is Σ_W's x here
    tracker, _ = two_looks(0.406, 0.89, FakeRecognizer(check_fitness=(0.90, 0.70), polish=polish))
    np.testing.assert_allclose(tracker.estimate_at(0.42).velocity[:2], [0.05, 0.0], atol=1e-6)
