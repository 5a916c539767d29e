"""Compiled GA generations (paper Sec. II-E): ranking selection, two-point crossover,
mutation per island, and whole runs of generations scored by the hue fitness."""

from __future__ import annotations

import numpy as np
from numba import njit

from robot_app.vision.fitness_kernels import fitness_of
from robot_app.vision.pose_kernels import poses_avoided, transforms_from_genes

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def evolve(genes, scores, starts, elite, cdfs, uniforms, crossover_rate, mutation_rate,
           lows, spans, gray_code, fitness_arguments, normalisation, avoided):  # fmt: skip
    """`uniforms.shape[0]` GA generations (`next_generation`, then the offspring scored by
    `fitness_of` at the nearest pixel, -1 where `poses_avoided`) in one
    compiled loop.

    Args:
        genes, scores: the population and its fitness.
        starts, elite, cdfs, crossover_rate, mutation_rate: as `next_generation`.
        uniforms: (generations, pairs, 5 + m) the draws of each generation.
        lows, spans, gray_code: as `transforms_from_genes`.
        fitness_arguments, normalisation: as `fitness_of` takes them.
        avoided: `poses_avoided`'s (centres, windows, separation).

    Returns:
        the last population, its fitness, the offspring scored, and the best fitness after
        each generation.
    """
    history = np.empty(uniforms.shape[0])
    evaluated = 0
    for g in range(uniforms.shape[0]):
        new, source = next_generation(genes, scores, starts, elite, cdfs, uniforms[g],
                                      crossover_rate, mutation_rate)  # fmt: skip
        children = np.flatnonzero(source < 0)
        poses = transforms_from_genes(new[children], lows, spans, gray_code)
        fitness = fitness_of(poses, fitness_arguments, normalisation, False)
        if avoided[0].shape[0] > 0:
            fitness[poses_avoided(poses, *avoided)] = -1.0
        new_scores = np.empty(new.shape[0])
        for k in range(new.shape[0]):
            if source[k] >= 0:
                new_scores[k] = scores[source[k]]
        for j in range(children.shape[0]):
            new_scores[children[j]] = fitness[j]
        evaluated += children.shape[0]
        genes, scores = new, new_scores
        history[g] = scores.max()
    return genes, scores, evaluated, history


@_jit
def breed(ranked, cdf, uniforms, n_children, crossover_rate, mutation_rate):
    """Offspring of one GA generation: ranking selection, two-point crossover, mutation.

    Args:
        ranked: (n, 6) uint16 genes, best first.
        cdf: (n,) cumulative selection probability of each rank.
        uniforms: (pairs, 5 + m) uniform [0, 1) draws: 2 parents, crossover yes/no, 2 cut
            points, then the gaps between mutated bits over the pair's 144 bits (geometric
            with `mutation_rate`: the same law as one draw per bit, with ~144·rate draws
            instead of 144). A pair that would need more than m gaps keeps the first m
            mutations; `mutation_draws` picks m so that this practically never happens.
        n_children: offspring wanted (<= 2 * pairs).
        crossover_rate, mutation_rate: per pair, per bit probabilities.

    Returns:
        (n_children, 6) uint16 genes.
    """
    n_genes, n_bits = ranked.shape[1], 12
    total_bits = n_genes * n_bits
    full = (1 << n_bits) - 1
    log_keep = np.log1p(-mutation_rate) if mutation_rate < 1.0 else -np.inf
    children = np.empty((n_children, n_genes), np.uint16)
    for k in range(uniforms.shape[0]):
        a = min(np.searchsorted(cdf, uniforms[k, 0]), ranked.shape[0] - 1)
        b = min(np.searchsorted(cdf, uniforms[k, 1]), ranked.shape[0] - 1)
        cross = uniforms[k, 2] < crossover_rate
        c1 = int(uniforms[k, 3] * (total_bits + 1))
        c2 = int(uniforms[k, 4] * (total_bits + 1))
        if c1 > c2:
            c1, c2 = c2, c1
        first, second = 2 * k, 2 * k + 1
        for g in range(n_genes):
            # bits g*12 .. g*12+11, most significant first; those in [c1, c2) are swapped
            lo, hi = max(c1 - g * n_bits, 0), min(c2 - g * n_bits, n_bits)
            mask = 0
            if cross and lo < hi:
                mask = ((1 << (n_bits - lo)) - 1) ^ ((1 << (n_bits - hi)) - 1)
            ga, gb = np.int64(ranked[a, g]), np.int64(ranked[b, g])
            if first < n_children:
                children[first, g] = (ga & ~mask & full) | (gb & mask)
            if second < n_children:
                children[second, g] = (gb & ~mask & full) | (ga & mask)
        if mutation_rate <= 0.0:
            continue
        bit = -1
        for j in range(5, uniforms.shape[1]):
            if mutation_rate >= 1.0:
                bit += 1
            else:
                bit += 1 + int(np.log(1.0 - uniforms[k, j]) / log_keep)
            if bit >= 2 * total_bits:
                break
            child = first if bit < total_bits else second
            if child >= n_children:
                break
            position = bit % total_bits
            g, j_bit = position // n_bits, position % n_bits
            children[child, g] ^= np.uint16(1 << (n_bits - 1 - j_bit))
    return children


@_jit
def next_generation(genes, scores, starts, elite, cdfs, uniforms, crossover_rate, mutation_rate):
    """Elites and offspring of every island for one generation (the offspring unscored).

    Args:
        genes: (P, 6) uint16 population; island i holds rows starts[i]:starts[i + 1].
        scores: (P,) fitness of `genes`.
        starts: (islands + 1,) int64 first row of each island, then P.
        elite: best individuals each island copies unchanged.
        cdfs: (islands, max island size) cumulative ranking probabilities, best first.
        uniforms: (pairs in all islands, 5 + m) uniform draws (see `breed`), island by island.
        crossover_rate, mutation_rate: per pair, per bit probabilities.

    Returns:
        new genes (P, 6) island by island, elites first; (P,) the row of `genes` each
        elite came from, -1 for offspring.
    """
    new = np.empty_like(genes)
    source = np.full(genes.shape[0], -1, np.int64)
    pair = 0
    for i in range(starts.shape[0] - 1):
        a, b = starts[i], starts[i + 1]
        order = a + np.argsort(-scores[a:b], kind="mergesort")
        ranked = genes[order]
        n_children = (b - a) - elite
        pairs = (n_children + 1) // 2
        children = breed(ranked, cdfs[i, : b - a], uniforms[pair : pair + pairs], n_children,
                         crossover_rate, mutation_rate)  # fmt: skip
        pair += pairs
        for k in range(elite):
            new[a + k] = ranked[k]
            source[a + k] = order[k]
        new[a + elite : b] = children
    return new, source


__all__ = ["breed", "evolve", "next_generation"]
