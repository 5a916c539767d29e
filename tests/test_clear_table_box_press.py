"""Putting a cloth into its box (`clear.into_box`): pressing the box's contents down after
each release (`press_into_box`) and the release spot on the box's sides in turn
(`TableClearer.release_spot`): the hand's moves, where, the limits and bad settings."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from pydantic import ValidationError

from robot_app.control.clear_table_records import ClearTableSettings, IntoBoxSettings
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_clearer import press_into_box
from robot_app.errors import IKError


class Recorder:
    """A hand that writes down what it is told (fingers, holds, TCP moves)."""

    def __init__(self, reachable: bool = True) -> None:
        self.calls: list[tuple[str, object]] = []
        self.reachable = reachable

    def set_gripper(self, opening: float) -> None:
        self.calls.append(("gripper", opening))

    def hold(self, duration: float) -> None:
        self.calls.append(("hold", duration))

    def move_tcp(self, position: np.ndarray, speed: float = 1.0) -> None:
        if not self.reachable:
            raise IKError("out of reach")
        self.calls.append(("move", (tuple(np.round(position, 6)), speed)))


def test_the_fingers_close_before_they_press_the_box_middle_down_to_the_set_height() -> None:
    hand = Recorder()
    centre = np.array([0.30, -0.56, 0.75])
    press = IntoBoxSettings(press=True, press_height=0.05, press_speed=0.25)
    loop = LoopSettings(close_time=0.4)
    press_into_box(hand, hand, centre, press, loop)  # type: ignore[arg-type]
    assert hand.calls == [("gripper", 0.0), ("hold", 0.4), ("move", ((0.30, -0.56, 0.80), 0.25))]
    assert centre[2] == 0.75  # the box's centre is not moved


def test_a_press_out_of_reach_is_reported_with_the_fingers_closed() -> None:
    hand = Recorder(reachable=False)
    with pytest.raises(IKError):
        press_into_box(hand, hand, [0.3, -0.56, 0.75], IntoBoxSettings(), LoopSettings())  # type: ignore[arg-type]
    assert hand.calls[0] == ("gripper", 0.0)


@pytest.mark.parametrize(
    "bad",
    [
        {"press_height": 0.03},
        {"press_height": 0.2},
        {"press_speed": 0.0},
        {"press_speed": 1.5},
        {"spread": -0.01},
        {"spread": 0.08},
    ],
)
def test_a_press_into_the_floor_or_without_speed_is_rejected(bad: dict[str, float]) -> None:
    with pytest.raises(ValidationError):
        IntoBoxSettings(**bad)


def test_by_default_the_cloth_is_let_go_over_the_middle_and_not_pressed() -> None:
    settings = ClearTableSettings().into_box
    assert not settings.press and settings.spread == 0.0


def test_the_job_presses_only_when_switched_on() -> None:
    from robot_app.control.table_clearer import TableClearer

    for enabled in (True, False):
        hand = Recorder()
        job = TableClearer.__new__(TableClearer)
        job.settings = ClearTableSettings(into_box={"press": enabled})  # type: ignore[arg-type]
        job.loop_settings = LoopSettings()
        job.motion = hand  # type: ignore[assignment]
        job.cell = hand  # type: ignore[assignment]
        attempt = SimpleNamespace(box=SimpleNamespace(centre=np.array([0.3, -0.56, 0.75])), notes=[])
        assert job.press_box(attempt) is enabled  # type: ignore[arg-type]
        assert bool(hand.calls) is enabled


def test_spread_release_spots_go_round_the_sides_of_each_box_on_its_own() -> None:
    from robot_app.control.clear_table_records import BoxPlace
    from robot_app.control.table_clearer import TableClearer

    job = TableClearer.__new__(TableClearer)
    job.settings = ClearTableSettings(into_box={"spread": 0.05})  # type: ignore[arg-type]
    job._released = {}
    a = BoxPlace("a", np.array([0.3, -0.56, 0.75]), 0.22)
    b = BoxPlace("b", np.array([0.3, 0.56, 0.75]), 0.22)
    spots = []
    for box in (a, a, b, a, a, a):
        spots.append(np.round(job.release_spot(box) - box.centre, 6).tolist())
        job._released[box.name] = job._released.get(box.name, 0) + 1
    assert spots == [
        [0.0, -0.05, 0.0], [0.0, 0.05, 0.0], [0.0, -0.05, 0.0],  # box b starts at its own first side
        [-0.05, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, -0.05, 0.0],
    ]  # fmt: skip
    job.settings = ClearTableSettings()
    assert np.allclose(job.release_spot(a), a.centre)  # spread 0: the middle
