"""The occluder read: a plain sheet of a hue the model has, read as hidden.

The verify stage takes a texture sample as hidden where it lands on a colour foreign to the
model (`fitness_scores.foreign_codes`). A sheet of a hue the model has (brown over a red or
amber print, blue over a violet one) is not foreign: its samples count as seen, its cells
disagree with the model photo, and a right pose 45 % under it looks like a wrong one (half
the cells disagreeing, everything seen). What tells such a sheet from missing print is its
shape: a sheet is one plain region that goes on past the cloth's outline. So at a pose the
read takes, in each image, the texture cells that disagree (`verify_kernels.AGREES` not
reached) and where the image is plain (RMS deviation of the gain-corrected image at most
`VerificationSettings.occluder_plain`); neighbouring cells of one colour
(`chroma_tolerance`, `brightness_tolerance`) make a region; a region is an occluder where
the outline pairs whose inner point lies in it show its colour on the outer point too (not
the green sheet), in at least `occluder_min_pairs` pairs and `occluder_continued` of the
region's pairs in view. Its cells are then hidden: they leave the appearance, the agreeing
share and the visible fraction (`evidence`), as a sheet of a foreign colour's would.

The recogniser takes the read's evidence only where the decision's log-odds are higher with
it than with the plain evidence (a sheet read as hidden lowers the visible fraction), and
searches a pose with much of it read so again with the sheet's pixels hidden
(`Recognizer._read_and_aligned`, `depth.research.occluder_min_share`).

A real print's own plain areas end on the outline (the outer point shows the sheet, or, on
another cloth, that cloth's other colours), so a wrong cloth's missing print is not excused;
a plain model on a larger plain cloth of its colour is already told by the outline
(`Verification.outline`: its colour goes on past the outline everywhere), which the read
leaves as it was.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.verify_kernels import _cell_scores

SIDES = 2  # left, right


@dataclass(frozen=True)
class CellGrid:
    """Where the texture cells lie: (C, 2) int64 each cell's column and row on the cell grid."""

    positions: npt.NDArray[np.int64]

    def neighbours(self) -> list[npt.NDArray[np.int64]]:
        """Per cell the cells that touch it (8-neighbourhood)."""
        index = {(int(a), int(b)): k for k, (a, b) in enumerate(self.positions)}
        out = []
        for a, b in self.positions:
            near = [
                index[(int(a) + da, int(b) + db)]
                for da in (-1, 0, 1)
                for db in (-1, 0, 1)
                if (da or db) and (int(a) + da, int(b) + db) in index
            ]
            out.append(np.array(near, dtype=np.int64))
        return out


@dataclass(frozen=True)
class CellStatistics:
    """Each image's cells at one pose (`cell_statistics`), (2, C) or (2, C, 3) arrays.

    Attributes:
        scores: the cell's agreement in [-1, 1] (`verify_kernels._cell_scores`).
        weights: its visible samples if scored (0: not compared).
        visible: its visible samples (scored or not).
        landed: its samples in the image (visible or hidden).
        image_mean: the image's mean b, g, r over the visible samples (gain- and shading-corrected).
        image_rms: the image's RMS deviation over them [grey levels].
        model_rms: the model photo's RMS deviation over them [grey levels].
    """

    scores: FloatArray
    weights: FloatArray
    visible: FloatArray
    landed: FloatArray
    image_mean: FloatArray
    image_rms: FloatArray
    model_rms: FloatArray


def cell_statistics(
    sums: FloatArray,
    min_points: float,
    texture_min: float,
    flat_tolerance: float,
    chroma_tolerance: float,
    brightness_tolerance: float,
) -> CellStatistics:
    """`CellStatistics` from (2, C, 17) `verify_kernels.cell_sums`."""
    n_cells = sums.shape[1]
    scores, weights = np.zeros((SIDES, n_cells)), np.zeros((SIDES, n_cells))
    for side in range(SIDES):
        _cell_scores(
            sums[side], min_points, texture_min, flat_tolerance, chroma_tolerance, brightness_tolerance,
            scores[side], weights[side],
        )  # fmt: skip
    n = np.maximum(sums[:, :, 0], 1.0)[:, :, None]
    channels = np.arange(3) * 5
    mean_m, mean_i = sums[:, :, 1 + channels] / n, sums[:, :, 2 + channels] / n
    var_m = np.maximum(sums[:, :, 3 + channels] / n - mean_m**2, 0.0)
    var_i = np.maximum(sums[:, :, 4 + channels] / n - mean_i**2, 0.0)
    return CellStatistics(
        scores,
        weights,
        sums[:, :, 0].copy(),
        sums[:, :, 16].copy(),
        mean_i,
        np.sqrt(var_i.mean(axis=2)),
        np.sqrt(var_m.mean(axis=2)),
    )


