"""DESCEND's doubt rule: the blind segment starts only on a prediction the views confirm.

On the way down each recognition either confirms the filter's prediction (fused near it,
or relocating it), doubts it, or neither. It doubts it when the filter's gates reject it,
when it is fused `DOUBT_DISTANCE` or farther from the prediction (an untrusted view,
fused with little weight, of a cloth pushed aside), or when it is poor where the cloth
should be *and* turned poor at once (its fitness below `FITNESS_DROP` of the previous
view's: the cloth pushed out of the tracker's window, which stays where it was), or a
doubt run is on. Poor views standing since before (a cloth whose close view scores low,
bench episode 10 at 100 mm/s) or drifting across `min_fitness` (the occluded cloth of
test_pick_place) neither confirm nor doubt, nor does a look-alike (a tracking result far
from the prediction whose frame the prediction explains as well: the tracker slid onto the
blue paper over a blue cloth, `look_alike`). A frame exposed closer than the working
distance (not fused, `UpdateReason.TOO_CLOSE`) is not a view at all: it changes nothing.

The servo holds the hand `HOLD_MARGIN` above the blind height, and the TCP at least
`HOLD_CLEARANCE` above the cloth (cameras that see down to the grasp height would
otherwise hold the fingertips on a cloth they may be dragging), while a doubt stands and
goes on down when a view confirms; `DOUBTED_VIEWS` in a row end DESCEND as lost (the loop
looks again) instead of grasping where the cloth was.
"""

from __future__ import annotations

import enum

from robot_app.control.pose_filter import FilterUpdate, UpdateReason

HOLD_MARGIN = 0.01  # [m] above the height where the cameras go blind, DESCEND holds on a doubted view
HOLD_CLEARANCE = 0.05  # [m] TCP above the cloth at least while a doubt stands: fingertips 4 cm clear
DOUBT_DISTANCE = 0.012  # [m] a fused view this far from the prediction doubts it (3 sigma of a normal one)
FITNESS_DROP = 0.5  # a poor view below this share of the previous view's fitness turned poor at once
DOUBTED_VIEWS = 3  # recognitions in a row not fused on the way down: the cloth is not where predicted
NEUTRAL = (UpdateReason.LOW_FITNESS_CONSISTENT, UpdateReason.LOOK_ALIKE)  # doubt only in a doubt run


class Verdict(enum.Enum):
    """What one recognition did to the descent."""

    NONE = "none"  # neither confirmed nor doubted, or confirmed with no doubt standing
    DOUBTED = "doubted"  # a doubt (the first of a run, or one more)
    CLEARED = "cleared"  # confirmed while a doubt stood: the descent goes on


class DescentDoubt:
    """The doubt run of one DESCEND.

    Args:
        previous_fitness: the fitness of the last recognition before DESCEND [-].
    """

    def __init__(self, previous_fitness: float) -> None:
        self.doubted = 0
        self.previous_fitness = float(previous_fitness)

    @property
    def standing(self) -> bool:
        """A doubt stands: the hand must not go blind."""
        return self.doubted > 0

    @property
    def lost(self) -> bool:
        """`DOUBTED_VIEWS` doubts in a row: the cloth is not where predicted."""
        return self.doubted >= DOUBTED_VIEWS

    def judge(self, update: FilterUpdate, fitness: float) -> Verdict:
        """The verdict on one recognition (the filter's `update` of it, its `fitness` [-])."""
        if update.reason is UpdateReason.TOO_CLOSE:
            return Verdict.NONE
        turned_poor = self.doubted > 0 or fitness < FITNESS_DROP * self.previous_fitness
        self.previous_fitness = float(fitness)
        if confirms(update):
            cleared = self.doubted > 0
            self.doubted = 0
            return Verdict.CLEARED if cleared else Verdict.NONE
        if doubts(update, turned_poor=turned_poor):
            self.doubted += 1
            return Verdict.DOUBTED
        return Verdict.NONE


def confirms(update: FilterUpdate) -> bool:
    """True if a recognition confirms the prediction: fused, and near it or relocating it."""
    if not update.accepted:
        return False
    return update.reason is UpdateReason.RELOCATED or not update.distance >= DOUBT_DISTANCE


def doubts(update: FilterUpdate, *, turned_poor: bool) -> bool:
    """True if a recognition that does not confirm the prediction doubts it: rejected by a
    gate, fused far from it, or, if it `turned_poor`, poor where the cloth should be or a
    look-alike (the prediction fits its frame as well: `ClothTracker`)."""
    if confirms(update):
        return False
    return update.reason not in NEUTRAL or turned_poor


__all__ = [
    "DOUBTED_VIEWS",
    "DOUBT_DISTANCE",
    "FITNESS_DROP",
    "HOLD_CLEARANCE",
    "HOLD_MARGIN",
    "DescentDoubt",
    "Verdict",
]
