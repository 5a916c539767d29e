"""The clear-table job's waits: the arm may move while the computer recognises, and the
job goes on no earlier than the recognition is done (`TableClearer._wait`)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_clearer import TableClearer

DT = 1.0 / 240.0


def _job(latency: float) -> tuple[TableClearer, SimpleNamespace]:
    cell = SimpleNamespace(time=0.0)

    def hold(seconds: float) -> None:
        cell.time += round(seconds / DT) * DT

    job = TableClearer.__new__(TableClearer)
    job.settings = ClearTableSettings(survey_latency=None)
    job.loop_settings = LoopSettings(vision_latency=latency)
    job.cell = cell  # type: ignore[assignment]
    job.motion = SimpleNamespace(hold=hold)  # type: ignore[assignment]
    return job, cell


@pytest.mark.parametrize(("trip", "expected"), [(0.5, 1.2), (3.0, 3.0), (0.0, 1.2)])
def test_moves_made_while_recognising_count_toward_the_recognition_time(trip: float, expected: float) -> None:
    job, cell = _job(latency=0.06)
    moved: list[float] = []

    def look_at_boxes() -> None:
        moved.append(cell.time)
        cell.time += trip

    job._wait(0.0, 20, look_at_boxes)  # 20 recognitions of 0.06 s
    assert moved == [0.0]  # the moves start with the recognition, not after it
    assert cell.time == pytest.approx(expected, abs=DT)


def test_without_moves_the_job_holds_for_the_recognitions() -> None:
    job, cell = _job(latency=0.06)
    job._wait(5.0, 10)
    assert cell.time == pytest.approx(0.6, abs=DT)
    job, cell = _job(latency=None)  # type: ignore[arg-type]
    job._wait(0.25, 10)  # the measured CPU time
    assert cell.time == pytest.approx(0.25, abs=DT)
