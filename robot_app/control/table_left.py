"""What the clear-table job leaves: at its end, the evidence on every unknown region still
on the table, booked on the known cloths not placed whose colours it shows (`left_notes`).

A failed episode says which cloth stayed and what its last attempt did; it did not say
whether the cloth still lay in view, as which region, and what kept the lost-cloth rules
(`table_lost`) from it. A replay cannot tell afterwards: the arm holds for measured
computation times, so a rerun takes another course after a few attempts (held-out 807 and
810, session 34). These notes are the evidence, not the rules' verdict: the rules' gates
are named where the evidence alone closes them (lost far from there, no attempts left,
blind grasps closed on nothing there, never booked lost).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.cell import StereoCapture
from robot_app.control.clear_table_records import LostPlace, LostSettings
from robot_app.control.colour_fit import colour_shares
from robot_app.control.table_lost import near_the_loss
from robot_app.vision import Recognizer
from robot_app.vision.identify import UnknownRegion

RIVALS = 3  # the best fits named beside a cloth's own


def left_notes(
    capture: StereoCapture,
    regions: Sequence[UnknownRegion],
    centres: Sequence[FloatArray],
    candidates: Mapping[str, Recognizer],
    lost: Mapping[str, LostPlace],
    settings: LostSettings,
    untried: Callable[[str], bool],
    grasped_empty: Callable[[FloatArray], bool],
    seen_by: str = "left at the end",
) -> dict[str, list[str]]:
    """Per known cloth not placed (`candidates`), a note on each unknown region (`regions`
    of the survey taken as `capture`, centred at `centres` on the table [m]) that shows
    `settings.min_share` of its main colours at its lightness, as the lost-cloth rules
    gate a region: where, how large, its colour fit and the best others', and the gates
    the evidence closes (`lost`: where each cloth booked lost was lost; `untried`: it has
    attempts left; `grasped_empty`: blind grasps closed on nothing at a centre); `seen_by`
    opens each note (which survey saw the region)."""
    notes: dict[str, list[str]] = {}
    if not candidates:
        return notes
    for region, centre in zip(regions, centres, strict=True):
        fits = colour_shares(capture, region.mask, candidates)
        ranked = sorted(fits.items(), key=lambda item: -item[1].score)
        x, y = (float(v) for v in np.asarray(centre, dtype=float).reshape(2))
        for name, fit in ranked:
            if fit.share * fit.lightness < settings.min_share:
                continue
            gates = []
            place = lost.get(name)
            if place is None:
                gates.append("not booked lost")
            elif not near_the_loss(centre, place, settings):
                gates.append(f"lost far from there ({place.how})")
            if not untried(name):
                gates.append("no attempts left")
            if grasped_empty(centre):
                gates.append("blind grasps closed on nothing there")
            others = ", ".join(f"{o} {f.score:.2f}" for o, f in ranked[: RIVALS + 1] if o != name)
            notes.setdefault(name, []).append(
                f"{seen_by}: an unknown region at ({x:.2f}, {y:.2f}), {region.area} px, "
                f"{fit.share:.0%} in its colours (fit {fit.score:.2f}; {others or 'no other'})"
                + (f": {', '.join(gates)}" if gates else "")
            )
    return notes


__all__ = ["left_notes"]
