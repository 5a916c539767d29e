"""Which boxes the clear-table job looks into for their reference view, and when
(`clear.look_at_boxes`, `clear.boxes_when_needed`; `TableClearer._first_boxes`,
`TableClearer.look_into_box`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control import table_clearer
from robot_app.control.box_check import BoxCheckSettings, BoxView
from robot_app.control.clear_table_records import BoxPlace, ClearTableSettings
from robot_app.control.sort_rule import SortSettings
from robot_app.control.table_clearer import TableClearer

OBSERVATION = np.zeros(7)


class _Motion:
    """Joints the job's moves end at; `move_tcp` is a look's pose (no IK here)."""

    def __init__(self, q: np.ndarray) -> None:
        self.q = q.copy()
        self.looked_at: list[tuple[float, float]] = []

    def move_tcp(self, tcp: np.ndarray) -> None:
        self.looked_at.append((round(float(tcp[0]), 2), round(float(tcp[1]), 2)))
        self.q = np.full(7, len(self.looked_at), dtype=float)

    def move_to_joints(self, q: np.ndarray) -> None:
        self.q = np.asarray(q, dtype=float).copy()


def _job(models: list[str], monkeypatch: pytest.MonkeyPatch, **settings: bool) -> TableClearer:
    def seen(*_args: object) -> BoxView:
        return BoxView(np.zeros((8, 8, 3), np.uint8), np.ones((8, 8), bool))

    monkeypatch.setattr(table_clearer, "box_view", seen)
    monkeypatch.setattr(table_clearer, "rim_view", lambda *args: None)
    job = TableClearer.__new__(TableClearer)
    job.settings = ClearTableSettings(**settings)
    job.sort = SortSettings(default="colours", boxes={"whites": (6, 17, 18)})
    job.boxes = {
        "colours": BoxPlace("colours", np.array([0.30, -0.56, 0.0]), 0.22),
        "whites": BoxPlace("whites", np.array([0.30, 0.56, 0.0]), 0.22),
    }
    job.recognizers = dict.fromkeys(models)  # type: ignore[assignment]
    job.box_settings = BoxCheckSettings()
    job.observation_joints = OBSERVATION
    job.cell = SimpleNamespace(capture=lambda: None)  # type: ignore[assignment]
    job.motion = _Motion(np.full(7, -1.0))  # type: ignore[assignment]
    job.camera_offset = lambda: np.zeros(3)  # type: ignore[method-assign]
    job.rig = None  # type: ignore[assignment]
    job._views, job._looked_into, job._rims = dict.fromkeys(job.boxes), set(), {}
    return job


def test_the_first_look_goes_into_every_box_or_the_likeliest(monkeypatch: pytest.MonkeyPatch) -> None:
    catalogue = [f"No.{n}" for n in range(1, 21)]  # 17 of colours, 3 of whites
    assert _job(catalogue, monkeypatch)._first_boxes() == ("colours", "whites")
    assert _job(catalogue, monkeypatch, boxes_when_needed=True)._first_boxes() == ("colours",)
    # the box most of the known cloths go to, whichever it is
    assert _job(["No.3", "No.6", "No.17"], monkeypatch, boxes_when_needed=True)._first_boxes() == ("whites",)
    assert _job(["No.3", "No.6"], monkeypatch, boxes_when_needed=True)._first_boxes() == ("colours",)


def test_a_box_is_looked_into_once_before_its_first_pick_and_the_arm_returns(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    job = _job(["No.3", "No.6"], monkeypatch, boxes_when_needed=True)
    job._look_at_boxes(job._first_boxes())  # the first survey's look
    assert job.motion.looked_at == [(0.30, -0.56)]
    assert np.array_equal(job.motion.q, OBSERVATION)
    assert job._views["whites"] is None
    job.look_into_box("colours")  # looked into already: no move
    assert job.motion.looked_at == [(0.30, -0.56)]
    job.motion.q = np.full(7, 0.5)  # where a look around left the arm
    job.look_into_box("whites")
    assert job.motion.looked_at == [(0.30, -0.56), (0.30, 0.56)]
    assert np.array_equal(job.motion.q, np.full(7, 0.5))  # back where it was
    assert job._views["whites"] is not None
    job.look_into_box("whites")
    assert len(job.motion.looked_at) == 2


@pytest.mark.parametrize("settings", [{}, {"boxes_when_needed": True, "look_at_boxes": False}])
def test_without_the_option_no_look_is_made_before_a_pick(
    monkeypatch: pytest.MonkeyPatch, settings: dict[str, bool]
) -> None:
    job = _job(["No.3", "No.6"], monkeypatch, **settings)
    job.look_into_box("whites")
    assert job.motion.looked_at == []


def _seen(*names: str) -> SimpleNamespace:
    """A survey's identification, as far as `_boxes_ahead` reads it."""
    return SimpleNamespace(detections=[SimpleNamespace(name=n) for n in names])


