"""Local refinement of a recognised pose: a compass search or a CMA-ES on the continuous pose.

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

The compass search stops on ridges where depth, tilt and position must change together
(a tilted cloth seen a little farther and shifted sideways fills nearly the same pixels).
`cma_search`, a small (mu/mu_w, lambda) CMA-ES (Hansen, "The CMA Evolution Strategy: A
Tutorial", 2016, with its default constants), learns that coupling as the covariance of
its search distribution and follows the ridge: on the synthetic bench it takes results of
fitness 0.97-0.98 with 4-15 mm depth errors onto the true peak (0.995-0.999).

`compass_search` and `cma_search` take any score and allowed set (Python callables). For
the recognizer's fitness (a `KernelFitness`) within box limits, `compass_search_compiled`
and `cma_search_compiled` run the same searches in one compiled loop each (tested equal,
bit for bit): an iteration's Python overhead was about the cost of its 12-15 poses.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision._kernels import cma_run, cma_sample, cma_update, compass_run, moved_poses, poses_allowed
from robot_app.vision.fitness import AvoidedPoses, KernelFitness

PoseScore = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) fitness
PosePredicate = Callable[[FloatArray], np.ndarray]  # (P, 4, 4) poses -> (P,) bool allowed


class RefinementSettings(StrictModel):
    """Compass search after the GA (set `enabled: false` for the paper's GA alone).

    Attributes:
        enabled: refine one-shot results.
        method: the final polish of a one-shot result: "cma" (`cma_search`) or
            "compass" (`compass_search`); the candidates and tracking always use the
            compass search.
        in_tracking: refine tracking results too.
        subpixel: search on the bilinear-score fitness (else the nearest-pixel one).
        candidate_subpixel: the same for the short compass searches of the recognizer's
            best candidates, which only have to tell the right peak from the others.
        step_position: first step along camera x and y [m].
        step_depth: first step along the camera axis [m].
        step_angle_deg: first rotation step about each camera axis [deg].
        min_step_position: stop when the x-y step falls below this [m].
        max_iterations: cap on search iterations (15 poses each), candidates' included.
        candidate_iterations: iterations for each of the recognizer's best candidates
            before the best of them goes on.
        tracking_iterations: cap when tracking.
        cma_population: poses per CMA-ES iteration (lambda).
        cma_iterations: cap on CMA-ES iterations of the final polish. 80 (with 30 fine):
            on 100 synthetic scenes the 40 (12 fine) of before stopped short on the flat
            depth and tilt directions: mean±3σ z -4.3..+2.7 mm, now -1.7..+0.3 mm (x, y
            and yaw halved too; 45 % covered: 2 of 100 gross failures, now none); it
            costs about 8 ms per recognition.
        cma_sigma: initial CMA-ES step, in units of the compass steps (`step_position`,
            `step_depth`, `step_angle_deg`).
        cma_tolerance: stop when the CMA-ES step falls below this (same units).
        cma_fine_iterations: the last CMA-ES iterations, which rank by the sub-pixel
            fitness (with `subpixel`; the others by the nearest-pixel one, 2-3x cheaper).
        cma_fine_below: the sub-pixel ranking also starts when the step falls below this.
    """

    enabled: bool = True
    in_tracking: bool = True
    subpixel: bool = True
    candidate_subpixel: bool = False
    step_position: float = Field(default=0.002, gt=0.0)
    step_depth: float = Field(default=0.006, gt=0.0)
    step_angle_deg: float = Field(default=1.0, gt=0.0)
    min_step_position: float = Field(default=0.0001, gt=0.0)
    max_iterations: int = Field(default=30, ge=1)
    candidate_iterations: int = Field(default=6, ge=1)
    tracking_iterations: int = Field(default=4, ge=1)
    method: Literal["cma", "compass"] = "cma"
    cma_population: int = Field(default=12, ge=4)
    cma_iterations: int = Field(default=80, ge=1)
    cma_sigma: float = Field(default=2.0, gt=0.0)
    cma_tolerance: float = Field(default=0.03, gt=0.0)
    cma_fine_iterations: int = Field(default=30, ge=0)
    cma_fine_below: float = Field(default=0.1, ge=0.0)

    def steps(self) -> FloatArray:
        """(6,) first steps along (x, y, depth [m], rotation about camera x, y, z [rad])."""
        angle = np.deg2rad(self.step_angle_deg)
        return np.array([self.step_position, self.step_position, self.step_depth, angle, angle, angle])


def compass_search(
    pose: FloatArray,
    score: PoseScore,
    settings: RefinementSettings,
    iterations: int,
    allowed: PosePredicate | None = None,
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
    steps = settings.steps()
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


def cma_search(
    pose: FloatArray,
    score: PoseScore,
    settings: RefinementSettings,
    rng: np.random.Generator,
    allowed: PosePredicate | None = None,
    fine_score: PoseScore | None = None,
) -> tuple[FloatArray, float]:
    """CMA-ES over the pose moves of `moved` (x, y, depth along the ray, rotation vector).

    The search distribution starts at `pose` with a step of `cma_sigma` compass steps in
    each coordinate; each iteration scores `cma_population` samples, moves the mean to
    the weighted best half and adapts step and covariance (rank-one and rank-mu updates,
    cumulative step-size adaptation). Samples that `allowed` rejects score -inf. It
    stops after `cma_iterations` or when the step falls below `cma_tolerance`. With
    `fine_score` (e.g. the sub-pixel fitness, dearer than `score`), the last
    `cma_fine_iterations` iterations (and those after the step first falls below
    `cma_fine_below`) rank the samples by it; the ranking is all a CMA-ES uses, so its
    state carries over.

    Args:
        pose: (4, 4) start ^CR T_M.
        score: fitness of (P, 4, 4) poses (higher is better).
        settings: population, iterations, initial step and tolerance.
        rng: the random generator (seeded by the caller: same seed, same result).
        allowed: which poses may be scored; None: all.
        fine_score: the score of the last iterations; None: `score` throughout.

    Returns:
        (best pose seen, its score by the score of the last iteration); `pose` itself if
        nothing better was seen.
    """
    n, lam = _CMA_DIMENSIONS, settings.cma_population
    weights, constants = _cma_constants(lam)
    draws = rng.standard_normal((settings.cma_iterations, lam, n))  # all at once, as `cma_run`
    scale = settings.steps()
    start = np.ascontiguousarray(pose, dtype=float)
    best_pose, best = start, float(score(start[None])[0])
    mean, sigma = np.zeros(n), settings.cma_sigma
    C, B, D = np.eye(n), np.eye(n), np.ones(n)
    p_c, p_s = np.zeros(n), np.zeros(n)
    fine_from = settings.cma_iterations - settings.cma_fine_iterations + 1
    for generation in range(1, settings.cma_iterations + 1):
        if fine_score is not None and (generation >= fine_from or sigma * D.max() < settings.cma_fine_below):
            score, fine_score = fine_score, None
            best = float(score(best_pose[None])[0])
        y, poses = cma_sample(draws[generation - 1], B, D, mean, sigma, scale, start)
        scores = np.full(lam, -np.inf)
        inside = np.ones(lam, bool) if allowed is None else np.asarray(allowed(poses))
        if inside.any():
            scores[inside] = score(poses[inside])
        order = np.argsort(-scores, kind="stable")
        if scores[order[0]] > best:
            best, best_pose = float(scores[order[0]]), poses[order[0]]
        sigma = cma_update(mean, sigma, C, p_c, p_s, B, D, y, order, weights, constants, generation)
        if sigma * D.max() < settings.cma_tolerance:
            break
    return best_pose, best


def cma_search_compiled(
    pose: FloatArray,
    objective: KernelFitness,
    settings: RefinementSettings,
    rng: np.random.Generator,
    limits: PoseLimits,
    fine: KernelFitness | None = None,
) -> tuple[FloatArray, float]:
    """`cma_search` in one compiled loop (`_kernels.cma_run`): the same result, bit for bit,
    for `score` = `objective` (nearest pixel), `fine_score` = the sub-pixel fitness of
    `fine`'s points and parameters (None: no fine ranking) and `allowed` = `limits.allows`
    with `objective.avoid`. Saves the Python overhead of each iteration (about 0.1 ms of the
    0.2 ms an iteration of 12 poses cost).

    Returns:
        (best pose seen, its score by the objective of the last iteration).
    """
    weights, constants = _cma_constants(settings.cma_population)
    draws = rng.standard_normal((settings.cma_iterations, settings.cma_population, _CMA_DIMENSIONS))
    arguments, normalisation = objective.kernel_arguments()
    fine_arguments, fine_normalisation = (objective if fine is None else fine).kernel_arguments()
    best_pose, best, evaluated = cma_run(
        np.ascontiguousarray(pose, dtype=float), draws, settings.steps(), settings.cma_sigma,
        settings.cma_tolerance, settings.cma_iterations - settings.cma_fine_iterations + 1,
        settings.cma_fine_below, weights, constants, arguments, normalisation, fine is not None,
        fine_arguments, fine_normalisation, tuple(limits), objective.avoid.kernel_arguments(),
    )  # fmt: skip
    objective.count(evaluated)
    return np.asarray(best_pose), float(best)


def compass_search_compiled(
    pose: FloatArray,
    objective: KernelFitness,
    settings: RefinementSettings,
    iterations: int,
    limits: PoseLimits,
) -> tuple[FloatArray, float]:
    """`compass_search` in one compiled loop (`_kernels.compass_run`): the same result for
    `score` = `objective` (its `subpixel` or not) and `allowed` = `limits.allows` with
    `fitness.avoid`, without the Python overhead of each iteration (~0.2 ms of 15 poses).

    Returns:
        (best pose, its score).
    """
    arguments, normalisation = objective.kernel_arguments()
    best_pose, best, evaluated = compass_run(
        np.ascontiguousarray(pose, dtype=float), settings.steps(), iterations, settings.min_step_position,
        arguments, normalisation, objective.subpixel, tuple(limits), objective.avoid.kernel_arguments(),
    )  # fmt: skip
    objective.count(evaluated)
    return np.asarray(best_pose), float(best)


class PoseLimits(NamedTuple):
    """The allowed set of `_kernels.poses_inside`: position within [low, high] (x, y, z [m]),
    cosine of the tilt at least `min_cos_tilt`, |yaw| at most `max_yaw` [rad] (inf: any)."""

    low: FloatArray
    high: FloatArray
    min_cos_tilt: float
    max_yaw: float

    def allows(self, transforms: FloatArray, avoid: AvoidedPoses | None = None) -> npt.NDArray[np.bool_]:
        """(P,) True where a pose of (P, 4, 4) `transforms` is within the limits and not avoided."""
        avoided = avoid if avoid is not None else AvoidedPoses.none()
        T = np.ascontiguousarray(transforms, dtype=float).reshape(-1, 4, 4)
        return np.asarray(poses_allowed(T, tuple(self), avoided.kernel_arguments()))


_CMA_DIMENSIONS = 6  # x, y, depth, rotation vector


def _cma_constants(lam: int) -> tuple[FloatArray, tuple[float, ...]]:
    """Recombination weights and (c_c, c_s, c_1, c_mu, damping, E|N(0, I)|, mu_eff) of Hansen's
    defaults for population `lam` in 6 dimensions."""
    n, mu = _CMA_DIMENSIONS, lam // 2
    weights = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
    weights /= weights.sum()
    mu_eff = 1.0 / float(np.sum(weights**2))
    c_s, c_1 = (mu_eff + 2) / (n + mu_eff + 5), 2 / ((n + 1.3) ** 2 + mu_eff)
    constants = (
        (4 + mu_eff / n) / (n + 4 + 2 * mu_eff / n),  # c_c
        c_s,
        c_1,
        min(1 - c_1, 2 * (mu_eff - 2 + 1 / mu_eff) / ((n + 2) ** 2 + mu_eff)),  # c_mu
        1 + 2 * max(0.0, np.sqrt((mu_eff - 1) / (n + 1)) - 1) + c_s,  # damping
        float(np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))),  # E|N(0, I)|
        mu_eff,
    )
    return weights, constants


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


__all__ = [
    "PoseLimits",
    "RefinementSettings",
    "cma_search",
    "cma_search_compiled",
    "compass_search",
    "compass_search_compiled",
    "moved",
    "neighbours",
]
