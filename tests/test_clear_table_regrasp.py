"""A blind grasp whose fingers close on nothing goes lower and closes again
(`table_lost.close_lowering`), down to `clear.lost.grasp_height` and at most
`clear.lost.regrasps` times."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from robot_app.control.clear_table_records import ClearTableSettings
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.table_lost import close_lowering


class _Hand:
    """A TCP over a cloth whose top lies at `cloth_z`: the fingers hold it when they close
    within `reach` over it (a plain height test, as the simulated grasp's radius)."""

    def __init__(self, cloth_z: float, reach: float = 0.035) -> None:
        self.cloth_z, self.reach, self.z = cloth_z, reach, None
        self.closings: list[float] = []
        self.released = 0

    def move_tcp(self, point, speed: float = 1.0) -> None:
        self.z = float(point[2])

    def hold(self, seconds: float) -> None:
        pass

    def set_gripper(self, opening: float) -> None:
        pass

    def grasp(self) -> int:
        self.closings.append(self.z)
        return 3 if self.z - self.cloth_z <= self.reach else 0

    def release(self) -> None:
        self.released += 1


def _job(hand: _Hand, **lost) -> SimpleNamespace:
    settings = ClearTableSettings.model_validate({"lost": lost})
    loop = LoopSettings()
    return SimpleNamespace(settings=settings, loop_settings=loop, table_z=0.0, cell=hand, motion=hand)


def test_fingers_closing_on_nothing_go_lower_until_they_hold() -> None:
    hand = _Hand(cloth_z=0.040)  # the heap's top measured at 76 mm, the cloth at 40 mm
    hand.z = 0.098
    notes: list[str] = []
    held, closings = close_lowering(_job(hand), (0.4, 0.0), 0.098, notes)
    assert held > 0 and closings == 3
    assert hand.closings == pytest.approx([0.098, 0.086, 0.074])  # 12 mm lower each time
    assert hand.released == 2
    assert notes and "closed 3 times, lowered to 74 mm" in notes[0]


def test_lowering_stops_at_the_blind_grasp_height_and_after_the_configured_closings() -> None:
    hand = _Hand(cloth_z=-0.1)  # nothing there at all
    hand.z = 0.040
    notes: list[str] = []
    assert close_lowering(_job(hand), (0.4, 0.0), 0.040, notes) == (0, 3)
    assert hand.closings == pytest.approx([0.040, 0.028, 0.025])  # never under grasp_height
    assert "still nothing" in notes[0]
    hand = _Hand(cloth_z=-0.1)
    hand.z = 0.2
    close_lowering(_job(hand, regrasps=1), (0.4, 0.0), 0.2, [])
    assert hand.closings == pytest.approx([0.2, 0.188])
    # fingers that hold at once close once, and nothing is noted
    hand = _Hand(cloth_z=0.05)
    hand.z = 0.07
    notes = []
    assert close_lowering(_job(hand), (0.4, 0.0), 0.07, notes) == (3, 1)
    assert hand.closings == [0.07] and not notes
