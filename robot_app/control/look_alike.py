"""Tracking's look-alike rule: a result away from the prediction whose frame the prediction fits as well.

Close to a blue cloth under the blue paper (the paper within the cloth's hue band), the
multi-step tracking GA slid onto the paper by 19 mm a frame with a rising fitness
(0.92 -> 0.96 against 0.91 at the truth; bench_pick_place episode 76), or crept by 5-7 mm
a frame at a fitness gap of 0.002-0.007 (episode 28, grasped 21 mm off). Such a result
does not say the cloth moved, only that the tracker found a look-alike: it is not fused
(`look_alike` returns a LOOK_ALIKE verdict) and `ClothTracker` starts the tracker again
from the prediction. A cloth pushed away leaves the prediction on the table, which scores
far lower, so its result is fused.
"""

from __future__ import annotations

import math

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.pose_filter import FilterUpdate, PoseFilter, UpdateReason
from robot_app.control.vision_pipeline import VisionResult

LOOK_ALIKE_DISTANCE = 0.005  # [m] a tracking result this far from the prediction (1.4 sigma of a view) ...
LOOK_ALIKE_MARGIN = 0.08  # ... whose frame scores within this of it at the prediction: a look-alike


def look_alike(pose_filter: PoseFilter, result: VisionResult, pose: FloatArray) -> FilterUpdate | None:
    """The look-alike verdict on one tracking result.

    Args:
        pose_filter: the tracker's filter (its prediction at the result's exposure).
        result: the tracking result (`predicted_fitness` is its frame's search fitness at
            the prediction, over the points in view as its `search_fitness`).
        pose: the result's 4x4 pose in Σ_W on the prediction's branch [m].

    Returns:
        A LOOK_ALIKE verdict (not fused) if the result is LOOK_ALIKE_DISTANCE or farther
        from the filter's prediction and the prediction explains the same frame nearly as
        well (search fitness within LOOK_ALIKE_MARGIN); None otherwise (the filter decides).
    """
    estimate = pose_filter.estimate
    t = result.capture.time
    if (
        result.mode != "track"
        or estimate is None
        or pose_filter.lost
        or not math.isfinite(result.predicted_fitness)
    ):
        return None
    predicted = pose_filter.estimate_at(max(t, estimate.time))
    distance = float(np.hypot(pose[0, 3] - predicted.x, pose[1, 3] - predicted.y))
    near_as_good = result.predicted_fitness >= result.search_fitness - LOOK_ALIKE_MARGIN
    if distance < LOOK_ALIKE_DISTANCE or not near_as_good:
        return None
    return FilterUpdate(False, UpdateReason.LOOK_ALIKE, math.nan, estimate, distance)


__all__ = ["LOOK_ALIKE_DISTANCE", "LOOK_ALIKE_MARGIN", "look_alike"]
