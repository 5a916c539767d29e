"""Recognitions that take time: exposure stamps, camera latency, recognition latency, drops.

A fake cell (a clock and a camera whose frames arrive `camera_latency` after their
exposure, every third one lost and resent a frame period later) and a fake recogniser
(which takes a set wall time) drive the real `VisionPipeline`.
"""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control import VisionPipeline
from robot_app.geometry import invert_transform, make_transform
from tests.fake_tracking import Frame

DT = 0.005


class FakeCell:
    dt = DT

    def __init__(
        self, camera_latency: float = 0.05, drop_every: int = 0, frame_period: float = 1 / 15
    ) -> None:
        self.time = 0.0
        self.camera_latency = camera_latency
        self.drop_every = drop_every
        self.frame_period = frame_period
        self.frames: list[Frame] = []

    def step(self) -> None:
        self.time += DT

    def capture(self) -> Frame:
        dropped = self.drop_every > 0 and len(self.frames) % self.drop_every == self.drop_every - 1
        latency = self.camera_latency + (self.frame_period if dropped else 0.0)
        pose = make_transform(np.eye(3), [0.001 * len(self.frames), 0.0, 0.5])  # the hand moves in x
        frame = Frame(self.time, self.time + latency, dropped, pose)
        self.frames.append(frame)
        return frame


class FakeRecognizer:
    def __init__(self, wall: float = 0.0) -> None:
        self.wall = wall
        self.motions: list[np.ndarray | None] = []
        self.population = np.eye(4)[None]  # the kept poses: the cloth at the camera's origin
        self.model = SimpleNamespace(
            texture_bgr=None, texture_mask=None, texture_from_model=None
        )  # no warm-up

    def _result(self) -> SimpleNamespace:
        if self.wall:
            time.sleep(self.wall)
        return SimpleNamespace(transform_model_to_camera=np.eye(4), found=True, fitness=1.0)

    def recognize(self, left: np.ndarray, right: np.ndarray, seed: int = 0) -> SimpleNamespace:
        return self._result()

    def track(self, left: np.ndarray, right: np.ndarray, motion: np.ndarray | None, *, generations=None):
        self.motions.append(motion)
        return self._result()


def run(pipeline: VisionPipeline, cell: FakeCell, seconds: float, **poll) -> list:
    results = []
    pipeline.start_tracking()
    while cell.time < seconds:
        cell.step()
        for result in pipeline.poll(**poll):
            assert result.available_time <= cell.time + 1e-9  # never handed over early
            assert cell.time - result.available_time < DT + 1e-9  # nor held back
            results.append(result)
    return results


def test_results_arrive_after_the_camera_and_the_recognition_stamped_with_their_exposure() -> None:
    cell = FakeCell(camera_latency=0.05)
    pipeline = VisionPipeline(cell, FakeRecognizer(), rate_hz=15.0, latency=0.06)  # type: ignore[arg-type]
    results = run(pipeline, cell, 2.0)
    assert len(results) >= 25  # a result per camera period: recognition (60 ms) < period (67 ms)
    for result in results:
        assert result.start_time >= result.capture.available_time - 1e-9
        assert result.available_time == pytest.approx(result.start_time + 0.06)
        assert result.age == pytest.approx(0.11, abs=DT + 1e-9)
    exposures = [r.capture.time for r in results]
    assert exposures == sorted(exposures) and len(set(exposures)) == len(exposures)


def test_a_slow_recogniser_works_on_fresh_frames_not_a_backlog() -> None:
    cell = FakeCell(camera_latency=0.05)
    pipeline = VisionPipeline(cell, FakeRecognizer(), rate_hz=15.0, latency=0.12)  # type: ignore[arg-type]
    results = run(pipeline, cell, 3.0)
    assert pipeline.skipped_triggers > 0
    assert len(cell.frames) - len(results) <= 2  # no frame rendered in vain: one waiting, one in work
    ages = np.array([r.age for r in results])
    assert ages.max() <= 0.05 + 0.12 + 1 / 15 + 2 * DT  # at most one period waiting for the recogniser
    gaps = np.diff([r.available_time for r in results])
    assert gaps.min() >= 0.12 - 1e-9  # one recognition at a time


