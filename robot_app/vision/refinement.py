"""Local refinement of a recognised pose: a compass search on the continuous pose.

The GA's best individual sits on the right peak but only as precisely as its last
generations happened to land. The compass search steps the pose along the camera x and
y axes, in depth along the ray through the model origin (which keeps the cloth's centre
on its pixel in the right image) and about the camera axes (rotation through the model
origin), tries three steps along the gradient those neighbours give, keeps any better
pose and halves its steps when none is better. It scores on the sub-pixel
fitness (each point's score interpolated bilinearly between its four neighbouring
pixels), which is smooth in the pose where the paper's nearest-pixel fitness is a
staircase, so the search can settle between pixels: that is what pins depth (a 1 mm
depth change moves the disparity by about 0.2 px at 580 mm).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydantic import Field

from robot_app.config import StrictModel
from robot_app.geometry import FloatArray
from robot_app.vision._kernels import moved_poses

PoseScore = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) fitness
PoseFilter = Callable[[FloatArray], "np.ndarray"]  # (P, 4, 4) poses -> (P,) bool allowed


class RefinementSettings(StrictModel):
    """Compass search after the GA (set `enabled: false` for the paper's GA alone).

    Attributes:
        enabled: refine one-shot results.
        in_tracking: refine tracking results too.
        subpixel: search on the bilinear-score fitness (else the nearest-pixel one).
        step_position: first step along camera x and y [m].
        step_depth: first step along the camera axis [m].
        step_angle_deg: first rotation step about each camera axis [deg].
        min_step_position: stop when the x-y step falls below this [m].
        max_iterations: cap on search iterations (15 poses each), candidates' included.
        candidate_iterations: iterations for each of the recognizer's best candidates
            before the best of them goes on.
        tracking_iterations: cap when tracking.
    """

    enabled: bool = True
    in_tracking: bool = True
    subpixel: bool = True
    step_position: float = Field(default=0.002, gt=0.0)
    step_depth: float = Field(default=0.006, gt=0.0)
    step_angle_deg: float = Field(default=1.0, gt=0.0)
    min_step_position: float = Field(default=0.0001, gt=0.0)
    max_iterations: int = Field(default=30, ge=1)
    candidate_iterations: int = Field(default=6, ge=1)
    tracking_iterations: int = Field(default=4, ge=1)


def compass_search(
    pose: FloatArray,
    score: PoseScore,
    settings: RefinementSettings,
    iterations: int,
    allowed: PoseFilter | None = None,
) -> tuple[FloatArray, float]:
    """Compass search with gradient moves on (x, y, depth along the ray, rotation about camera x, y, z).

    Each iteration scores the 12 neighbours one step away along each coordinate, and
    three poses along the central-difference gradient that those 12 give (1, 2 and 4
    steps), so that it climbs ridges where depth and tilt must change together; it
    moves to the best if that is better and halves the steps otherwise.

    Args:
        pose: (4, 4) start ^CR T_M.
        score: fitness of (P, 4, 4) poses (higher is better).
        settings: steps and stop rule.
        iterations: cap on iterations (15 poses each).
        allowed: which neighbours may be scored (e.g. inside the search bounds); None: all.

    Returns:
        (best pose, its score).
    """
    steps = np.array(
        [
            settings.step_position,
            settings.step_position,
            settings.step_depth,
            *[np.deg2rad(settings.step_angle_deg)] * 3,
        ]
    )
    current = float(score(pose[None])[0])
    for _ in range(iterations):
        candidates = neighbours(pose, steps)
        inside = np.ones(len(candidates), bool) if allowed is None else np.asarray(allowed(candidates))
        if not inside.any():
            break
        scores = np.full(len(candidates), -np.inf)
        scores[inside] = score(candidates[inside])
        if inside.all():
            gradient = (scores[0::2] - scores[1::2]) / 2.0  # per step, along each coordinate
            size = float(np.max(np.abs(gradient)))
            if size > 0:
                direction = gradient / size * steps
                along = moved_poses(pose, np.outer([1.0, 2.0, 4.0], direction))
                ok = np.ones(3, bool) if allowed is None else np.asarray(allowed(along))
                if ok.any():
                    candidates = np.concatenate([candidates, along[ok]])
                    scores = np.concatenate([scores, score(along[ok])])
        best = int(np.argmax(scores))
        if scores[best] > current:
            pose, current = candidates[best], float(scores[best])
            continue
        steps /= 2.0
        if steps[0] < settings.min_step_position:
            break
    return pose, current


def neighbours(pose: FloatArray, steps: FloatArray) -> FloatArray:
    """The 12 poses one step away along each of the six coordinates, both ways (+, - pairs).

    Args:
        pose: (4, 4) ^CR T_M.
        steps: (6,) steps along camera x, y, along the ray through the model origin
            (in depth) [m] and about the camera axes through the model origin [rad].
    """
    deltas = np.zeros((12, 6))
    deltas[0::2][np.arange(6), np.arange(6)] = steps
    deltas[1::2][np.arange(6), np.arange(6)] = -steps
    return np.asarray(moved_poses(np.ascontiguousarray(pose, dtype=float), deltas))


def moved(pose: FloatArray, delta: FloatArray) -> FloatArray:
    """`pose` moved by (dx, dy [m], d_depth [m] along the ray through the model origin,
    rotation vector [rad] about the camera axes through the model origin)."""
    deltas = np.asarray(delta, dtype=float).reshape(1, 6)
    return np.asarray(moved_poses(np.ascontiguousarray(pose, dtype=float), deltas))[0]


__all__ = ["RefinementSettings", "compass_search", "moved", "neighbours"]
