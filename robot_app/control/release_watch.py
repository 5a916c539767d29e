"""After letting go over the box: has the cloth come to rest? The hand camera tells.

The fingers open and the hand leaves once the cloth has stopped falling under it: the
right hand camera, still over the box, takes a frame every `1 / rate_hz` [s]; the cloth
has come to rest when `frames` successive pairs of frames differ in at most `share` of
their pixels (`image_change`: grey levels moved by `threshold` or more, on images
shrunk by `SHRINK` against noise). A cloth still moving `longest` [s] after letting go
is noted and the fingers open then, as after the fixed `loop.release_wait` before: the
watch never waits longer than that wait did.

A frame is compared only once it has arrived (`available_time`): the hand waits for it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np
import numpy.typing as npt

from robot_app.control.cell import Cell

SHRINK = 4  # frames are compared at a quarter of their size: single-pixel noise averages out


class Holder(Protocol):
    """What the watch needs of an arm mover (`ArmMotion`, `JobMotion`)."""

    def hold(self, duration: float) -> None:
        """Holds still for `duration` [s]."""
        ...


@dataclass(frozen=True)
class Settling:
    """What the watch saw.

    Attributes:
        settled: the cloth came to rest before `longest`.
        waited: time from letting go until the fingers may open [s].
        frames: frames taken.
        last_change: share of pixels changed between the last two frames [-].
    """

    settled: bool
    waited: float
    frames: int
    last_change: float


def image_change(before: npt.NDArray[np.uint8], after: npt.NDArray[np.uint8], threshold: float) -> float:
    """Share of pixels [-] whose grey level moved by `threshold` or more between two BGR
    frames of one camera, both shrunk by `SHRINK` first."""
    if before.shape != after.shape:
        raise ValueError(f"frames of different sizes: {before.shape} and {after.shape}")
    size = (max(1, before.shape[1] // SHRINK), max(1, before.shape[0] // SHRINK))
    grey = [
        cv2.resize(
            cv2.cvtColor(np.ascontiguousarray(f), cv2.COLOR_BGR2GRAY), size, interpolation=cv2.INTER_AREA
        )
        for f in (before, after)
    ]
    moved = np.abs(grey[1].astype(np.int16) - grey[0].astype(np.int16)) >= threshold
    return float(np.mean(moved))


def wait_until_settled(
    motion: Holder,
    cell: Cell,
    *,
    rate_hz: float,
    longest: float,
    threshold: float,
    share: float,
    frames: int,
) -> Settling:
    """Holds the hand still, watching, until the cloth under it has come to rest (module
    docstring), at most `longest` [s] from the call (no frame that arrives later counts)."""
    if rate_hz <= 0 or longest < 0 or frames < 1:
        raise ValueError(f"rate_hz > 0, longest >= 0 and frames >= 1, got {rate_hz}, {longest}, {frames}")
    start, period = cell.time, 1.0 / rate_hz
    deadline = start + longest
    previous: npt.NDArray[np.uint8] | None = None
    still = taken = 0
    change = float("nan")
    while True:
        exposure = cell.time
        capture = cell.capture()
        taken += 1
        if capture.available_time > deadline:  # it would arrive too late to count
            motion.hold(max(0.0, deadline - cell.time))
            return Settling(False, cell.time - start, taken, change)
        motion.hold(max(0.0, capture.available_time - cell.time))  # not before it has arrived
        image = np.asarray(capture.right_bgr)
        if previous is not None:
            change = image_change(previous, image, threshold)
            still = still + 1 if change <= share else 0
            if still >= frames:
                return Settling(True, cell.time - start, taken, change)
        previous = image
        if deadline - cell.time < cell.dt / 2:  # no later frame before the deadline
            motion.hold(max(0.0, deadline - cell.time))
            return Settling(False, cell.time - start, taken, change)
        motion.hold(max(0.0, min(exposure + period, deadline) - cell.time))  # the next trigger
        if cell.time <= exposure + 1e-9:
            motion.hold(cell.dt)  # a later frame, never the same one twice


__all__ = ["SHRINK", "Holder", "Settling", "image_change", "wait_until_settled"]
