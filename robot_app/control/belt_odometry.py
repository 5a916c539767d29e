"""A conveyor's encoder in the cloth filter: its samples, fused in time order.

The hand cameras cannot follow the cloth closer than `loop.min_working_distance`, so a belt
that brakes after the last usable frame is not seen stopping; the encoder sees it.
`ClothTracker` holds one `BeltOdometry` when the cell has an encoder and `loop.belt_encoder`
is on.
"""

from __future__ import annotations

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.cell import BeltEncoder
from robot_app.control.pose_filter import PoseEstimate, PoseFilter


class BeltOdometry:
    """Encoder samples waiting for the filter, and the filter's predictions with them.

    A conveyor-tracking cell measures its belt with an encoder. The hand cameras cannot
    follow the cloth closer than `loop.min_working_distance`, so a belt that brakes after
    the last usable frame is not seen stopping; the encoder sees it. Samples are taken at
    `rate_hz` while the filter's cloth lies over the belt and fused into the filter's
    horizontal velocity in time order: those up to a recognition's exposure before that
    recognition (results arrive a latency late; the filter runs at exposure times), the
    rest only into predictions (`PoseFilter.estimate_with_velocities`). The position stays
    vision's: a cloth pushed across the belt is relocated by the recognitions.

    Args:
        encoder: the belt's encoder.
        rate_hz: samples per second [Hz].
    """

    def __init__(self, encoder: BeltEncoder, rate_hz: float) -> None:
        if not rate_hz > 0.0:
            raise ValueError(f"the encoder's rate must be > 0 [Hz], got {rate_hz}")
        self.encoder = encoder
        self.period = 1.0 / rate_hz
        self.samples: list[tuple[float, FloatArray]] = []
        self._next = -np.inf

    def reset(self) -> None:
        """Drops every sample (a new episode)."""
        self.samples.clear()
        self._next = -np.inf

    def sample(self, t: float, pose_filter: PoseFilter) -> None:
        """Reads the encoder at cell time `t` [s] if a period has passed and the filter's
        cloth lies over the belt; samples the filter has passed are dropped."""
        estimate = pose_filter.estimate
        if estimate is None:
            return
        self.samples = [s for s in self.samples if s[0] > estimate.time]
        if t < self._next:
            return
        self._next = t + self.period
        if self.encoder.carries(np.array([estimate.x, estimate.y])):
            velocity = np.asarray(self.encoder.velocity(), dtype=float).reshape(2).copy()
            velocity.setflags(write=False)
            self.samples.append((float(t), velocity))

    def fuse_until(self, pose_filter: PoseFilter, t: float) -> None:
        """Fuses the samples up to `t` [s] (a recognition's exposure) into the filter."""
        if pose_filter.estimate is None:
            return
        due = [s for s in self.samples if s[0] <= t]
        if due:
            pose_filter.fuse_velocities(due, self.encoder.std)
            self.samples = self.samples[len(due) :]

    def estimate_at(self, pose_filter: PoseFilter, t: float) -> PoseEstimate:
        """The filter's prediction for `t` [s] (not before its time) with the samples up to `t`."""
        estimate = pose_filter.estimate
        if estimate is None:
            raise RuntimeError("no estimate to predict: the filter is not initialised")
        return pose_filter.estimate_with_velocities(self.samples, self.encoder.std, max(t, estimate.time))


__all__ = ["BeltOdometry"]
