"""Local refinement of a recognised pose: a compass search on the continuous pose.

The GA's best individual sits on the right peak but only as precisely as its last
generations happened to land. The compass search steps the pose along the camera axes
(position) and about them (rotation through the model origin), keeps any better
neighbour and halves its steps when none is better. It scores on the sub-pixel
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
        max_iterations: cap on search iterations (12 poses each).
        tracking_iterations: cap when tracking.
    """

    enabled: bool = True
    in_tracking: bool = True
    subpixel: bool = True
    step_position: float = Field(default=0.002, gt=0.0)
    step_depth: float = Field(default=0.006, gt=0.0)
    step_angle_deg: float = Field(default=1.0, gt=0.0)
    min_step_position: float = Field(default=0.0001, gt=0.0)
    max_iterations: int = Field(default=40, ge=1)
    tracking_iterations: int = Field(default=6, ge=1)


def compass_search(
    pose: FloatArray,
    score: PoseScore,
    settings: RefinementSettings,
    iterations: int,
    allowed: PoseFilter | None = None,
) -> tuple[FloatArray, float]:
    """Compass search on (x, y, z, rotation about camera x, y, z), halving steps on failure.

    Args:
        pose: (4, 4) start ^CR T_M.
        score: fitness of (P, 4, 4) poses (higher is better).
        settings: steps and stop rule.
        iterations: cap on iterations (12 poses each).
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
        best = int(np.argmax(scores))
        if scores[best] > current:
            pose, current = candidates[best], float(scores[best])
            continue
        steps /= 2.0
        if steps[0] < settings.min_step_position:
            break
    return pose, current


def neighbours(pose: FloatArray, steps: FloatArray) -> FloatArray:
    """The 12 poses one step away along each of the six coordinates, both ways.

    Args:
        pose: (4, 4) ^CR T_M.
        steps: (6,) steps along camera x, y, z [m] and about them [rad].
    """
    out = np.repeat(pose[None], 12, axis=0)
    for k in range(3):
        out[2 * k, k, 3] += steps[k]
        out[2 * k + 1, k, 3] -= steps[k]
    for k in range(3):
        for sign, index in ((1.0, 6 + 2 * k), (-1.0, 7 + 2 * k)):
            axis = np.zeros(3)
            axis[k] = sign * steps[3 + k]
            out[index, :3, :3] = _rotation_vector(axis) @ pose[:3, :3]
    return out


def _rotation_vector(omega: FloatArray) -> FloatArray:
    """Rodrigues: rotation by |omega| [rad] about omega."""
    angle = float(np.linalg.norm(omega))
    k = omega / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


__all__ = ["RefinementSettings", "compass_search", "neighbours"]
