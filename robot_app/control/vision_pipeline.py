"""Recognitions that take time, as on a real rig: a triggered camera and one recogniser.

The camera is triggered at `rate_hz` of cell time. A frame shows the scene at its exposure
(`capture.time`) and reaches the computer at `capture.available_time` (the camera's
latency; a lost frame arrives a frame period later). One recogniser works through the
frames in order: it takes a frame once the frame has arrived and it is free, and its
result is available `latency` later (`loop.vision_latency`, or the recognition's measured
wall time when that is None). Meanwhile the arm keeps moving: the loop polls every
control period and receives each result at the cell time it becomes available, stamped
with the exposure time it belongs to.

A trigger is skipped when the recogniser would still be busy when the *next* trigger's
frame arrives (that frame will be fresher), so a slow recogniser works on the newest
frames instead of a queue of old ones. In simulation the recognition itself runs when
the cell time reaches its start, with what the loop knew at that moment (the filter's
motion prediction for the tracker).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.cell import Cell, StereoCapture
from robot_app.geometry import invert_transform
from robot_app.vision import KernelFitness, Recognition, Recognizer, warm_up

# displacement of the cloth in Σ_W between two exposure times -> 4x4 (None: assume still)
ClothMotion = Callable[[float, float], FloatArray | None]
# the cloth's predicted 4x4 pose in Σ_W at an exposure time
ClothPrediction = Callable[[float], FloatArray]


@dataclass(frozen=True)
class VisionResult:
    """One recognition and when it happened.

    Attributes:
        capture: the frame (exposure `capture.time`, camera pose at the exposure).
        recognition: the recogniser's result (^CR T_M, fitness, confidence, found).
        transform_model_to_world: (4, 4) ^W T_M = ^W T_CR(exposure) ^CR T_M [m], read-only.
        mode: "search" (one-shot), "track" (multi-step) or "check" (near a known pose).
        start_time: cell time the recogniser took the frame [s].
        available_time: cell time the result reached the loop [s].
        compute_s: wall time of the recognition [s].
        predicted_fitness: a tracking frame's search fitness, on the same frame, at the
            pose the loop predicted for its exposure (`poll(prediction=...)`), to weigh
            against `search_fitness`; nan without a prediction.
        view_fitness, view_search_fitness: a tracking frame's fitness and search fitness
            at its pose over the model points in view (the tracking GA's normalisation,
            `TrackingSettings.view_floor`); nan: the recognition's own.
    """

    capture: StereoCapture
    recognition: Recognition
    transform_model_to_world: FloatArray
    mode: str
    start_time: float
    available_time: float
    compute_s: float
    predicted_fitness: float = math.nan
    view_fitness: float = math.nan
    view_search_fitness: float = math.nan

    @property
    def fitness(self) -> float:
        """The fitness the loop judges the result by: over the points in view for a
        tracking frame (a close view shows only part of the cloth, and the recognition's
        own fitness counts the rest as missing), else the recognition's."""
        return self.view_fitness if math.isfinite(self.view_fitness) else self.recognition.fitness

    @property
    def search_fitness(self) -> float:
        """The search fitness at the result's pose, over the points in view for a tracking frame."""
        if math.isfinite(self.view_search_fitness):
            return self.view_search_fitness
        return self.recognition.search_fitness

    @property
    def age(self) -> float:
        """Exposure to availability [s]."""
        return self.available_time - self.capture.time


