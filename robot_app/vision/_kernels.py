"""Compiled inner loops of the fitness (eqs. 9-11): one gather and one table look-up per point.

The fitness of a pose is a sum over model points of a score that depends only on the row
of the point (its model colour, a hue or a tone, or "outside") and on the code of the
image pixel it lands on (its hue, its tone, or "off the image"). `fitness.py` builds that
score table once per model, beside each score a "seen" flag (does the point count towards
the divisor of the fitness); these kernels project the points with a 3x4 matrix per pose and camera and add
up the table entries. Each image is a flat code array framed by pixels whose code scores 0
in every row: points off the image or behind the camera are clamped onto the frame, so
the projection loop has no data-dependent branches. Numba's `error_model="numpy"`
matters: python's model checks every division for zero and stops vectorisation. So do
unsigned indices in the gathers: numba wraps a negative signed index around, a test and
an add per access that also spill registers (the nearest-pixel sum went from 2.5 to 1.7 ns
per point, the bilinear one from 7.3 to 4.5 ns, on one core of this machine).
Everything here is internal: callers go through `FitnessEvaluator`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")


@_jit
def hsv_codes(hsv, min_saturation, min_value, value_split, dark, light, fill):
    """(H, W, 3) HSV_FULL image -> flat pixel codes, framed by `fill` (one pixel left and
    top, two right and bottom; row stride width + 3), as the scoring kernels read them.
    A code is the hue, or where saturation < min_saturation or value < min_value the tone:
    `dark` for value < value_split, else `light` (`hue.colour_codes`, pixel by pixel)."""
    height, width = hsv.shape[0], hsv.shape[1]
    stride = width + 3
    out = np.full((height + 3) * stride, fill, dtype=np.uint16)
    for v in range(height):
        base = (v + 1) * stride + 1
        for u in range(width):
            value = hsv[v, u, 2]
            if hsv[v, u, 1] >= min_saturation and value >= min_value:
                out[base + u] = np.uint16(hsv[v, u, 0])
            else:
                out[base + u] = np.uint16(dark) if value < value_split else np.uint16(light)
    return out


@_jit
def every_colour():
    """(4096, 4096, 3) uint8 BGR image holding each of the 2^24 colours once, colour
    (b, g, r) at flat pixel index b << 16 | g << 8 | r."""
    out = np.empty((4096, 4096, 3), dtype=np.uint8)
    for i in range(1 << 24):
        y, x = i >> 12, i & 4095
        out[y, x, 0] = (i >> 16) & 255
        out[y, x, 1] = (i >> 8) & 255
        out[y, x, 2] = i & 255
    return out


@_jit
def bgr_codes(bgr, table, fill):
    """(H, W, 3) BGR image -> flat pixel codes framed like `hsv_codes`'s, each pixel looked
    up in `table` ((2^24,) code of every colour, index b << 16 | g << 8 | r): one gather per
    pixel instead of an HSV conversion and a pass over it (0.27 against 0.78 ms per
    640 x 480 image; an image's colours are few, so the table's lines stay in cache)."""
    height, width = bgr.shape[0], bgr.shape[1]
    stride = width + 3
    out = np.full((height + 3) * stride, fill, dtype=np.uint16)
    for v in range(height):
        base = (v + 1) * stride + 1
        for u in range(width):
            b, g, r = np.int64(bgr[v, u, 0]), np.int64(bgr[v, u, 1]), np.int64(bgr[v, u, 2])
            out[base + u] = table[(b << 16) | (g << 8) | r]
    return out


@_jit
def _nearest_sum(M, points, table, codes, width, height, pixel):
    """Sum of the scores of all points in one image at their nearest pixels, branch-free,
    and the sum of `best` over the points that count as seen (the most they could score).

    `table` holds (score, seen) pairs: entry 2 (row offset + code) is the score, the next
    one 1 if the point counts as seen on that pixel, else 0. Pixel j of a row is padded
    column j + 1. A point's coordinate is clamped into the padded frame, so every point
    off the image (or behind the camera) reads frame pixels, whose code scores 0 and is
    not seen, and the loop has no data-dependent branch.
    """
    px, py, pz, weights, best, row_offsets = points
    stride = width + 3
    zero, one, eps, shift = np.float32(0.0), np.float32(1.0), np.float32(1e-6), np.float32(1.5)
    umax, vmax = np.float32(width + 1), np.float32(height + 1)
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in range(px.shape[0]):  # projection first: this loop vectorises
        x, y, z = px[i], py[i], pz[i]
        w = m20 * x + m21 * y + m22 * z + m23
        front = w > eps
        inv = one / (w if front else one)
        u = (m00 * x + m01 * y + m02 * z + m03) * inv + shift
        v = (m10 * x + m11 * y + m12 * z + m13) * inv + shift
        u = min(max(u if front else zero, zero), umax)  # floor(u + 0.5) + 1 below
        v = min(max(v if front else zero, zero), vmax)
        pixel[i] = np.uint32(np.int32(v) * stride + np.int32(u))
    total = np.float32(0.0)
    view = np.float32(0.0)
    two = np.uint64(2)
    for i in range(px.shape[0]):  # then the gathers, by unsigned indices (see the module)
        k = np.uint64(row_offsets[i]) + two * np.uint64(codes[np.uint64(pixel[i])])
        total += weights[i] * table[k]
        view += best[i] * table[k + np.uint64(1)]
    return total, view


@_jit
def _bilinear_sum(M, points, table, codes, width, height, pixel, fraction):
    """Like `_nearest_sum`, with each score (and "seen") interpolated between the four
    neighbouring pixels (scores, not hues: hue has no linear interpolation on a circle).
    `fraction` is (2, N) float32 scratch for the sub-pixel offsets."""
    px, py, pz, weights, best, row_offsets = points
    stride = width + 3
    zero, one, eps = np.float32(0.0), np.float32(1.0), np.float32(1e-6)
    umax, vmax = np.float32(width + 1), np.float32(height + 1)
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in range(px.shape[0]):  # projection first: this loop vectorises
        x, y, z = px[i], py[i], pz[i]
        w = m20 * x + m21 * y + m22 * z + m23
        front = w > eps
        inv = one / (w if front else one)
        u = (m00 * x + m01 * y + m02 * z + m03) * inv + one
        v = (m10 * x + m11 * y + m12 * z + m13) * inv + one
        u = min(max(u if front else zero, zero), umax)
        v = min(max(v if front else zero, zero), vmax)
        iu, iv = np.int32(u), np.int32(v)
        fraction[0, i] = u - np.float32(iu)
        fraction[1, i] = v - np.float32(iv)
        pixel[i] = np.uint32(iv * stride + iu)
    total = np.float32(0.0)
    view = np.float32(0.0)
    one_, two, below = np.uint64(1), np.uint64(2), np.uint64(stride)
    for i in range(px.shape[0]):  # then the gathers, by unsigned indices (see the module)
        k, r = np.uint64(pixel[i]), np.uint64(row_offsets[i])
        fu, fv = fraction[0, i], fraction[1, i]
        ka, kb = r + two * np.uint64(codes[k]), r + two * np.uint64(codes[k + one_])
        kc, kd = r + two * np.uint64(codes[k + below]), r + two * np.uint64(codes[k + below + one_])
        a, b, c, d = table[ka], table[kb], table[kc], table[kd]
        top = a + fu * (b - a)
        total += weights[i] * (top + fv * (c + fu * (d - c) - top))
        a, b, c, d = table[ka + one_], table[kb + one_], table[kc + one_], table[kd + one_]
        top = a + fu * (b - a)
        view += best[i] * (top + fv * (c + fu * (d - c) - top))
    return total, view


@_jit
def _projection(P, pose, out):
    """out (3, 4) float32 = P @ pose, P a (3, 4) camera projection, pose a float64 (4, 4)
    rigid transform (its last row 0 0 0 1). Written out: `@` in a compiled loop is a BLAS
    call and an allocation per pose, about 0.3 µs, a third of a GA generation's cost on
    a one-point model."""
    for r in range(3):
        for c in range(3):
            out[r, c] = P[r, 0] * pose[0, c] + P[r, 1] * pose[1, c] + P[r, 2] * pose[2, c]
        out[r, 3] = P[r, 0] * pose[0, 3] + P[r, 1] * pose[1, 3] + P[r, 2] * pose[2, 3] + P[r, 3]


@_jit
def score_poses(
    transforms,
    K_left,
    K_right,
    left_from_right,
    px,
    py,
    pz,
    weights,
    best,
    row_offsets,
    table,
    codes_left,
    codes_right,
    width,
    height,
    bilinear,
):
    """Sum of the scores of all points in both images, for each pose, and the most the
    points in view could have scored.

    Args:
        transforms: (P, 4, 4) float64 poses ^CR T_M.
        K_left, K_right: (3, 3) camera matrices.
        left_from_right: (4, 4) transform Σ_CR -> Σ_CL.
        px, py, pz: (N,) float32 model point coordinates [m].
        weights: (N,) float32 weight of each point's score.
        best: (N,) float32 weight x the highest score of each point's row.
        row_offsets: (N,) uint32 start of each point's row in the flat table.
        table: flat float32 table of (score, seen) pairs, row by row (see `_nearest_sum`).
        codes_left, codes_right: pixel codes as made by `hsv_codes` (the frame's code
            scores 0 and is not seen in every row).
        width, height: image size [px].
        bilinear: interpolate the scores of the four neighbouring pixels instead of taking
            the nearest one.

    Returns:
        (P,) left sum + right sum, unnormalised; (P,) the sum of `best` over the points
        seen in each image, left + right.
    """
    n_poses = transforms.shape[0]
    out = np.empty(n_poses)
    view = np.empty(n_poses)
    M_left = np.empty((3, 4), np.float32)
    M_right = np.empty((3, 4), np.float32)
    pixel = np.empty(px.shape[0], np.uint32)  # scratch: each point's pixel index
    fraction = np.empty((2, px.shape[0]), np.float32)  # scratch: sub-pixel offsets
    points = (px, py, pz, weights, best, row_offsets)
    P_right = np.zeros((3, 4))
    P_right[:, :3] = K_right
    P_left = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    for p in range(n_poses):
        pose = transforms[p]
        _projection(P_right, pose, M_right)
        _projection(P_left, pose, M_left)
        if bilinear:
            sum_l, view_l = _bilinear_sum(M_left, points, table, codes_left, width, height, pixel, fraction)
            sum_r, view_r = _bilinear_sum(M_right, points, table, codes_right, width, height, pixel, fraction)
        else:
            sum_l, view_l = _nearest_sum(M_left, points, table, codes_left, width, height, pixel)
            sum_r, view_r = _nearest_sum(M_right, points, table, codes_right, width, height, pixel)
        out[p] = sum_l + sum_r
        view[p] = view_l + view_r
    return out, view


@_jit
def normalised(sums, seen, full, view, min_view_fraction, hidden_penalty):
    """Fitness from `score_poses`' sums: divided by `full` (the paper's "model" normalisation)
    or, with `view`, by what the points in view could score (at least `min_view_fraction`
    of `full`), minus `hidden_penalty` times the share of `full` not seen."""
    out = np.empty(sums.shape[0])
    floor = min_view_fraction * full
    for p in range(sums.shape[0]):
        if not view:
            out[p] = sums[p] / full
            continue
        out[p] = sums[p] / max(seen[p], floor)
        if hidden_penalty != 0.0:
            out[p] -= hidden_penalty * min(max(1.0 - seen[p] / full, 0.0), 1.0)
    return out


@_jit
def evolve(genes, scores, starts, elite, cdfs, uniforms, crossover_rate, mutation_rate,
           lows, spans, gray_code, fitness_arguments, normalisation, avoided):  # fmt: skip
    """`uniforms.shape[0]` GA generations (`next_generation`, then the offspring scored by
    `score_poses` at the nearest pixel and `normalised`, -1 where `poses_avoided`) in one
    compiled loop.

    Args:
        genes, scores: the population and its fitness.
        starts, elite, cdfs, crossover_rate, mutation_rate: as `next_generation`.
        uniforms: (generations, pairs, 5 + m) the draws of each generation.
        lows, spans, gray_code: as `transforms_from_genes`.
        fitness_arguments: `score_poses`' arguments from K_left to height.
        normalisation: (full, view, min_view_fraction, hidden_penalty) of `normalised`.
        avoided: `poses_avoided`'s (centres, windows, separation).

    Returns:
        the last population, its fitness, the offspring scored, and the best fitness after
        each generation.
    """
    K_left, K_right, left_from_right, px, py, pz, weights, best, rows, table, codes_l, codes_r, w, h = (
        fitness_arguments
    )
    full, view, min_view_fraction, hidden_penalty = normalisation
    history = np.empty(uniforms.shape[0])
    evaluated = 0
    for g in range(uniforms.shape[0]):
        new, source = next_generation(genes, scores, starts, elite, cdfs, uniforms[g],
                                      crossover_rate, mutation_rate)  # fmt: skip
        children = np.flatnonzero(source < 0)
        poses = transforms_from_genes(new[children], lows, spans, gray_code)
        sums, seen = score_poses(poses, K_left, K_right, left_from_right, px, py, pz, weights, best, rows,
                                 table, codes_l, codes_r, w, h, False)  # fmt: skip
        fitness = normalised(sums, seen, full, view, min_view_fraction, hidden_penalty)
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


@_jit
def transforms_from_genes(genes, lows, spans, gray_code):
    """(P, 6) 12-bit genes -> (P, 4, 4) poses; |ε| > 1 is normalised to 1 (see ga.py)."""
    n = genes.shape[0]
    T = np.zeros((n, 4, 4))
    x = np.empty(6)
    for p in range(n):
        for g in range(6):
            v = np.int64(genes[p, g])
            if gray_code:
                v ^= v >> 1
                v ^= v >> 2
                v ^= v >> 4
                v ^= v >> 8
            x[g] = lows[g] + v / 4095.0 * spans[g]
        e1, e2, e3 = x[3], x[4], x[5]
        norm2 = e1 * e1 + e2 * e2 + e3 * e3
        if norm2 > 1.0:
            scale = 1.0 / np.sqrt(norm2)
            e1, e2, e3 = e1 * scale, e2 * scale, e3 * scale
            norm2 = 1.0
        e0 = np.sqrt(1.0 - norm2)
        T[p, 0, 0] = 1 - 2 * (e2 * e2 + e3 * e3)
        T[p, 0, 1] = 2 * (e1 * e2 - e0 * e3)
        T[p, 0, 2] = 2 * (e1 * e3 + e0 * e2)
        T[p, 1, 0] = 2 * (e1 * e2 + e0 * e3)
        T[p, 1, 1] = 1 - 2 * (e1 * e1 + e3 * e3)
        T[p, 1, 2] = 2 * (e2 * e3 - e0 * e1)
        T[p, 2, 0] = 2 * (e1 * e3 - e0 * e2)
        T[p, 2, 1] = 2 * (e2 * e3 + e0 * e1)
        T[p, 2, 2] = 1 - 2 * (e1 * e1 + e2 * e2)
        T[p, 0, 3], T[p, 1, 3], T[p, 2, 3] = x[0], x[1], x[2]
        T[p, 3, 3] = 1.0
    return T


@_jit
def moved_poses(pose, deltas):
    """(K, 4, 4) copies of `pose` each moved by a row of `deltas` (K, 6): dx, dy [m], depth
    change along the ray through the model origin [m], rotation vector about the camera
    axes through the model origin [rad] (see refinement.moved)."""
    out = np.empty((deltas.shape[0], 4, 4))
    depth = pose[2, 3]
    for k in range(deltas.shape[0]):
        out[k] = pose
        out[k, 0, 3] += deltas[k, 0]
        out[k, 1, 3] += deltas[k, 1]
        if depth > 0:
            scale = (depth + deltas[k, 2]) / depth
            for r in range(3):
                out[k, r, 3] *= scale
        else:
            out[k, 2, 3] += deltas[k, 2]
        wx, wy, wz = deltas[k, 3], deltas[k, 4], deltas[k, 5]
        angle = np.sqrt(wx * wx + wy * wy + wz * wz)
        if angle > 0:
            x, y, z = wx / angle, wy / angle, wz / angle
            c, s_, t = np.cos(angle), np.sin(angle), 1.0 - np.cos(angle)
            R = np.array(
                [
                    [c + x * x * t, x * y * t - z * s_, x * z * t + y * s_],
                    [y * x * t + z * s_, c + y * y * t, y * z * t - x * s_],
                    [z * x * t - y * s_, z * y * t + x * s_, c + z * z * t],
                ]
            )
            for r in range(3):
                for c in range(3):
                    out[k, r, c] = R[r, 0] * pose[0, c] + R[r, 1] * pose[1, c] + R[r, 2] * pose[2, c]
    return out


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
def _fitness(poses, fitness_arguments, normalisation, bilinear):
    """`score_poses` + `normalised`: the normalised fitness of (P, 4, 4) poses."""
    K_left, K_right, left_from_right, px, py, pz, weights, best, rows, table, codes_l, codes_r, w, h = (
        fitness_arguments
    )
    sums, seen = score_poses(poses, K_left, K_right, left_from_right, px, py, pz, weights, best, rows,
                             table, codes_l, codes_r, w, h, bilinear)  # fmt: skip
    full, view, min_view_fraction, hidden_penalty = normalisation
    return normalised(sums, seen, full, view, min_view_fraction, hidden_penalty)


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
    best = _fitness(start.reshape(1, 4, 4), fitness_arguments, normalisation, False)[0]
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
            best = _fitness(best_pose.reshape(1, 4, 4), fitness_arguments, normalisation, True)[0]
            evaluated += 1
        y, poses = cma_sample(draws[generation - 1], B, D, mean, sigma, scale, start)
        scores = np.full(lam, -np.inf)
        inside = np.flatnonzero(poses_allowed(poses, limits, avoided))
        if inside.shape[0] > 0:
            fitness = _fitness(poses[inside], fitness_arguments, normalisation, bilinear)
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
def pose_parameters(transforms):
    """(P, 4, 4) ^CR T_M -> (P, 6) (t, ε1, ε2, ε3), the unit quaternion's vector part with
    ε0 >= 0 (Shepperd: the largest of the four squared components gives a stable division)."""
    out = np.empty((transforms.shape[0], 6))
    q = np.empty(4)
    for p in range(transforms.shape[0]):
        R = transforms[p]
        r00, r11, r22 = R[0, 0], R[1, 1], R[2, 2]
        squares = (1 + r00 + r11 + r22, 1 + r00 - r11 - r22, 1 - r00 + r11 - r22, 1 - r00 - r11 + r22)
        pick = 0
        for k in range(1, 4):
            if squares[k] > squares[pick]:
                pick = k
        s = np.sqrt(max(squares[pick], 1e-300)) * 2.0
        d21, d02, d10 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
        a01, a02, a12 = R[0, 1] + R[1, 0], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1]
        if pick == 0:
            q[0], q[1], q[2], q[3] = s / 4, d21 / s, d02 / s, d10 / s
        elif pick == 1:
            q[0], q[1], q[2], q[3] = d21 / s, s / 4, a01 / s, a02 / s
        elif pick == 2:
            q[0], q[1], q[2], q[3] = d02 / s, a01 / s, s / 4, a12 / s
        else:
            q[0], q[1], q[2], q[3] = d10 / s, a02 / s, a12 / s, s / 4
        sign = -1.0 if q[0] < 0 else 1.0
        norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        for k in range(3):
            out[p, k] = R[k, 3]
            out[p, 3 + k] = sign * q[1 + k] / norm
    return out


@_jit
def poses_inside(transforms, low, high, min_cos_tilt, max_yaw):
    """(P,) bool: position within [low, high] (each of x, y, z), the model normal's cosine
    to the camera axis at least `min_cos_tilt`, |yaw| at most `max_yaw` (inf: any)."""
    n = transforms.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        ok = transforms[i, 2, 2] >= min_cos_tilt
        for k in range(3):
            t = transforms[i, k, 3]
            ok = ok and low[k] <= t <= high[k]
        if ok and max_yaw < np.inf:
            ok = abs(np.arctan2(transforms[i, 1, 0], transforms[i, 0, 0])) <= max_yaw
        out[i] = ok
    return out


@_jit
def poses_avoided(transforms, centres, windows, separation):
    """(P,) bool: the model origin within `separation` (x-y) of a centre (x, y, yaw) of
    (K, 3) `centres` and the yaw within that centre's `windows` [rad] of its yaw (a window
    above pi: any yaw; NaN cannot say so here, as fastmath assumes there is none)."""
    n = transforms.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        yaw = np.arctan2(transforms[i, 1, 0], transforms[i, 0, 0])
        for c in range(centres.shape[0]):
            dx, dy = transforms[i, 0, 3] - centres[c, 0], transforms[i, 1, 3] - centres[c, 1]
            if np.sqrt(dx * dx + dy * dy) >= separation:
                continue
            turn = (yaw - centres[c, 2] + np.pi) % (2.0 * np.pi) - np.pi
            if abs(turn) < windows[c]:
                out[i] = True
                break
    return out


@_jit
def poses_allowed(transforms, limits, avoided):
    """(P,) bool: `poses_inside(transforms, *limits)` and not `poses_avoided(transforms, *avoided)`."""
    out = poses_inside(transforms, *limits)
    if avoided[0].shape[0] > 0:
        out &= ~poses_avoided(transforms, *avoided)
    return out


@_jit
def compass_run(start, steps, iterations, min_step, fitness_arguments, normalisation, bilinear, limits,
                avoided):  # fmt: skip
    """`refinement.compass_search` in one compiled loop, for a fitness that is `score_poses`
    + `normalised` (`bilinear` or not) and an allowed set that is `poses_allowed(limits,
    avoided)`. Returns (best pose, its score, poses scored)."""
    pose = start.copy()
    current = _fitness(pose.reshape(1, 4, 4), fitness_arguments, normalisation, bilinear)[0]
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
        fitness = _fitness(candidates[inside], fitness_arguments, normalisation, bilinear)
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
                    more = _fitness(along[ok], fitness_arguments, normalisation, bilinear)
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


__all__ = [
    "bgr_codes",
    "breed",
    "cma_run",
    "cma_sample",
    "cma_update",
    "compass_run",
    "every_colour",
    "evolve",
    "hsv_codes",
    "moved_poses",
    "next_generation",
    "normalised",
    "pose_parameters",
    "poses_allowed",
    "poses_avoided",
    "poses_inside",
    "score_poses",
    "transforms_from_genes",
]
