"""Tracking: a result far from the prediction whose frame the prediction fits as well.

Close to a blue cloth half under the blue paper (the paper within the cloth's hue band),
the tracker slid onto the paper by ~19 mm a frame with a rising fitness (bench_pick_place
episode 76); fused, it dragged the filter off the cloth. The real `ClothTracker` and
`VisionPipeline` run on fake frames and a fake recogniser whose frame scores
`predicted_fitness` at the filter's prediction.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from robot_app.control.descent_doubt import DescentDoubt, Verdict
from robot_app.control.pose_filter import UpdateReason
from robot_app.geometry import invert_transform, make_transform
from tests.fake_tracking import Frame, first_tracking_update

CAMERA = make_transform(np.eye(3), [0.4, 0.1, 0.3])  # Σ_CR in Σ_W


class FakeCell:
    def __init__(self) -> None:
        self.time, self.dt = 0.5, 0.005

    def capture(self) -> Frame:
        return Frame(self.time, self.time + 0.01, False, CAMERA)


class FakeRecognizer:
    """`track` finds Σ_M at world x `found_x` [m] with search fitness `found_fitness`; the
    frame scores `predicted_fitness` anywhere else (the filter's prediction)."""

    def __init__(self, found_x: float, found_fitness: float, predicted_fitness: float) -> None:
        self.found = make_transform(np.eye(3), [found_x, 0.1, 0.0])
        self.found_fitness = found_fitness
        self.population = None
        self.model = SimpleNamespace(symmetry_angles=(), grasp_point=np.zeros(3))
        self.rig, self.settings = None, SimpleNamespace(fitness=None)
        self.evaluator = SimpleNamespace(evaluate=lambda pose, search: np.array([predicted_fitness]))

    def track(self, left: np.ndarray, right: np.ndarray, motion: object, *, generations: object) -> object:
        return SimpleNamespace(
            transform_model_to_camera=invert_transform(CAMERA) @ self.found,
            found=False,
            fitness=self.found_fitness,
            search_fitness=self.found_fitness,
            evaluations=1,
            confidence=0.5,
        )


def one_tracking_frame(found_x: float, found_fitness: float, predicted_fitness: float):
    """The filter knows a still cloth at x 0.40 m; one tracking frame arrives."""
    return first_tracking_update(FakeCell(), FakeRecognizer(found_x, found_fitness, predicted_fitness))


def test_a_slide_onto_a_look_alike_is_not_fused_and_the_tracker_starts_again_from_the_prediction() -> None:
    # 19 mm off with a better fit (0.96), but the prediction fits the frame nearly as well (0.91)
    tracker, pipeline, update = one_tracking_frame(0.419, 0.96, 0.91)
    assert update.reason is UpdateReason.LOOK_ALIKE and not update.accepted
    assert abs(update.distance - 0.019) < 1e-9
    assert abs(tracker.estimate_at(0.6).x - 0.40) < 1e-9  # the filter stays on the cloth
    assert pipeline._reseed is not None
    doubt = DescentDoubt(0.96)
    assert doubt.judge(update, 0.96) is Verdict.NONE and not doubt.standing  # neither doubts nor confirms


def test_a_cloth_pushed_away_is_not_a_look_alike() -> None:
    # the same result, but the prediction is left on the table: the filter decides as before
    _, _, update = one_tracking_frame(0.419, 0.96, 0.55)
    assert update.reason is not UpdateReason.LOOK_ALIKE


def test_a_result_near_the_prediction_is_fused() -> None:
    tracker, _, update = one_tracking_frame(0.403, 0.96, 0.95)
    assert update.accepted and update.reason is UpdateReason.ACCEPTED
    assert tracker.estimate_at(0.6).x > 0.40
