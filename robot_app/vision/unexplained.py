"""What one compact cause cannot explain at a pose: disagreement scattered over the model.

The decision forgives a present cloth what a sheet over it or a folded corner does to the
evidence: a compact region of the model that is hidden, shows the green sheet (a corner
turned over) or disagrees with the model photo's texture (a sheet of one of the model's
own colours). What it should not forgive, which two of the identification bench's last
false accepts showed (a model accepted on another cloth that shares its hue band), is
disagreement scattered all over the model: a yellow-dots-on-cyan model on a plain cyan
cloth sees cyan at every dot, and no sheet over part of a cloth hides dots everywhere
(confidence 0.594-0.630 before, on test and calibration seeds).

`scattered` is the share of the looks at S_in points (each point in each image) that
disagree and lie outside the half-plane of the model (`DIRECTIONS` directions, up to half
of the points) that holds the most disagreeing minus agreeing looks; what that half-plane
holds wrongly (its agreeing looks) counts too. It is measured twice, by the colour each
point sees (`point_looks`) and by whether its texture cell agrees
(`Verifier.agreeing_cells`), and the smaller is kept (`Verifier.unexplained`; the colour
alone without texture): the disagreement must be scattered by both. One sheet or one
fold: close to 0; the dots model on plain cyan: 0.23 by colour, 0.35 by texture. By colour
alone a sheet of one of a print's own colours matches some of its points, which splits
its region (a covered astronaut print 0.22; by texture 0.02); by texture alone a plain
cloth under a strong colour cast (a flat yellow square, 0.35, found 0.625 -> 0.001 on the
full run) or a fine print seen a few millimetres off disagrees in cells all over it,
while its colours match (by colour about 0).

It is measured once, at the pose the recogniser reports (`Recognizer._result`, one-shot
and check) where the decision weighs it (`DecisionSettings.weight_scattered`: 0 by
default, measured and not adopted, see `decide.py`); it does not
rank a pose's alternatives (`decide.ranking`), so the recognised poses are those without
it. Tried and not kept: a missing part that is no fold (the sheet beyond a line whose
mirror image the texture agrees with, where a fold's flap would disagree), which the
calibration gave no weight (-0.57 against scattered's -11.75; README).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.vision.hue import colours_match

DIRECTIONS = 24  # half-plane directions tried, 15° apart
MAX_SHARE = 0.5  # a half-plane holds at most this share of the S_in points


@dataclass(frozen=True)
class PointLooks:
    """Per S_in point, in how many of the two images (0-2) it sees each kind of colour.

    Attributes:
        match: its own colour (within the hue threshold, or the same tone).
        sheet: the sheet's hue.
        other: another colour that is not foreign (one of the model's other colours).
        hidden: a foreign colour (an occluder or another cloth's colours; also off the image).
    """

    match: FloatArray
    sheet: FloatArray
    other: FloatArray
    hidden: FloatArray


@dataclass(frozen=True)
class Unexplained:
    """What one compact cause does not explain at a pose (see the module docstring).

    Attributes:
        scattered: share of the looks that disagree outside the best half-plane [0-1].
    """

    scattered: float = 0.0


def point_looks(
    codes: npt.NDArray[np.int64],
    model_codes: npt.ArrayLike,
    foreign: npt.NDArray[np.bool_],
    sheet: npt.NDArray[np.bool_],
    hue_threshold: int,
) -> PointLooks:
    """What each S_in point sees in the two images.

    Args:
        codes: (2, N) the pixel code under each point in each image
            (`FitnessEvaluator.point_codes`; `OFF_IMAGE` counts as hidden).
        model_codes: (N,) each point's own colour code.
        foreign: (259,) per pixel code: hidden (`fitness_scores.foreign_codes`).
        sheet: (259,) per pixel code: the sheet's hue.
        hue_threshold: hue difference within which two hues match [HSV_FULL steps].
    """
    codes = np.asarray(codes, dtype=np.int64)
    hidden = foreign[codes]
    on_sheet = ~hidden & sheet[codes]
    own = np.asarray(model_codes, dtype=np.int64)[None, :]
    match = ~hidden & ~on_sheet & colours_match(codes, own, hue_threshold)
    other = ~hidden & ~on_sheet & ~match
    return PointLooks(*(a.sum(axis=0).astype(float) for a in (match, on_sheet, other, hidden)))


class DisagreementShape:
    """The half-planes of one model's S_in points, ordered once (`unexplained` per pose).

    Args:
        points: (N, 2+) the S_in points in Σ_M [m].
    """

    def __init__(self, points: FloatArray) -> None:
        xy = np.asarray(points, dtype=float)[:, :2]
        angles = np.arange(DIRECTIONS) * (2.0 * np.pi / DIRECTIONS)
        directions = np.column_stack([np.cos(angles), np.sin(angles)])
        along = xy @ directions.T  # (N, D)
        self._order = np.argsort(-along, axis=0).T  # (D, N), farthest first
        self._high = max(int(MAX_SHARE * len(xy)), 1)

    def _best(self, gain: FloatArray) -> tuple[float, int, int]:
        """(excess, direction, count): the half-plane holding the most `gain` (of the S_in points)."""
        sums = np.cumsum(gain[self._order[:, : self._high]], axis=1)
        flat = int(np.argmax(sums))
        d, k = divmod(flat, self._high)
        return float(sums[d, k]), d, k + 1

    def unexplained(
        self, looks: PointLooks, texture: tuple[FloatArray, FloatArray] | None = None
    ) -> Unexplained:
        """`Unexplained` of one pose.

        Args:
            looks: what each S_in point sees (`point_looks`).
            texture: (N,) agreeing and (N,) disagreeing looks per S_in point by its texture
                cell (0-2 each); `scattered` is taken from them if given, else from the
                colours of `looks`.
        """
        agree, disagree = (looks.match, looks.sheet + looks.other) if texture is None else texture
        looked = float(np.sum(agree + disagree))
        if looked <= 0.0:
            return Unexplained()
        excess, _, _ = self._best(np.asarray(disagree, dtype=float) - agree)
        return Unexplained((float(np.sum(disagree)) - max(excess, 0.0)) / looked)


__all__ = ["DIRECTIONS", "DisagreementShape", "PointLooks", "Unexplained", "point_looks"]
