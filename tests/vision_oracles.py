"""Pure-Python twins of the compiled search loops: test oracles, not implementations.

The GA's generations (`ga_kernels.evolve`), the compass search (`refine_kernels.compass_run`)
and the CMA-ES (`refine_kernels.cma_run`) run compiled in the package; these loops do the
same steps one call at a time with any Python score function, so the tests can check the
compiled loops against them bit for bit and test the algorithms on analytic functions.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.vision.ga import GAResult, GeneticAlgorithm
from robot_app.vision.ga_kernels import next_generation
from robot_app.vision.pose_kernels import moved_poses
from robot_app.vision.poses import neighbours
from robot_app.vision.refine_kernels import cma_sample, cma_update
from robot_app.vision.refinement import CMA_DIMENSIONS, RefinementSettings, cma_constants

PoseScore = Callable[[FloatArray], FloatArray]  # (P, 4, 4) poses -> (P,) fitness
PosePredicate = Callable[[FloatArray], np.ndarray]  # (P, 4, 4) poses -> (P,) bool allowed


def ga_run(ga: GeneticAlgorithm, score: PoseScore, generations: int) -> GAResult:
    """`GeneticAlgorithm.run` with a Python score: same draws, same population."""
    return ga_evolve(ga, score, ga.random_genes(), generations)


def ga_evolve(ga: GeneticAlgorithm, score: PoseScore, genes: np.ndarray, generations: int) -> GAResult:
    """`GeneticAlgorithm.evolve` from `genes` with a Python score, one generation at a time."""
    s = ga.settings
    starts, cdfs = ga.breeding_tables()
    scores = score(ga.transforms(genes))
    history = [float(scores.max())]
    evaluations = len(genes)
    uniforms = ga.rng.random((generations, *ga.draws_per_generation())) if generations else None
    for g in range(generations):
        assert uniforms is not None
        new, source = next_generation(
            genes, scores, starts, s.elite, cdfs, uniforms[g], s.crossover_rate, s.mutation_rate
        )
        offspring = source < 0
        new_scores = np.empty(len(new))
        new_scores[~offspring] = scores[source[~offspring]]
        new_scores[offspring] = score(ga.transforms(new[offspring]))
        evaluations += int(offspring.sum())
        genes, scores = new, new_scores
        history.append(float(scores.max()))
    ga.population, ga.scores = genes, scores
    best = int(np.argmax(scores))
    return GAResult(ga.transforms(genes[best : best + 1])[0], float(scores[best]), generations, evaluations,
                    np.array(history))  # fmt: skip


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
    n, lam = CMA_DIMENSIONS, settings.cma_population
    weights, constants = cma_constants(lam)
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


__all__ = ["cma_search", "compass_search", "ga_evolve", "ga_run"]
