"""Compiled local searches of the refinement stage: CMA-ES sampling and update, the whole
CMA-ES run and the compass search, scored by the hue fitness inside the loop."""

from __future__ import annotations

import numpy as np
from numba import njit

from robot_app.vision.fitness_kernels import fitness_of
from robot_app.vision.pose_kernels import moved_poses, poses_allowed

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def cma_sample(z, B, D, mean, sigma, scale, start):
    """CMA-ES samples y = B diag(D) z (rows of `z` ~ N(0, I), so y ~ N(0, C)) and the poses
    `moved_poses(start, (mean + sigma y) scale)`."""
    lam, n = z.shape
    y = np.zeros((lam, n))
    deltas = np.empty((lam, n))
    for k in range(lam):
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += B[i, j] * D[j] * z[k, j]
            y[k, i] = acc
            deltas[k, i] = (mean[i] + sigma * acc) * scale[i]
    return y, moved_poses(start, deltas)


@_jit
def cma_update(mean, sigma, C, p_c, p_s, B, D, y, order, weights, constants, generation):
    """One CMA-ES update (Hansen's tutorial, 2016) of mean, C, p_c, p_s, B and D in place,
    from samples `y` ranked best first by `order`; returns the new step size.

    `constants` are (c_c, c_s, c_1, c_mu, damping, chi_n, mu_eff); `generation` counts from 1.
    """
    c_c, c_s, c_1, c_mu, damping, chi_n, mu_eff = constants
    n, mu = mean.shape[0], weights.shape[0]
    y_mean = np.zeros(n)
    for r in range(mu):
        for i in range(n):
            y_mean[i] += weights[r] * y[order[r], i]
    rotated = np.zeros(n)  # diag(1/D) B^T y_mean
    for j in range(n):
        for i in range(n):
            rotated[j] += B[i, j] * y_mean[i]
        rotated[j] /= D[j]
    norm_s = 0.0
    for i in range(n):
        mean[i] += sigma * y_mean[i]
        whitened = 0.0  # C^(-1/2) y_mean
        for j in range(n):
            whitened += B[i, j] * rotated[j]
        p_s[i] = (1 - c_s) * p_s[i] + np.sqrt(c_s * (2 - c_s) * mu_eff) * whitened
        norm_s += p_s[i] * p_s[i]
    norm_s = np.sqrt(norm_s)
    h_s = 1.0 if norm_s / np.sqrt(1 - (1 - c_s) ** (2 * generation)) / chi_n < 1.4 + 2 / (n + 1) else 0.0
    for i in range(n):
        p_c[i] = (1 - c_c) * p_c[i] + h_s * np.sqrt(c_c * (2 - c_c) * mu_eff) * y_mean[i]
    keep = 1 - c_1 - c_mu + c_1 * (1 - h_s) * c_c * (2 - c_c)
    for i in range(n):
        for j in range(n):
            rank_mu = 0.0
            for r in range(mu):
                rank_mu += weights[r] * y[order[r], i] * y[order[r], j]
            C[i, j] = keep * C[i, j] + c_1 * p_c[i] * p_c[j] + c_mu * rank_mu
    values, vectors = np.linalg.eigh(0.5 * (C + C.T))
    for i in range(n):
        D[i] = np.sqrt(max(values[i], 1e-20))
        for j in range(n):
            B[i, j] = vectors[i, j]
    return sigma * np.exp(c_s / damping * (norm_s / chi_n - 1))


