"""The transfer of what a lift holds to its box (`pick_place.carry_over_box`): a double pick
placed with its other cloth hangs lower and is carried higher, risen straight up first."""

from __future__ import annotations

import numpy as np
import pytest

from robot_app.control.loop_settings import LoopSettings
from robot_app.control.pick_place import carry_over_box
from robot_app.errors import IKError

BOX = np.array([0.3, -0.56, 0.0])
TCP = np.array([0.7, -0.15, 0.4])


class Motion:
    """Records the TCP targets solved and the moves made; no solution above `highest` [m]."""

    def __init__(self, highest: float = 10.0) -> None:
        self.highest = highest
        self.moves: list[np.ndarray] = []

    def solve_tcp(self, position) -> np.ndarray:
        position = np.asarray(position, dtype=float)
        if position[2] > self.highest + 1e-9:
            raise IKError(f"no solution at {position}")
        return position.copy()  # the "joints" are the TCP target here

    def move_to_joints(self, q_goal, speed: float = 1.0) -> None:
        self.moves.append(np.asarray(q_goal, dtype=float))


def test_one_cloth_goes_straight_over_the_box_at_the_transfer_height() -> None:
    motion, s = Motion(), LoopSettings()
    carry_over_box(motion, BOX, 0.0, s, 0.0, TCP)  # type: ignore[arg-type]
    assert len(motion.moves) == 1
    np.testing.assert_allclose(motion.moves[0], [0.3, -0.56, s.transfer_height])


def test_a_heap_rises_first_and_is_carried_as_much_higher_as_it_hangs_lower() -> None:
    motion, s = Motion(), LoopSettings()
    carry_over_box(motion, BOX, 0.0, s, 0.2, TCP)  # type: ignore[arg-type]
    up, over = motion.moves
    np.testing.assert_allclose(up, [0.7, -0.15, s.transfer_height + 0.2])  # straight up first
    np.testing.assert_allclose(over, [0.3, -0.56, s.transfer_height + 0.2])


def test_a_heap_too_high_to_reach_is_carried_as_high_as_the_arm_reaches() -> None:
    s = LoopSettings()
    motion = Motion(highest=s.transfer_height + 0.12)
    carry_over_box(motion, BOX, 0.0, s, 0.2, TCP)  # type: ignore[arg-type]
    assert motion.moves[-1][2] == pytest.approx(s.transfer_height + 0.1)  # 0.2 less two steps of 5 cm
    motion = Motion(highest=s.transfer_height - 0.01)
    with pytest.raises(IKError):  # not even one cloth's height: as before, the caller's abort
        carry_over_box(motion, BOX, 0.0, s, 0.2, TCP)  # type: ignore[arg-type]


def test_what_the_load_cell_no_longer_reads_over_the_box_fell_on_the_way() -> None:
    # held-out episode 475 (session 29): No.17 came up with No.6 (50 g) and fell back onto the
    # table as the hand rose; the job booked it placed
    from robot_app.control.clear_table_records import ClearTableSettings
    from robot_app.control.pick_checks import fell_on_the_way

    s = ClearTableSettings()
    along = {"No.17": 0.024, "No.11": 0.028}
    assert fell_on_the_way(0.075, 0.022, along, s) == ()  # all three still carried
    assert fell_on_the_way(0.022, 0.022, along, s) == ("No.17", "No.11")  # the meant cloth alone
    assert fell_on_the_way(0.051, 0.022, along, s) == ("No.17",)  # 22 + 28 g: No.17 fell
    assert fell_on_the_way(0.046, 0.022, {"No.17": 0.024}, s) == ()
    assert fell_on_the_way(0.012, 0.022, {"No.17": 0.024}, s) == ("No.17",)  # less than any: not sure
    # more than all of them (replay of held-out 540, session 30: another cloth hung there too)
    assert fell_on_the_way(0.071, 0.0275, {"No.4": 0.0224}, s) == ()
    assert fell_on_the_way(0.200, 0.022, {"No.17": 0.024}, s) == ()
    assert fell_on_the_way(0.046, 0.022, {"No.17": None}, s) == ("No.17",)  # weight unknown: not sure
