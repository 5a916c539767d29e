"""The look-then-move APPROACH hovers lower where the arm cannot reach the observation
height that far out, never so low that the cameras stop seeing the cloth (bench_clear_table
episode 32, session 19: a cloth laid back at x = 0.78 m was 10 mm out of reach at the
observation height, and left on the table)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.look_then_move import HOVER_MARGIN, HOVER_STEP, LookThenMoveStrategy
from robot_app.control.loop_settings import LoopSettings

SHOULDER = np.array([0.0, 0.0, 0.10])  # a reach sphere about the shoulder stands in for the arm's IK
REACH = 0.9  # [m]
HOVER_TCP_Z, CAMERA_ABOVE_TCP = 0.48, 0.15


class SphereArm:
    """An arm whose TCP reaches every point within `REACH` of `SHOULDER`."""

    preferred_posture = np.zeros(7)
    asked: list[float]

    def __init__(self) -> None:
        self.asked = []

    def tcp_position(self, q=None) -> np.ndarray:
        return np.array([0.55, 0.0, HOVER_TCP_Z])

    def frame_position(self, frame: str, q=None) -> np.ndarray:
        return np.array([0.55, 0.0, HOVER_TCP_Z + CAMERA_ABOVE_TCP])

    def solve_tcp(self, position) -> np.ndarray:
        p = np.asarray(position, dtype=float)
        self.asked.append(float(p[2]))
        if np.linalg.norm(p - SHOULDER) > REACH:
            raise EpisodeAbortError(Outcome.IK_UNREACHABLE, f"no IK solution for {p}")
        return np.full(7, p[2])


def test_the_hover_comes_down_only_as_far_as_the_arm_needs_and_the_cameras_allow() -> None:
    arm, settings = SphereArm(), LoopSettings()
    strategy = LookThenMoveStrategy(arm, SimpleNamespace(), settings, table_z=0.0)  # type: ignore[arg-type]
    near = np.array([0.55, 0.0, 0.01])
    target, joints = strategy._hover(near)
    assert target[2] == pytest.approx(HOVER_TCP_Z) and arm.asked == [HOVER_TCP_Z]  # in reach: unchanged
    far = np.array([0.85, 0.10, 0.01])  # out of reach at the observation height, in reach lower
    assert np.linalg.norm([0.85, 0.10, HOVER_TCP_Z] - SHOULDER) > REACH
    target, joints = strategy._hover(far)
    np.testing.assert_allclose(target[:2], far[:2])
    one_step_higher = target + np.array([0.0, 0.0, HOVER_STEP])
    assert np.linalg.norm(target - SHOULDER) <= REACH < np.linalg.norm(one_step_higher - SHOULDER)
    assert joints[0] == pytest.approx(target[2])
    camera_over_cloth = target[2] + CAMERA_ABOVE_TCP - far[2]
    assert camera_over_cloth >= settings.min_working_distance + HOVER_MARGIN
    # farther still: no height where the cameras still see the cloth is in reach
    arm.asked.clear()
    with pytest.raises(EpisodeAbortError) as raised:
        strategy._hover(np.array([0.95, 0.10, 0.01]))
    assert raised.value.outcome is Outcome.IK_UNREACHABLE
    lowest = 0.01 + settings.min_working_distance + HOVER_MARGIN - CAMERA_ABOVE_TCP
    assert min(arm.asked) >= lowest - 1e-9 and len(arm.asked) > 1
