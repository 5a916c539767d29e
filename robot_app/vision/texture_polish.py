"""Refine stage, on the texture: the yaw of a print whose outline barely holds it.

The hue fitness pins a pose by where the model's hue bands and outline fall. On a print of
nearly one hue on a round outline (a brown photograph on an ellipse) the outline is all it
has, and an ellipse turned by a degree about its centre covers nearly the same pixels: on
the recognition bench's calibration scenes the hue fitness fell 0.0005-0.002 for a turn of
1° there (0.004-0.03 on every other cloth), less than a third of its fall for a shift of
1 mm (more than that on every other cloth), and the polish ended up to 4.5° and 5 mm off
with the truth scoring no better, or only by a few thousandths. The model photo's texture
does hold the yaw: its agreement (`Verification.appearance`) falls by 0.05-0.07 at 1°.

So where the hue fitness's fall for a turn of `texture_probe_deg` is below
`texture_yaw_flat_below` times its fall for a shift of `texture_probe_shift` (mean over both
directions and, for the shift, over x and y: `yaw_weakly_held`), and the texture is
compared mostly by correlation (a plain cloth's flat cells say nothing about yaw), the pose
is moved in the cloth plane (x, y and the turn about its normal, through its origin) by a
pattern search on the texture's agreement (`texture_polish`): the six neighbours one step
away are verified, the best taken if it agrees better, the steps halved otherwise, down to
`texture_min_step_position`; then the vertex of each coordinate's parabola through the last
round's neighbours is tried (one pose more: a 0.25 mm end step took 6-18 poses more for the
same errors on the calibration scenes). The recogniser keeps the end only if its hue fitness
stays within `texture_fitness_margin` of the pose's (the texture moved the pose along the
hue's flat ridge, not off the cloth). It verifies 14-90 poses without the outline (about
0.3 ms each on one core of a loaded machine), paid only where the test above calls the yaw
weakly held (the test itself: seven sub-pixel fitness evaluations on a print).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.vision.poses import as_poses

AppearanceOf = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) agreement
FitnessOf = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) hue fitness


class TexturePolish(NamedTuple):
    """The end of `texture_polish`.

    Attributes:
        transform_model_to_camera: (4, 4) ^CR T_M.
        appearance: the texture's agreement there.
        evaluations: poses verified.
    """

    transform_model_to_camera: FloatArray
    appearance: float
    evaluations: int


def in_plane(x: float, y: float, angle: float) -> FloatArray:
    """(4, 4) a move in the cloth plane (Σ_M): by (x, y) [m] and turned by `angle` [rad]
    about its normal, through its origin."""
    c, s = np.cos(angle), np.sin(angle)
    move = np.eye(4)
    move[:2, :2] = [[c, -s], [s, c]]
    move[:2, 3] = x, y
    return move


def yaw_weakly_held(pose: FloatArray, fitness: FitnessOf, turn: float, shift: float, below: float) -> bool:
    """Whether the hue fitness falls less for a turn of `turn` [rad] about the cloth normal
    than `below` times its fall for a shift of `shift` [m] in the cloth plane (each the mean
    of both directions; the shift's over x and y too). A pose at no peak of the shift
    (no fall) is not judged: False."""
    T = as_poses(pose)[0]
    moves = [(0.0, 0.0, -turn), (0.0, 0.0, turn), (-shift, 0.0, 0.0), (shift, 0.0, 0.0),
             (0.0, -shift, 0.0), (0.0, shift, 0.0)]  # fmt: skip
    scores = np.asarray(fitness(np.array([T, *(T @ in_plane(*m) for m in moves)])), dtype=float)
    turn_fall = scores[0] - float(np.mean(scores[1:3]))
    shift_fall = scores[0] - float(np.mean(scores[3:]))
    return bool(shift_fall > 0.0 and turn_fall < below * shift_fall)


def texture_polish(
    pose: FloatArray,
    appearance: AppearanceOf,
    step_position: float,
    step_angle: float,
    min_step_position: float,
    iterations: int,
) -> TexturePolish:
    """Pattern search of the texture's agreement over in-plane moves of `pose` (module docstring).

    Args:
        pose: (4, 4) the start ^CR T_M.
        appearance: the agreement of each of (P, 4, 4) poses (higher is better; NaN never wins).
        step_position: first step along the cloth's x and y [m].
        step_angle: first turn step about its normal [rad].
        min_step_position: stop when the x-y step falls below this [m].
        iterations: cap on the rounds of six neighbours.

    Returns:
        the best pose seen (`pose` itself if no neighbour agreed better), its agreement and
        the poses verified.
    """
    T = as_poses(pose)[0]
    steps = np.array([step_position, step_position, step_angle], dtype=float)
    at = np.zeros(3)
    best = float(np.asarray(appearance(T[None]))[0])
    evaluations = 1
    directions = np.vstack([np.eye(3), -np.eye(3)])
    last: FloatArray | None = None  # the scores of the last round that found nothing better
    for _ in range(iterations):
        if steps[0] < min_step_position:
            break
        moves = at + directions * steps
        scores = np.asarray(appearance(np.array([T @ in_plane(*m) for m in moves])), dtype=float)
        evaluations += len(moves)
        k = int(np.argmax(np.nan_to_num(scores, nan=-np.inf)))
        if scores[k] > best or (np.isnan(best) and not np.isnan(scores[k])):
            at, best, last = moves[k], float(scores[k]), None
        else:
            last, steps = scores, steps / 2.0
    if last is not None and np.all(np.isfinite(last)) and np.isfinite(best):
        # the parabola through each coordinate's two neighbours and the best: its vertex
        plus, minus, step = last[:3], last[3:], 2.0 * steps
        curvature = plus + minus - 2.0 * best
        with np.errstate(divide="ignore", invalid="ignore"):
            offset = np.where(curvature < 0.0, 0.5 * step * (minus - plus) / curvature, 0.0)
        vertex = at + np.clip(offset, -step, step)
        score = float(np.asarray(appearance((T @ in_plane(*vertex))[None]))[0])
        evaluations += 1
        if score > best:
            at, best = vertex, score
    return TexturePolish(T @ in_plane(*at), best, evaluations)


__all__ = ["TexturePolish", "in_plane", "texture_polish", "yaw_weakly_held"]
