"""Foreseeing, before DESCEND moves down, that the belt carries the cloth out of the arm's reach.

A fast belt heading toward the robot's base takes the cloth where the PA10, its hand
pointing down, cannot get low: the descent used to end in an IK failure halfway down
(bench_conveyor, 100 mm/s). `leaves_reach` checks the predicted grasp point (straight on
at the filter's velocity) at the grasp height every `REACH_STEP` from now until the hand
would be down, each IK seeded with the previous, and says where and when it leaves.
"""

from __future__ import annotations

import numpy as np

from robot_app.control.arm_motion import ArmMotion
from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.height_profile import tcp_height
from robot_app.control.intercept import GraspPath
from robot_app.control.loop_settings import LoopSettings

REACH_STEP = 0.1  # [s] between the predicted grasp points DESCEND checks for reach before it starts


def leaves_reach(
    arm: ArmMotion, path: GraspPath, down: float, table_z: float, settings: LoopSettings
) -> str | None:
    """Why the hand cannot be down on the moving grasp point by time `down` [s], or None.

    Args:
        arm: the commanded arm (its IK, seeded from the command).
        path: the grasp point's predicted track.
        down: when the hand would be down at the grasp height [s] (cell time).
        table_z: height of the belt's top [m].
        settings: the loop's settings (grasp height, clearance above the belt).
    """
    now = arm.cell.time
    seed = arm.command.q
    for t in [*np.arange(now, down, REACH_STEP), down]:
        point = path.at(float(t))
        z = tcp_height(point[2], settings.grasp_height, table_z, settings.min_table_clearance)
        try:
            seed = arm.solve_tcp([point[0], point[1], z], seed)
        except EpisodeAbortError as abort:
            if abort.outcome is not Outcome.IK_UNREACHABLE:
                raise
            return (
                f"the cloth, moving at {path.speed * 1e3:.0f} mm/s, leaves the arm's reach at the grasp "
                f"height (x={point[0]:.2f}, y={point[1]:.2f} m) {t - now:.2f} s from now, before the "
                f"hand could be down on it ({down - now:.2f} s)"
            )
    return None


__all__ = ["REACH_STEP", "leaves_reach"]
