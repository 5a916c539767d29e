"""The clear-table ledger's books against what the surveys saw."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from robot_app.control.clear_table_records import ClothOutcome
from robot_app.control.table_ledger import TableLedger


def _survey(ledger: TableLedger, *names: str) -> None:
    capture = SimpleNamespace(time=float(len(ledger.surveys)), transform_right_camera_to_world=np.eye(4))
    detections = tuple(
        SimpleNamespace(name=n, confidence=0.9, transform_model_to_camera=np.eye(4)) for n in names
    )
    ident = SimpleNamespace(detections=detections, dropped=(), above=(), unknown=())
    ledger.record_survey(capture, 0.0, ident, None, SimpleNamespace())  # type: ignore[arg-type]


def test_a_cloth_booked_placed_but_seen_on_the_table_again_is_not_placed() -> None:
    # bench episode 32: a remembered companion of a double pick was booked placed with the
    # target while it still lay on the table
    ledger = TableLedger()
    _survey(ledger, "No.14", "No.19")
    ledger.placed("No.14", confirmed=True)
    ledger.seen_in_box.add("No.14")
    ledger.placed("No.19", confirmed=False)  # from memory, not seen in the box
    _survey(ledger, "No.19")  # the next survey finds it on the table
    _survey(ledger)  # and the last one no longer does (hidden, or not recognised)
    records = {r.name: r for r in ledger.cloths(None, lambda name: "colours", max_attempts=4)}
    assert records["No.14"].outcome is ClothOutcome.PLACED
    assert records["No.19"].outcome is ClothOutcome.LEFT and records["No.19"].order is None
    assert any("seen on the table by survey 2" in note for note in records["No.19"].notes)
    assert not ledger.cleared(None, False, tuple(records.values()))


def test_a_cloth_placed_again_after_it_was_found_on_the_table_counts_once() -> None:
    ledger = TableLedger()
    _survey(ledger, "No.19")
    ledger.placed("No.19", confirmed=False)
    _survey(ledger, "No.19")
    ledger.placed("No.19", confirmed=True)
    _survey(ledger)
    (record,) = ledger.cloths(None, lambda name: "colours", max_attempts=4)
    assert record.outcome is ClothOutcome.PLACED and record.order == 1
