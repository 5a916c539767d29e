"""Compiled comparisons of the verify stage: the model photo's texture samples projected into
both images at each pose, compared cell by cell; and the outline's colour contrast."""

from __future__ import annotations

import numpy as np
from numba import njit

from robot_app.vision.fitness_kernels import _projection

_jit = njit(cache=True, fastmath=True, nogil=True, error_model="numpy")
AGREES, DISAGREES = 1, 2  # a texture cell's verdict in `appearance`'s agree_cells (0: not compared)


@_jit
def _accumulate(M, px, py, values, cells, image, codes, foreign, gains, shade_factors, shade_index, block,
                saturated, width, height, sums):  # fmt: skip
    """Adds the visible samples of one image to `sums` (cells, 17): count, then per channel
    (b, g, r) the sums of model, image, model², image² and model·image values, then the
    count of samples in the image (visible or hidden). A sample is visible if it lands
    inside the image and its pixel's code (nearest pixel of the framed `codes`) is not
    `foreign`. Image values are multiplied by `gains` and by the shading factor of their
    block (`shade_factors[shade_index[v // block, u // block]]`, see `exposure.Shading`).
    A channel read at `saturated[i]` or more is clipped by the camera: its true value is at
    least what was read, so where the model's value is higher the sample takes the model's
    (consistent with it; a lower model value still disagrees).
    Returns the number of visible samples."""
    stride = width + 3
    rows, cols = shade_index.shape[0], shade_index.shape[1]
    visible = 0
    for i in range(px.shape[0]):
        x, y = px[i], py[i]
        w = M[2, 0] * x + M[2, 1] * y + M[2, 3]
        if w <= 1e-6:
            continue
        u = (M[0, 0] * x + M[0, 1] * y + M[0, 3]) / w
        v = (M[1, 0] * x + M[1, 1] * y + M[1, 3]) / w
        if not (0.0 <= u < width - 1.0 and 0.0 <= v < height - 1.0):
            continue
        iu, iv = np.int64(u), np.int64(v)
        fu, fv = u - iu, v - iv
        nu, nv = np.int64(u + 0.5), np.int64(v + 0.5)
        c = cells[i]
        sums[c, 16] += 1.0
        if foreign[codes[(nv + 1) * stride + nu + 1]]:
            continue
        visible += 1
        sums[c, 0] += 1.0
        shade = shade_factors[shade_index[min(nv // block, rows - 1), min(nu // block, cols - 1)]]
        for k in range(3):
            a = image[iv, iu, k] + fu * (image[iv, iu + 1, k] - np.float32(image[iv, iu, k]))
            b = image[iv + 1, iu, k] + fu * (image[iv + 1, iu + 1, k] - np.float32(image[iv + 1, iu, k]))
            raw = a + fv * (b - a)
            seen = raw * gains[k] * shade
            m = values[i, k]
            if raw >= saturated[i] and m > seen:
                seen = m
            sums[c, 1 + 5 * k] += m
            sums[c, 2 + 5 * k] += seen
            sums[c, 3 + 5 * k] += m * m
            sums[c, 4 + 5 * k] += seen * seen
            sums[c, 5 + 5 * k] += m * seen
    return visible


@_jit
def _cell_scores(sums, min_points, texture_min, flat_tolerance, chroma_tolerance, brightness_tolerance,
                 out_scores, out_weights):  # fmt: skip
    """Each cell's agreement in [-1, 1] and weight (its visible samples; 0: not scored).

    A cell whose model texture has an RMS deviation of at least `texture_min` (grey
    levels, over the three channels) scores the zero-mean normalised cross-correlation of
    each channel, weighted by the model's deviation in that channel: invariant to a gain
    and an offset per channel, i.e. to exposure and white balance. A flat cell scores 1
    if the image is flat there too (RMS deviation at most the model's + `flat_tolerance`),
    falling to -1 at twice that tolerance: a plain model on a patterned cloth disagrees;
    and only if its mean colour agrees: chromaticity (b, g, r over their sum) within
    `chroma_tolerance` and brightness within a factor 1 + `brightness_tolerance` (the
    image after the exposure gains), each falling to -1 at twice the tolerance.
    """
    log_bright = np.log(1.0 + brightness_tolerance)
    mean_m = np.zeros(3)
    mean_i = np.zeros(3)
    for c in range(sums.shape[0]):
        n = sums[c, 0]
        out_scores[c] = 0.0
        out_weights[c] = 0.0
        if n < min_points:
            continue
        var_m = np.zeros(3)
        var_i = np.zeros(3)
        cov = np.zeros(3)
        for k in range(3):
            mean_m[k], mean_i[k] = sums[c, 1 + 5 * k] / n, sums[c, 2 + 5 * k] / n
            var_m[k] = max(sums[c, 3 + 5 * k] / n - mean_m[k] * mean_m[k], 0.0)
            var_i[k] = max(sums[c, 4 + 5 * k] / n - mean_i[k] * mean_i[k], 0.0)
            cov[k] = sums[c, 5 + 5 * k] / n - mean_m[k] * mean_i[k]
        rms_m = np.sqrt((var_m[0] + var_m[1] + var_m[2]) / 3.0)
        rms_i = np.sqrt((var_i[0] + var_i[1] + var_i[2]) / 3.0)
        if rms_m >= texture_min:
            total, weights = 0.0, 0.0
            for k in range(3):
                sd = np.sqrt(var_m[k])
                total += sd * cov[k] / np.sqrt(var_m[k] * var_i[k] + 1e-9)
                weights += sd
            score = total / weights
        else:
            excess = (rms_i - rms_m - flat_tolerance) / flat_tolerance
            score = 1.0 - 2.0 * min(max(excess, 0.0), 1.0)
            sum_m = max(mean_m[0] + mean_m[1] + mean_m[2], 1.0)
            sum_i = max(mean_i[0] + mean_i[1] + mean_i[2], 1.0)
            d = 0.0
            for k in range(3):
                d += (mean_m[k] / sum_m - mean_i[k] / sum_i) ** 2
            excess = (np.sqrt(d) - chroma_tolerance) / chroma_tolerance
            score = min(score, 1.0 - 2.0 * min(max(excess, 0.0), 1.0))
            excess = (abs(np.log(sum_i / sum_m)) - log_bright) / log_bright
            score = min(score, 1.0 - 2.0 * min(max(excess, 0.0), 1.0))
        out_scores[c] = score
        out_weights[c] = n
    return out_scores, out_weights


@_jit
def appearance(transforms, K_left, K_right, left_from_right, px, py, values, cells, n_cells, image_left,
               image_right, codes_left, codes_right, foreign, gains_left, gains_right, shade_factors_left,
               shade_index_left, shade_factors_right, shade_index_right, block, saturated, min_points,
               texture_min, flat_tolerance, chroma_tolerance, brightness_tolerance, partial_low, partial_high,
               agree_level):  # fmt: skip
    """For each pose: the cell-weighted agreement of the texture samples with both images
    (NaN if no cell is scored), the share of samples visible (mean of both images), the
    share of the scored weight on textured cells, and the share of the samples in view
    that lie in partly hidden cells (a hidden share between `partial_low` and
    `partial_high`; cells with fewer than `min_points` samples in view left out), and the
    share of the scored weight on cells that agree at least `agree_level` (NaN if none);
    and (P, 2, n_cells) uint8 per pose and image (left, right): the cell is scored and agrees
    (`AGREES`), is scored and does not (`DISAGREES`), or is not scored (0).

    Args:
        transforms: (P, 4, 4) poses ^CR T_M.
        K_left, K_right, left_from_right: the rig.
        px, py: (N,) float32 sample positions on the cloth plane [m] (z = 0).
        values: (N, 3) float32 the model photo's (blurred) b, g, r at each sample.
        cells: (N,) int64 cell of each sample; n_cells cells.
        image_left, image_right: (H, W, 3) uint8 images.
        codes_left, codes_right: the framed pixel codes of `FitnessEvaluator.codes`.
        foreign: (259,) bool per pixel code: a sample there is hidden.
        gains_left, gains_right: (3,) channel gains of each image (exposure reference).
        shade_factors_left, shade_index_left, shade_factors_right, shade_index_right, block:
            each image's shading (`exposure.Shading`; one level of factor 1: even light).
        saturated: (N,) float32 per sample: an image channel read at this or more is clipped
            (`_accumulate`; 256: never, as for the samples of textured cells).
        min_points, texture_min, flat_tolerance, chroma_tolerance, brightness_tolerance:
            see `_cell_scores`.
    """
    height, width = image_left.shape[0], image_left.shape[1]
    n_poses = transforms.shape[0]
    scores = np.empty(n_poses)
    agree_cells = np.zeros((n_poses, 2, n_cells), np.uint8)
    visible = np.empty(n_poses)
    textured = np.empty(n_poses)
    interleaved = np.empty(n_poses)
    agreeing = np.empty(n_poses)
    P_right = np.zeros((3, 4))
    P_right[:, :3] = K_right
    P_left = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    M = np.empty((3, 4), np.float32)
    cell_scores = np.empty(n_cells)
    cell_weights = np.empty(n_cells)
    model_rms = np.zeros(n_cells)
    for p in range(n_poses):
        total, weight, textured_weight, seen = 0.0, 0.0, 0.0, 0
        in_view, partial, agreeing_weight = 0.0, 0.0, 0.0
        for side in range(2):
            sums = np.zeros((n_cells, 17))
            if side == 0:
                _projection(P_left, transforms[p], M)
                seen += _accumulate(M, px, py, values, cells, image_left, codes_left, foreign, gains_left,
                                    shade_factors_left, shade_index_left, block, saturated, width, height,
                                    sums)  # fmt: skip
            else:
                _projection(P_right, transforms[p], M)
                seen += _accumulate(M, px, py, values, cells, image_right, codes_right, foreign, gains_right,
                                    shade_factors_right, shade_index_right, block, saturated, width, height,
                                    sums)  # fmt: skip
            _cell_scores(sums, min_points, texture_min, flat_tolerance, chroma_tolerance,
                         brightness_tolerance, cell_scores, cell_weights)  # fmt: skip
            for c in range(n_cells):
                landed = sums[c, 16]
                if landed >= min_points:
                    hidden = 1.0 - sums[c, 0] / landed
                    in_view += landed
                    if partial_low <= hidden <= partial_high:
                        partial += landed
                n = sums[c, 0]
                if n > 0:
                    var = 0.0
                    for k in range(3):
                        mean = sums[c, 1 + 5 * k] / n
                        var += max(sums[c, 3 + 5 * k] / n - mean * mean, 0.0)
                    model_rms[c] = np.sqrt(var / 3.0)
                total += cell_scores[c] * cell_weights[c]
                weight += cell_weights[c]
                if cell_scores[c] >= agree_level:
                    agreeing_weight += cell_weights[c]
                    if cell_weights[c] > 0:
                        agree_cells[p, side, c] = AGREES
                elif cell_weights[c] > 0:
                    agree_cells[p, side, c] = DISAGREES
                if model_rms[c] >= texture_min:
                    textured_weight += cell_weights[c]
        scores[p] = total / weight if weight > 0 else np.nan
        visible[p] = seen / (2.0 * px.shape[0])
        textured[p] = textured_weight / weight if weight > 0 else 0.0
        interleaved[p] = partial / in_view if in_view > 0 else 0.0
        agreeing[p] = agreeing_weight / weight if weight > 0 else np.nan
    return scores, visible, textured, interleaved, agreeing, agree_cells


@_jit
def cell_sums(transform, K_left, K_right, left_from_right, px, py, values, cells, n_cells, image_left,
              image_right, codes_left, codes_right, foreign, gains_left, gains_right, shade_factors_left,
              shade_index_left, shade_factors_right, shade_index_right, block, saturated):  # fmt: skip
    """(2, n_cells, 17) the sums `appearance` compares cell by cell, of one pose (4, 4) in
    each image (left, right): `_accumulate`'s columns (the occluder read, `verify.py`, looks
    at each cell's own numbers). Arguments as in `appearance`."""
    height, width = image_left.shape[0], image_left.shape[1]
    P_right = np.zeros((3, 4))
    P_right[:, :3] = K_right
    P_left = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    M = np.empty((3, 4), np.float32)
    sums = np.zeros((2, n_cells, 17))
    _projection(P_left, transform, M)
    _accumulate(M, px, py, values, cells, image_left, codes_left, foreign, gains_left, shade_factors_left,
                shade_index_left, block, saturated, width, height, sums[0])  # fmt: skip
    _projection(P_right, transform, M)
    _accumulate(M, px, py, values, cells, image_right, codes_right, foreign, gains_right, shade_factors_right,
                shade_index_right, block, saturated, width, height, sums[1])  # fmt: skip
    return sums


@_jit
def _at_least(raw, factor, saturated, model):
    """A channel read `raw`, corrected by `factor`; where the camera clipped it (`raw` at least
    `saturated`) it is at least that, so a higher `model` value is taken as seen."""
    seen = raw * factor
    return model if raw >= saturated and model > seen else seen


@_jit
def _same_colour(image, u, v, gains, shade_factors, shade_index, block, saturated, model, chroma_tolerance,
                 bright):  # fmt: skip
    """Does the image's (gain- and shading-corrected, nearest) pixel at (u, v) show the colour
    `model` (b, g, r): chromaticity within `chroma_tolerance` and brightness within the
    factor `bright` either way? (Shading and clipped channels as in `_accumulate`.)"""
    iu, iv = np.int64(u + 0.5), np.int64(v + 0.5)
    rows, cols = shade_index.shape[0], shade_index.shape[1]
    shade = shade_factors[shade_index[min(iv // block, rows - 1), min(iu // block, cols - 1)]]
    b = _at_least(image[iv, iu, 0], gains[0] * shade, saturated, model[0])
    g = _at_least(image[iv, iu, 1], gains[1] * shade, saturated, model[1])
    r = _at_least(image[iv, iu, 2], gains[2] * shade, saturated, model[2])
    sum_m = max(model[0] + model[1] + model[2], 1.0)
    sum_i = max(b + g + r, 1.0)
    if sum_i > sum_m * bright or sum_m > sum_i * bright:
        return False
    d = (model[0] / sum_m - b / sum_i) ** 2 + (model[1] / sum_m - g / sum_i) ** 2
    d += (model[2] / sum_m - r / sum_i) ** 2
    return d <= chroma_tolerance * chroma_tolerance


@_jit
def _outline_side(M, inner, outer, model_bgr, inner_cells, agree, image, codes, gains,
                  shade_factors, shade_index, block, saturated, foreign, sheet, chroma_tolerance, bright,
                  width, height, counts):  # fmt: skip
    """Adds one image's outline pairs to `counts` (edge, same, astray, seam, coloured). A pair counts
    where both points land in the image. Its inner point on a foreign colour (an occluder,
    or another cloth's colours) makes it a seam if the outer point shows the sheet (the
    foreign region ends exactly at the outline, as another cloth's does, not an occluder)
    and is otherwise left out; an inner point not showing the model photo's colour there
    (`_same_colour`) is astray; a pair whose inner point's texture cell does not agree
    (`agree[inner_cells[i]] != AGREES`; -1: no cell) is left out (a textured print under a sheet of
    its own colour, a fold: the texture says it is not the model there); else the outer
    point shows the model's colour (same: the region goes on past the outline) or not
    (edge). counts[4]: the pairs whose inner point shows the model's colour, before the cell
    gate (edge + same are the share of them the gate lets through)."""
    stride = width + 3
    for i in range(inner.shape[0]):
        w = M[2, 0] * inner[i, 0] + M[2, 1] * inner[i, 1] + M[2, 3]
        wo = M[2, 0] * outer[i, 0] + M[2, 1] * outer[i, 1] + M[2, 3]
        if w <= 1e-6 or wo <= 1e-6:
            continue
        u = (M[0, 0] * inner[i, 0] + M[0, 1] * inner[i, 1] + M[0, 3]) / w
        v = (M[1, 0] * inner[i, 0] + M[1, 1] * inner[i, 1] + M[1, 3]) / w
        uo = (M[0, 0] * outer[i, 0] + M[0, 1] * outer[i, 1] + M[0, 3]) / wo
        vo = (M[1, 0] * outer[i, 0] + M[1, 1] * outer[i, 1] + M[1, 3]) / wo
        if not (0.0 <= u < width - 0.5 and 0.0 <= v < height - 0.5):
            continue
        if not (0.0 <= uo < width - 0.5 and 0.0 <= vo < height - 0.5):
            continue
        inside = codes[(np.int64(v + 0.5) + 1) * stride + np.int64(u + 0.5) + 1]
        outside = codes[(np.int64(vo + 0.5) + 1) * stride + np.int64(uo + 0.5) + 1]
        if outside == foreign.shape[0] - 1 or inside == foreign.shape[0] - 1:  # OFF_IMAGE: outside the box
            continue
        if foreign[inside]:
            if sheet[outside]:
                counts[3] += 1.0
            continue
        cell = inner_cells[i]
        checked = cell >= 0 and agree[cell] == AGREES
        if not _same_colour(image, u, v, gains, shade_factors, shade_index, block, saturated, model_bgr[i],
                            chroma_tolerance, bright):  # fmt: skip
            if checked:
                counts[2] += 1.0
            continue
        counts[4] += 1.0
        if not checked:
            continue
        if _same_colour(image, uo, vo, gains, shade_factors, shade_index, block, saturated, model_bgr[i],
                          chroma_tolerance, bright):  # fmt: skip
            counts[1] += 1.0
        else:
            counts[0] += 1.0


@_jit
def outline_contrast(transforms, K_left, K_right, left_from_right, inner, outer, model_bgr, inner_cells,
                     agree_cells, image_left, image_right, codes_left, codes_right, gains_left, gains_right,
                     shade_factors_left, shade_index_left, shade_factors_right, shade_index_right, block,
                     saturated, foreign, sheet, chroma_tolerance, brightness_tolerance):  # fmt: skip
    """For each pose, over both images: the outline pairs that are edges, same, astray and
    seams, and those whose inner point shows the model's colour before the cell gate
    (`_outline_side`).

    Args:
        transforms: (P, 4, 4) poses ^CR T_M.
        K_left, K_right, left_from_right: the rig.
        inner, outer: (N, 2) float64 points just inside and just outside the outline [m].
        model_bgr: (N, 3) float64 the model photo's (blurred) colour at each inner point.
        inner_cells: (N,) int64 the texture cell of each inner point (-1: none).
        agree_cells: (P, 2, cells) uint8 per pose and image: the cell agrees (`appearance`).
        image_left, image_right: (H, W, 3) uint8 images.
        codes_left, codes_right: the framed pixel codes of `FitnessEvaluator.codes`.
        gains_left, gains_right: (3,) channel gains of each image (exposure reference).
        shade_factors_left, shade_index_left, shade_factors_right, shade_index_right, block:
            each image's shading, as in `appearance`.
        saturated: an image channel read at this or more is clipped (`_at_least`; 256: none).
        foreign: (259,) bool per pixel code: foreign to the model (hidden), and OFF_IMAGE.
        sheet: (259,) bool per pixel code: the sheet's hue.
        chroma_tolerance, brightness_tolerance: see `_same_colour` (the factor minus one).

    Returns:
        (P, 5) counts (edge, same, astray, seam, coloured).
    """
    height, width = image_left.shape[0], image_left.shape[1]
    bright = 1.0 + brightness_tolerance
    out = np.zeros((transforms.shape[0], 5))
    P_right = np.zeros((3, 4))
    P_right[:, :3] = K_right
    P_left = K_left @ np.ascontiguousarray(left_from_right[:3, :])
    M = np.empty((3, 4), np.float32)
    counts = np.zeros(5)
    for p in range(transforms.shape[0]):
        counts[:] = 0.0
        _projection(P_left, transforms[p], M)
        _outline_side(M, inner, outer, model_bgr, inner_cells, agree_cells[p, 0], image_left,
                      codes_left, gains_left, shade_factors_left, shade_index_left, block, saturated, foreign,
                      sheet, chroma_tolerance, bright, width, height, counts)  # fmt: skip
        _projection(P_right, transforms[p], M)
        _outline_side(M, inner, outer, model_bgr, inner_cells, agree_cells[p, 1], image_right,
                      codes_right, gains_right, shade_factors_right, shade_index_right, block, saturated,
                      foreign, sheet, chroma_tolerance, bright, width, height, counts)  # fmt: skip
        out[p, :] = counts
    return out


__all__ = ["appearance", "cell_sums", "outline_contrast"]
