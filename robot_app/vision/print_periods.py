"""The periods of a cloth's print: shifts that map the model photo's texture onto itself.

A periodic print (stripes, checks, diagonals) scores nearly as well at a pose shifted by
one period as at the truth: only the outline tells them apart, and between the two peaks
the hue fitness has a valley that the GA's end and the polish do not cross (the pose is
a period off with a high confidence). The periods are measured once per model from the
masked, zero-mean normalised autocorrelation of the model photo's colour texture (blurred
and sampled at `sample` metres): a shift is a period if the correlation there is a local
maximum of at least `min_correlation`, well above the correlation at half the shift (a ridge along a stripe is
not a period), with the two images overlapping on at least
`min_overlap` of the cloth and the shift at most `max_shift` long. A plain cloth (no
texture to correlate) or a photograph (no repeat) has none. The propose stage tries the
best pose shifted by each period (`ProposalSettings.period_shifts`).
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.vision.cloth_model import ClothModel


class PeriodSettings(StrictModel):
    """How the periods of a print are measured (`print_periods`).

    Attributes:
        enabled: try the best pose shifted by the print's periods (off: the GA's end alone).
        sample: grid step of the autocorrelation on the cloth [m].
        min_correlation: a shift whose normalised autocorrelation reaches this is a period.
        min_prominence: ... if it is this much above the correlation at half the shift
            (along a stripe the correlation is a ridge, not a peak: the polish slides along it).
        min_overlap: ... if the texture and its shifted copy overlap on this share of the cloth.
        min_shift, max_shift: ... and it is this long [m].
        max_periods: the shortest this many (each with its opposite) are kept.
        min_texture: RMS colour deviation over the cloth below which it is plain [grey levels].
    """

    enabled: bool = True
    sample: float = Field(default=0.002, gt=0.0005, le=0.01)
    min_correlation: float = Field(default=0.6, gt=0.0, le=1.0)
    min_prominence: float = Field(default=0.3, gt=0.0, le=2.0)
    min_overlap: float = Field(default=0.5, gt=0.0, le=1.0)
    min_shift: float = Field(default=0.008, gt=0.0)
    max_shift: float = Field(default=0.08, gt=0.0)
    max_periods: int = Field(default=4, ge=1)
    min_texture: float = Field(default=8.0, ge=0.0)


def print_periods(model: ClothModel, settings: PeriodSettings) -> FloatArray:
    """(K, 4, 4) maps G of Σ_M onto itself under which the model's print looks the same
    (the interior, not the outline): shifts by a period (each with its opposite), half
    turns about a point of the print's own half-turn symmetry other than the model
    origin and quarter turns about a point of its quarter-turn symmetry (square checks),
    shortest shift first; (0, 4, 4) for a plain or non-periodic print or
    a model without texture. A pose T of the cloth a period off the truth has the truth
    at T @ G for one of them."""
    s = settings
    none = np.zeros((0, 4, 4))
    if model.texture_bgr is None or model.texture_mask is None or model.texture_from_model is None:
        return none
    A = np.asarray(model.texture_from_model, dtype=float)
    metres_per_pixel = 1.0 / float(np.sqrt(abs(np.linalg.det(A[:, :2]))))
    scale = metres_per_pixel / s.sample
    texture = cv2.GaussianBlur(model.texture_bgr.astype(np.float32), (0, 0), max(0.5 / scale, 0.5))
    size = (max(round(texture.shape[1] * scale), 1), max(round(texture.shape[0] * scale), 1))
    colour = cv2.resize(texture, size, interpolation=cv2.INTER_AREA).astype(float)
    mask = cv2.resize(model.texture_mask.astype(np.float32), size, interpolation=cv2.INTER_AREA) > 0.99
    if mask.sum() < 16:
        return none
    centred = (colour - colour[mask].mean(axis=0)) * mask[..., None]
    if float(np.sqrt(np.mean(centred[mask] ** 2))) < s.min_texture:
        return none
    maps = []
    correlation, rows, cols, centre = _peaks(centred, mask, centred, mask, s)
    halfway = correlation[(rows + centre[0]) // 2, (cols + centre[1]) // 2]
    isolated = correlation[rows, cols] - halfway >= s.min_prominence  # not a ridge along stripes
    half = (rows > centre[0]) | ((rows == centre[0]) & (cols > centre[1]))  # each with its opposite
    rows, cols = rows[isolated & half], cols[isolated & half]
    # a peak at (dv, du) downsampled pixels: c(p + shift) = c(p), the print repeats by the shift
    steps = np.vstack([(cols - centre[1]) / scale, (rows - centre[0]) / scale])
    shifts = np.linalg.solve(A[:, :2], steps).T  # texture pixels -> Σ_M [m]
    for k in _one_per_ridge(correlation, rows, cols, np.linalg.norm(shifts, axis=1), s):
        for sign in (1.0, -1.0):
            G = np.eye(4)
            G[:2, 3] = sign * shifts[k]
            maps.append(G)
    height, width = mask.shape
    L, t = A[:, :2], A[:, 2]
    for M, turned, offset in (
        (np.array([[-1, 0], [0, -1]]), lambda x: x[::-1, ::-1], (width - 1, height - 1)),  # a half turn
        (np.array([[0, -1], [1, 0]]), lambda x: np.rot90(x, 1), (width - 1, 0)),  # quarter turns
        (np.array([[0, 1], [-1, 0]]), lambda x: np.rot90(x, -1), (0, height - 1)),
    ):
        # the turned copy b(q) = c(M q + o) in downsampled pixels (u, v); a peak at shift q:
        # c(p + q) = b(p), i.e. the print is the same under p -> M p + e with e = o - M q
        correlation, rows, cols, centre = _peaks(centred, mask, turned(centred), turned(mask), s)
        q = np.vstack([cols - centre[1], rows - centre[0]]).astype(float)
        e = np.asarray(offset, dtype=float)[:, None] - M @ q
        ones = np.ones((2, 1))
        e_texture = 0.5 * (M @ ones) * (1.0 - 1.0 / scale) + (e + 0.5) / scale - 0.5  # texture pixels
        R = np.linalg.solve(L, M @ L)  # the same turn in Σ_M: x -> R x + d
        d = np.linalg.solve(L, (M @ t)[:, None] + e_texture - t[:, None]).T
        length = np.linalg.norm(d, axis=1)
        minimum = s.min_shift if M[0, 0] < 0 else 0.0  # the half turn about the origin is tried anyway
        for k in _one_per_ridge(correlation, rows, cols, length, s, minimum):
            G = np.eye(4)
            G[:2, :2], G[:2, 3] = R, d[k]
            maps.append(G)
    if not maps:
        return none
    out = np.array(maps)
    return out[np.argsort(np.linalg.norm(out[:, :2, 3], axis=1), kind="stable")]


def _peaks(
    a: FloatArray,
    mask_a: npt.NDArray[np.bool_],
    b: FloatArray,
    mask_b: npt.NDArray[np.bool_],
    s: PeriodSettings,
) -> tuple[FloatArray, npt.NDArray[np.int64], npt.NDArray[np.int64], tuple[int, int]]:
    """The masked normalised cross-correlation Σ a(p + q) b(p) over the colour channels
    (q = index - centre; -1 where the overlap is below `min_overlap`) and its local maxima
    of at least `min_correlation`."""
    shape = (cv2.getOptimalDFTSize(a.shape[0] + b.shape[0]), cv2.getOptimalDFTSize(a.shape[1] + b.shape[1]))
    spectra_a = [np.fft.rfft2(a[..., c], shape) for c in range(3)]
    spectra_b = [np.fft.rfft2(b[..., c], shape) for c in range(3)]
    numerator = np.fft.irfft2(
        sum(fa * np.conj(fb) for fa, fb in zip(spectra_a, spectra_b, strict=True)), shape
    )
    weights_a = np.fft.rfft2(mask_a.astype(float), shape)
    weights_b = np.fft.rfft2(mask_b.astype(float), shape)
    energy_a = np.fft.irfft2(np.fft.rfft2(np.sum(a**2, axis=2), shape) * np.conj(weights_b), shape)
    energy_b = np.fft.irfft2(weights_a * np.conj(np.fft.rfft2(np.sum(b**2, axis=2), shape)), shape)
    overlap = np.fft.fftshift(np.fft.irfft2(weights_a * np.conj(weights_b), shape))
    correlation = np.fft.fftshift(numerator / np.sqrt(np.maximum(energy_a * energy_b, 1e-12)))
    correlation = np.where(overlap >= s.min_overlap * mask_a.sum(), correlation, -1.0)
    local_max = correlation >= cv2.dilate(correlation.astype(np.float32), np.ones((5, 5), np.uint8)) - 1e-6
    rows, cols = np.nonzero(local_max & (correlation >= s.min_correlation))
    return correlation, rows, cols, (shape[0] // 2, shape[1] // 2)


def _one_per_ridge(
    correlation: FloatArray,
    rows: npt.NDArray[np.int64],
    cols: npt.NDArray[np.int64],
    length: FloatArray,
    s: PeriodSettings,
    min_length: float | None = None,
) -> list[int]:
    """Indices of the shortest peak of each ridge within the length limits (`min_length`:
    instead of `min_shift`), at most `max_periods`: two peaks joined by high correlation (at
    their midpoint) are one along a stripe."""
    kept: list[int] = []
    for k in np.argsort(length, kind="stable"):
        if not (s.min_shift if min_length is None else min_length) <= length[k] <= s.max_shift:
            continue
        level = correlation[rows[k], cols[k]]
        joined = any(
            correlation[(rows[k] + rows[j]) // 2, (cols[k] + cols[j]) // 2]
            >= min(level, correlation[rows[j], cols[j]]) - s.min_prominence
            for j in kept
        )
        if not joined:
            kept.append(int(k))
        if len(kept) == s.max_periods:
            break
    return kept


__all__ = ["PeriodSettings", "print_periods"]