def same_colour(
    a: FloatArray, b: FloatArray, chroma_tolerance: float, brightness_tolerance: float
) -> npt.NDArray[np.bool_]:
    """Do b, g, r colours (..., 3) `a` and `b` agree: chromaticity (each over its sum) within
    `chroma_tolerance` and brightness within the factor 1 + `brightness_tolerance` either way
    (the tests of `verify_kernels._same_colour`)?"""
    sum_a = np.maximum(np.sum(a, axis=-1), 1.0)
    sum_b = np.maximum(np.sum(b, axis=-1), 1.0)
    chroma = np.sqrt(np.sum((a / sum_a[..., None] - b / sum_b[..., None]) ** 2, axis=-1))
    bright = 1.0 + brightness_tolerance
    return np.asarray((chroma <= chroma_tolerance) & (sum_a <= sum_b * bright) & (sum_b <= sum_a * bright))


@dataclass(frozen=True)
class OutlineLooks:
    """The outline pairs seen in one image at one pose.

    Attributes:
        inner_cells: (N,) the texture cell of each pair's inner point (-1: none).
        in_view: (N,) both points land in the image.
        inner: (N, 3) the image's b, g, r at the inner point (gain- and shading-corrected).
        outer: (N, 3) ... at the outer point.
        outer_on_sheet: (N,) the outer point shows the green sheet's hue.
    """

    inner_cells: npt.NDArray[np.int64]
    in_view: npt.NDArray[np.bool_]
    inner: FloatArray
    outer: FloatArray
    outer_on_sheet: npt.NDArray[np.bool_]


@dataclass(frozen=True)
class OccluderRead:
    """What the read found at one pose.

    Attributes:
        hidden: (2, C) bool per image (left, right) and texture cell: behind a plain occluder.
        colours: per image the b, g, r of each occluder region found (gain-corrected).
        agreeing: (2, C) bool per image and cell: compared and agreeing (the print in view).
    """

    hidden: npt.NDArray[np.bool_]
    colours: tuple[tuple[FloatArray, ...], tuple[FloatArray, ...]]
    agreeing: npt.NDArray[np.bool_]

    @property
    def any(self) -> bool:
        return bool(self.hidden.any())


def read_occluders(
    statistics: CellStatistics,
    looks: tuple[OutlineLooks, OutlineLooks],
    neighbours: list[npt.NDArray[np.int64]],
    *,
    agree_level: float,
    plain: float,
    chroma_tolerance: float,
    brightness_tolerance: float,
    min_pairs: int,
    continued: float,
) -> OccluderRead:
    """The occluder regions of each image (module docstring).

    Args:
        statistics: the cells at the pose (`cell_statistics`).
        looks: the outline pairs in each image at the pose.
        neighbours: per cell the cells touching it (`CellGrid.neighbours`).
        agree_level: a cell agrees from this score.
        plain: a cell's image is plain up to this RMS deviation [grey levels].
        chroma_tolerance, brightness_tolerance: one colour (`same_colour`).
        min_pairs: a region needs this many outline pairs that show its colour on both points.
        continued: ... and this share of its pairs in view.
    """
    n_cells = statistics.scores.shape[1]
    hidden = np.zeros((SIDES, n_cells), dtype=bool)
    colours: list[list[FloatArray]] = [[], []]
    for side in range(SIDES):
        s = statistics
        candidate = (s.weights[side] > 0) & (s.scores[side] < agree_level) & (s.image_rms[side] <= plain)
        if not candidate.any():
            continue
        mean = s.image_mean[side]
        region = np.full(n_cells, -1, dtype=np.int64)
        regions = 0
        for start in np.flatnonzero(candidate):
            if region[start] >= 0:
                continue
            region[start] = regions
            stack = [int(start)]
            while stack:
                c = stack.pop()
                for d in neighbours[c]:
                    if (
                        candidate[d]
                        and region[d] < 0
                        and bool(same_colour(mean[c], mean[d], chroma_tolerance, brightness_tolerance))
                    ):
                        region[d] = regions
                        stack.append(int(d))
            regions += 1
        look = looks[side]
        cells = look.inner_cells
        owner = np.where(cells >= 0, region[np.maximum(cells, 0)], -1)
        for r in range(regions):
            members = region == r
            weights = s.weights[side][members]
            colour = (mean[members] * weights[:, None]).sum(axis=0) / max(float(weights.sum()), 1e-9)
            pairs = (owner == r) & look.in_view
            if pairs.sum() < min_pairs:
                continue
            shows = (
                same_colour(look.inner[pairs], colour, chroma_tolerance, brightness_tolerance)
                & same_colour(look.outer[pairs], colour, chroma_tolerance, brightness_tolerance)
                & ~look.outer_on_sheet[pairs]
            )
            if shows.sum() >= min_pairs and shows.mean() >= continued:
                hidden[side, members] = True
                colours[side].append(colour)
    agreeing = (statistics.weights > 0) & (statistics.scores >= agree_level)
    return OccluderRead(hidden, (tuple(colours[0]), tuple(colours[1])), agreeing)


__all__ = [
    "CellGrid",
    "CellStatistics",
    "OccluderRead",
    "OutlineLooks",
    "cell_statistics",
    "read_occluders",
    "same_colour",
]