class VisionPipeline:
    """The camera and the recogniser of the loop, with their timing.

    Args:
        cell: the robot cell (its `capture`, its clock).
        recognizer: the target's recogniser.
        rate_hz: camera triggers per second of cell time.
        latency: recognition time in cell time [s]; None: the measured wall time (the
            kernels are then compiled first, `vision.warm_up`: no result pays for that).
        track_generations: GA generations per tracking frame (None: the recogniser's).
        view_floor: the tracking GA's (min_view_fraction, hidden_penalty)
            (`TrackingSettings.view_floor`): a tracking result is also scored over the model
            points in view (`VisionResult.view_fitness`); None: by the recognition's own.
    """

    def __init__(
        self,
        cell: Cell,
        recognizer: Recognizer,
        rate_hz: float,
        latency: float | None = None,
        track_generations: int | None = None,
        view_floor: tuple[float, float] | None = None,
    ) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        if latency is not None and latency < 0:
            raise ValueError(f"latency must be >= 0 [s] or None, got {latency}")
        if latency is None:
            warm_up(recognizer)
        self.cell = cell
        self.recognizer = recognizer
        self.period = 1.0 / rate_hz
        self.latency = latency
        self.track_generations = track_generations
        self.view_floor = view_floor
        self.busy_until = -np.inf
        self.captures = 0
        self.skipped_triggers = 0
        self._camera_latency = 0.0
        self._previous: StereoCapture | None = None
        self._waiting: StereoCapture | None = None
        self._in_flight: list[VisionResult] = []
        self._next_trigger = np.inf
        self._reseed: ClothPrediction | None = None
        self.on_capture: Callable[[StereoCapture], None] | None = None  # e.g. ground truth at the exposure

    # ------------------------------------------------------------------ one-shot
    def search(self, seed: int, capture: StereoCapture | None = None) -> VisionResult:
        """Triggers the camera now and recognises the frame one-shot (GA search); or, given
        `capture`, a frame taken before (of a scene that has not moved since: the clear-table
        job's survey), without triggering.

        The result is stamped with the time it becomes available; the caller waits for it.
        Tracking frames in flight are dropped: the search starts a new track.
        """
        self.stop()
        if capture is None:
            capture = self._trigger()
        start = max(capture.available_time, self.busy_until)
        wall = time.perf_counter()
        recognition = self.recognizer.recognize(capture.left_bgr, capture.right_bgr, seed=seed)
        result = self._result(capture, recognition, "search", start, time.perf_counter() - wall)
        self.busy_until = result.available_time
        self._previous = capture
        return result

    def check(self, capture: StereoCapture, transform_model_to_world: FloatArray, seed: int) -> VisionResult:
        """Recognises an arrived frame near a known pose (`Recognizer.check`, no GA), once
        the recogniser is free; the result is stamped like a search's (the caller waits).

        Args:
            capture: a frame already taken (e.g. the second look's).
            transform_model_to_world: (4, 4) where the cloth is expected in Σ_W [m].
            seed: seed of the polish.
        """
        start = max(capture.available_time, self.busy_until, self.cell.time)
        expected = invert_transform(capture.transform_right_camera_to_world) @ transform_model_to_world
        wall = time.perf_counter()
        recognition = self.recognizer.check(capture.left_bgr, capture.right_bgr, expected, seed=seed)
        result = self._result(capture, recognition, "check", start, time.perf_counter() - wall)
        self.busy_until = result.available_time
        return result

    # ------------------------------------------------------------------ tracking
    def start_tracking(self) -> None:
        """Triggers from now on at the vision rate (after a search or a previous track)."""
        self._next_trigger = self.cell.time

    def stop(self) -> None:
        """Stops triggering and drops the frames and results still on their way."""
        self._next_trigger = np.inf
        self._waiting = None
        self._in_flight.clear()

    @property
    def tracking(self) -> bool:
        return bool(np.isfinite(self._next_trigger))

    def reseed(self, prediction: ClothPrediction) -> None:
        """Moves the tracker's kept poses onto `prediction` for the next frame (they settled
        on a wrong peak, e.g. the cloth half a turn round): the best kept pose lands on the
        predicted pose at that frame's exposure, the others move with it."""
        self._reseed = prediction

    def poll(
        self,
        *,
        may_capture: bool = True,
        cloth_motion: ClothMotion | None = None,
        prediction: ClothPrediction | None = None,
    ) -> list[VisionResult]:
        """Call once per control period: triggers, recognises and delivers what is due.

        Args:
            may_capture: False keeps the camera from triggering (e.g. closer to the cloth
                than the cameras' working distance); frames already taken still arrive.
            cloth_motion: the cloth's predicted displacement in Σ_W between two exposures
                (4x4); the tracker's kept poses move by it as well as by the camera's motion.
            prediction: the cloth's predicted pose in Σ_W at a time (4x4): each tracking
                frame is also scored there (`VisionResult.predicted_fitness`).

        Returns:
            The results that became available by now, oldest first.
        """
        now = self.cell.time
        ticked = now >= self._next_trigger
        if ticked:
            while self._next_trigger <= now:
                self._next_trigger += self.period
            if may_capture:
                arrival_next = now + self.period + self._camera_latency
                if self._waiting is not None or self.busy_until > arrival_next:
                    self.skipped_triggers += 1  # a frame waits, or the next trigger's is fresher in time
                else:
                    self._waiting = self._trigger()
        waiting = self._waiting
        if waiting is not None and waiting.available_time <= now and self.busy_until <= now:
            self._waiting = None
            start = max(waiting.available_time, self.busy_until)
            self._in_flight.append(self._track(waiting, start, cloth_motion, prediction))
        due = [r for r in self._in_flight if r.available_time <= now + 1e-12]
        self._in_flight = [r for r in self._in_flight if r.available_time > now + 1e-12]
        return due

    # ------------------------------------------------------------------ internals
    def _trigger(self) -> StereoCapture:
        capture = self.cell.capture()
        self.captures += 1
        if self.on_capture is not None:
            self.on_capture(capture)
        self._camera_latency = max(0.0, capture.available_time - capture.time)
        return capture

    def _track(
        self,
        capture: StereoCapture,
        start: float,
        cloth_motion: ClothMotion | None,
        prediction: ClothPrediction | None = None,
    ) -> VisionResult:
        previous = self._previous
        motion = None
        if previous is not None:
            world_motion = cloth_motion(previous.time, capture.time) if cloth_motion is not None else None
            displacement = np.eye(4) if world_motion is None else world_motion
            motion = (
                invert_transform(capture.transform_right_camera_to_world)
                @ displacement
                @ previous.transform_right_camera_to_world
            )
        kept = self.recognizer.population
        if self._reseed is not None and kept is not None:
            predicted = invert_transform(capture.transform_right_camera_to_world) @ self._reseed(capture.time)
            motion = predicted @ invert_transform(kept[0])
        self._reseed = None
        wall = time.perf_counter()
        recognition = self.recognizer.track(
            capture.left_bgr, capture.right_bgr, motion, generations=self.track_generations
        )
        floor = self.view_floor
        predicted_fitness = math.nan
        if prediction is not None:  # the same frame at the predicted pose (one pose: ~0.1 ms)
            predicted = invert_transform(capture.transform_right_camera_to_world) @ prediction(capture.time)
            predicted_fitness = self._search_fitness(predicted, floor)
        view_fitness = view_search_fitness = math.nan
        if floor is not None:
            pose = recognition.transform_model_to_camera
            view_fitness = float(KernelFitness(self.recognizer.evaluator, view_floor=floor)(pose)[0])
            view_search_fitness = self._search_fitness(pose, floor)
        result = self._result(capture, recognition, "track", start, time.perf_counter() - wall)
        result = dataclasses.replace(
            result,
            predicted_fitness=predicted_fitness,
            view_fitness=view_fitness,
            view_search_fitness=view_search_fitness,
        )
        self.busy_until = result.available_time
        self._previous = capture
        return result

    def _search_fitness(self, pose: FloatArray, view_floor: tuple[float, float] | None) -> float:
        """The search fitness of the pose ^CR T_M on the current pair, over the points in
        view with `view_floor` (the tracking GA's normalisation), else the search's own."""
        evaluator = self.recognizer.evaluator
        if view_floor is None:
            return float(evaluator.evaluate(pose, search=True)[0])
        return float(KernelFitness(evaluator, search=True, view_floor=view_floor)(pose)[0])

    def _result(
        self, capture: StereoCapture, recognition: Recognition, mode: str, start: float, compute_s: float
    ) -> VisionResult:
        latency = compute_s if self.latency is None else self.latency
        pose = capture.transform_right_camera_to_world @ recognition.transform_model_to_camera
        pose.setflags(write=False)
        return VisionResult(capture, recognition, pose, mode, start, start + latency, compute_s)


__all__ = ["ClothMotion", "ClothPrediction", "VisionPipeline", "VisionResult"]