@_jit
def cma_run(start, draws, scale, sigma, tolerance, fine_from, fine_below, weights, constants,
            fitness_arguments, normalisation, fine, fine_arguments, fine_normalisation, limits,
            avoided):  # fmt: skip
    """`refinement.cma_search` in one compiled loop, for a fitness that is `score_poses` +
    `normalised` at the nearest pixel (`fitness_arguments`, `normalisation`), then with
    `fine` bilinear (`fine_arguments`, `fine_normalisation`: e.g. more points) from
    iteration `fine_from` or once the step is below `fine_below`, and an allowed set that
    is `poses_allowed` (`limits` = (low, high, min_cos_tilt, max_yaw), `avoided` =
    (centres, windows, separation)).

    `draws` are the (iterations, lambda, 6) standard normal draws; the rest as in
    `cma_search`. Returns (best pose, its score by the last iteration's fitness, poses
    scored): the same, bit for bit, as `cma_search` with the same draws.
    """
    n, lam = draws.shape[2], draws.shape[1]
    best = fitness_of(start.reshape(1, 4, 4), fitness_arguments, normalisation, False)[0]
    best_pose = start.copy()
    evaluated = 1
    mean = np.zeros(n)
    C, B, D = np.eye(n), np.eye(n), np.ones(n)
    p_c, p_s = np.zeros(n), np.zeros(n)
    bilinear = False
    for generation in range(1, draws.shape[0] + 1):
        if fine and not bilinear and (generation >= fine_from or sigma * D.max() < fine_below):
            bilinear = True
            fitness_arguments, normalisation = fine_arguments, fine_normalisation
            best = fitness_of(best_pose.reshape(1, 4, 4), fitness_arguments, normalisation, True)[0]
            evaluated += 1
        y, poses = cma_sample(draws[generation - 1], B, D, mean, sigma, scale, start)
        scores = np.full(lam, -np.inf)
        inside = np.flatnonzero(poses_allowed(poses, limits, avoided))
        if inside.shape[0] > 0:
            fitness = fitness_of(poses[inside], fitness_arguments, normalisation, bilinear)
            for k in range(inside.shape[0]):
                scores[inside[k]] = fitness[k]
            evaluated += inside.shape[0]
        order = np.argsort(-scores, kind="mergesort")
        if scores[order[0]] > best:
            best = scores[order[0]]
            best_pose = poses[order[0]].copy()
        sigma = cma_update(mean, sigma, C, p_c, p_s, B, D, y, order, weights, constants, generation)
        if sigma * D.max() < tolerance:
            break
    return best_pose, best, evaluated


@_jit
def compass_run(start, steps, iterations, min_step, fitness_arguments, normalisation, bilinear, limits,
                avoided):  # fmt: skip
    """`refinement.compass_search` in one compiled loop, for a fitness that is `score_poses`
    + `normalised` (`bilinear` or not) and an allowed set that is `poses_allowed(limits,
    avoided)`. Returns (best pose, its score, poses scored)."""
    pose = start.copy()
    current = fitness_of(pose.reshape(1, 4, 4), fitness_arguments, normalisation, bilinear)[0]
    evaluated = 1
    steps = steps.copy()
    deltas = np.zeros((12, 6))
    factors = (1.0, 2.0, 4.0)
    along_deltas = np.empty((3, 6))
    for _ in range(iterations):
        for j in range(6):
            deltas[2 * j, j], deltas[2 * j + 1, j] = steps[j], -steps[j]
        candidates = moved_poses(pose, deltas)
        inside = np.flatnonzero(poses_allowed(candidates, limits, avoided))
        if inside.shape[0] == 0:
            break
        scores = np.full(12, -np.inf)
        fitness = fitness_of(candidates[inside], fitness_arguments, normalisation, bilinear)
        for k in range(inside.shape[0]):
            scores[inside[k]] = fitness[k]
        evaluated += inside.shape[0]
        if inside.shape[0] == 12:
            size = 0.0
            for j in range(6):
                size = max(size, abs((scores[2 * j] - scores[2 * j + 1]) / 2.0))
            if size > 0:
                for k in range(3):
                    for j in range(6):
                        gradient = (scores[2 * j] - scores[2 * j + 1]) / 2.0
                        along_deltas[k, j] = factors[k] * (gradient / size * steps[j])
                along = moved_poses(pose, along_deltas)
                ok = np.flatnonzero(poses_allowed(along, limits, avoided))
                if ok.shape[0] > 0:
                    more = fitness_of(along[ok], fitness_arguments, normalisation, bilinear)
                    evaluated += ok.shape[0]
                    candidates = np.concatenate((candidates, along[ok]))
                    scores = np.concatenate((scores, more))
        best = np.argmax(scores)
        if scores[best] > current:
            pose, current = candidates[best].copy(), scores[best]
            continue
        steps /= 2.0
        if steps[0] < min_step:
            break
    return pose, current, evaluated


__all__ = ["cma_run", "cma_sample", "cma_update", "compass_run"]
