"""A blind lift named by its weight after cloths of one box (`weighed_as`) is doubted
for the cloths of another box that would weigh as much in their stead
(`table_lost.weighs_instead`): held-out episode 304, session 26."""

from __future__ import annotations

from types import SimpleNamespace

from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.table_lost import weighs_instead

WEIGHTS = {"No.18": 0.0209, "No.17": 0.0201, "No.9": 0.0162, "No.4": 0.0160, "No.2": 0.0163, "No.7": 0.060}
BOXES = {
    "No.18": "whites",
    "No.17": "whites",
    "No.4": "whites",
    "No.9": "colours",
    "No.2": "colours",
    "No.7": "colours",
}


def _job(lost=(), last_survey=None, placed=(), surveys=5) -> SimpleNamespace:
    ledger = SimpleNamespace(
        placed_order=list(placed),
        surveys=[None] * surveys,
        last_survey=dict(last_survey or {}),
        lost=dict.fromkeys(lost),
    )
    return SimpleNamespace(
        ledger=ledger,
        weights=WEIGHTS,
        recognizers=dict.fromkeys(WEIGHTS),
        sort=SimpleNamespace(box_for=BOXES.__getitem__),
        settings=ClearTableSettings(),
    )


def test_a_lost_cloth_of_the_other_box_that_weighs_as_much_as_one_of_the_lift_is_named() -> None:
    # No.18 and No.17 read 41 g; No.9 (colours, lost) with No.17 weighs as much
    job = _job(lost=("No.18", "No.9", "No.4"))
    assert weighs_instead(job, "whites", ("No.18", "No.17"), 0.0410) == ("No.9",)
    # a cloth of the same box (No.4) goes there anyway; one too heavy (No.7) could not be it
    assert weighs_instead(_job(lost=("No.7",)), "whites", ("No.18", "No.17"), 0.0410) == ()
    # a single cloth named by its weight, and a hidden one (seen by an earlier survey only)
    job = _job(last_survey={"No.2": 3, "No.9": 5})
    assert weighs_instead(job, "whites", ("No.17",), 0.0170) == ("No.2",)


def test_placed_cloths_and_cloths_the_last_survey_saw_are_not_doubted() -> None:
    assert weighs_instead(_job(lost=("No.9",), placed=("No.9",)), "whites", ("No.18", "No.17"), 0.041) == ()
    seen_now = _job(last_survey={"No.9": 5})  # the fifth survey is the last one: No.9 lies in view
    assert weighs_instead(seen_now, "whites", ("No.18", "No.17"), 0.041) == ()
    # a reading that no swap explains names nobody
    assert weighs_instead(_job(lost=("No.9",)), "whites", ("No.18", "No.17"), 0.080) == ()