def test_lost_frames_arrive_a_period_late_and_keep_their_exposure() -> None:
    cell = FakeCell(camera_latency=0.03, drop_every=3)
    pipeline = VisionPipeline(cell, FakeRecognizer(), rate_hz=15.0, latency=0.0)  # type: ignore[arg-type]
    results = run(pipeline, cell, 2.0)
    late = [r for r in results if r.capture.dropped]
    assert late and all(r.age == pytest.approx(0.03 + 1 / 15, abs=DT + 1e-9) for r in late)
    assert all(r.age == pytest.approx(0.03, abs=DT + 1e-9) for r in results if not r.capture.dropped)


def test_measured_latency_is_the_recognitions_wall_time() -> None:
    cell = FakeCell(camera_latency=0.0)
    pipeline = VisionPipeline(cell, FakeRecognizer(wall=0.03), rate_hz=15.0, latency=None)  # type: ignore[arg-type]
    results = run(pipeline, cell, 0.5)
    assert results
    for result in results:
        assert result.compute_s >= 0.03
        assert result.available_time == pytest.approx(result.start_time + result.compute_s)


def test_no_trigger_while_too_close_but_frames_on_their_way_still_arrive() -> None:
    cell = FakeCell(camera_latency=0.05)
    pipeline = VisionPipeline(cell, FakeRecognizer(), rate_hz=15.0, latency=0.06)  # type: ignore[arg-type]
    run(pipeline, cell, 0.3)
    taken = len(cell.frames)
    late = run(pipeline, cell, 0.8, may_capture=False)
    assert len(cell.frames) == taken  # the camera was not triggered
    assert 1 <= len(late) <= 2  # what was already taken still arrived


def test_the_trackers_poses_move_with_the_camera_and_the_predicted_cloth() -> None:
    cell = FakeCell(camera_latency=0.0)
    recognizer = FakeRecognizer()
    pipeline = VisionPipeline(cell, recognizer, rate_hz=15.0, latency=0.0)  # type: ignore[arg-type]
    shift = make_transform(np.eye(3), [0.0, 0.004, 0.0])  # the cloth moves 4 mm between exposures
    run(pipeline, cell, 0.5, cloth_motion=lambda t0, t1: shift)
    motions = [m for m in recognizer.motions if m is not None]
    assert motions
    first, second = cell.frames[0], cell.frames[1]
    expected = (
        invert_transform(second.transform_right_camera_to_world)
        @ shift
        @ first.transform_right_camera_to_world
    )
    np.testing.assert_allclose(motions[0], expected, atol=1e-12)


def test_a_reseed_moves_the_kept_poses_onto_the_prediction() -> None:
    cell = FakeCell(camera_latency=0.0)
    recognizer = FakeRecognizer()
    pipeline = VisionPipeline(cell, recognizer, rate_hz=15.0, latency=0.0)  # type: ignore[arg-type]
    run(pipeline, cell, 0.2)
    n = len(recognizer.motions)  # frame k was tracked with motions[k]
    predicted = make_transform(np.eye(3), [0.3, 0.1, 0.0])
    pipeline.reseed(lambda t: predicted)
    run(pipeline, cell, 0.4)
    frame, reseeded = cell.frames[n], recognizer.motions[n]
    assert reseeded is not None
    # the best kept pose (identity in the old camera) lands on the prediction in the new camera
    np.testing.assert_allclose(
        frame.transform_right_camera_to_world @ reseeded @ recognizer.population[0], predicted, atol=1e-12
    )
    assert not np.allclose(recognizer.motions[n + 1], reseeded)  # once only
