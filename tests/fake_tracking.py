"""Fakes shared by the tracker tests: a captured frame, and the real tracker on fake parts.

The real `VisionPipeline` and `ClothTracker` run on a fake cell (a clock and a camera) and
a fake recogniser that each test file defines for what it checks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from robot_app.control import VisionPipeline
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.pose_filter import FilterUpdate
from robot_app.geometry import make_transform


@dataclass(frozen=True)
class Frame:
    """A stereo capture as the loop reads it: exposure and arrival [s], blank images."""

    time: float
    available_time: float
    dropped: bool
    transform_right_camera_to_world: np.ndarray
    left_bgr: np.ndarray = field(default_factory=lambda: np.zeros((2, 2, 3), np.uint8))
    right_bgr: np.ndarray = field(default_factory=lambda: np.zeros((2, 2, 3), np.uint8))


def tracker_and_pipeline(cell: object, recognizer: object, phase: str) -> tuple[ClothTracker, VisionPipeline]:
    """The real tracker and pipeline (15 Hz, 60 ms recognition) on fake parts, in `phase`."""
    pipeline = VisionPipeline(cell, recognizer, rate_hz=15.0, latency=0.06)  # type: ignore[arg-type]
    tracker = ClothTracker(
        cell,  # type: ignore[arg-type]
        recognizer,  # type: ignore[arg-type]
        pipeline,
        None,
        predict_motion=True,
        phase=lambda: phase,
    )
    return tracker, pipeline


def first_tracking_update(
    cell: object, recognizer: object, may_fuse: Callable[[object], bool] | None = None
) -> tuple[ClothTracker, VisionPipeline, FilterUpdate]:
    """The filter knows a still cloth at x 0.40 m (y 0.1, z 0); DESCEND tracks until the
    first tracking frame's result reaches the filter."""
    tracker, pipeline = tracker_and_pipeline(cell, recognizer, "descend")
    tracker.filter.reset(make_transform(np.eye(3), [0.40, 0.1, 0.0]), 0.45)
    tracker.start_tracking()
    updates: list[FilterUpdate] = []
    while not updates:
        updates = tracker.poll() if may_fuse is None else tracker.poll(may_fuse=may_fuse)
        cell.time += cell.dt  # type: ignore[attr-defined]
    return tracker, pipeline, updates[0]