def test_the_boxes_the_seen_cloths_need_are_looked_into_while_the_next_survey_computes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    job = _job(["No.3", "No.6", "No.12"], monkeypatch, boxes_when_needed=True)
    job._look_at_boxes(job._first_boxes())  # the first survey's look: colours
    assert job._boxes_ahead(_seen("No.3", "No.12")) is None  # colours looked into already
    ahead = job._boxes_ahead(_seen("No.3", "No.6"))  # No.6 goes to whites: not looked into yet
    assert ahead is not None
    job.motion.q = OBSERVATION.copy()  # the survey is taken at the observation pose
    ahead()
    assert job.motion.looked_at == [(0.30, -0.56), (0.30, 0.56)]
    assert np.array_equal(job.motion.q, OBSERVATION)  # back for the pick
    assert job._views["whites"] is not None
    assert job._boxes_ahead(_seen("No.6")) is None  # once
    job.look_into_box("whites")  # and the pick's own look is not made again
    assert len(job.motion.looked_at) == 2


def test_no_look_ahead_without_the_option(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _job(["No.3", "No.6"], monkeypatch)._boxes_ahead(_seen("No.6")) is None
    job = _job(["No.3", "No.6"], monkeypatch, boxes_when_needed=True, look_at_boxes=False)
    assert job._boxes_ahead(_seen("No.6")) is None


def test_with_straight_from_box_the_looks_stay_over_the_last_box(monkeypatch: pytest.MonkeyPatch) -> None:
    """`clear.straight_from_box`: the reference looks end over the box (the pick goes on
    from there), while without it they come back; once per box either way."""
    job = _job(["No.3", "No.6"], monkeypatch, boxes_when_needed=True, straight_from_box=True)
    job._look_at_boxes(job._first_boxes(), stay=True)  # the first survey's look: colours
    assert job.motion.looked_at == [(0.30, -0.56)]
    over_colours = job.motion.q.copy()
    assert not np.array_equal(over_colours, OBSERVATION)
    job.look_into_box("colours", stay=True)  # looked into already: no move
    assert np.array_equal(job.motion.q, over_colours)
    job.look_into_box("whites", stay=True)  # straight on from colours
    assert job.motion.looked_at == [(0.30, -0.56), (0.30, 0.56)]
    assert not np.array_equal(job.motion.q, over_colours)
    assert job._views["whites"] is not None
    ahead = job._boxes_ahead(_seen("No.6"))
    assert ahead is None  # whites looked into already
    job = _job(["No.3", "No.6"], monkeypatch, boxes_when_needed=True, straight_from_box=True)
    job._looked_into.add("colours")
    ahead = job._boxes_ahead(_seen("No.6"))
    assert ahead is not None
    job.motion.q = OBSERVATION.copy()
    ahead()
    assert job.motion.looked_at == [(0.30, 0.56)]
    assert not np.array_equal(job.motion.q, OBSERVATION)  # stays over whites for the pick
