"""The baseline strategy (`loop.strategy: look_then_move`): the wave-1 loop, kept to compare.

APPROACH servos the TCP at the observation height over the grasp point of the latest
filtered estimate (at its exposure time, not predicted) and waits there at rest (lower,
in `HOVER_STEP`s, where the arm cannot reach that far out so high, while the cameras stay
`min_working_distance` + `HOVER_MARGIN` above the cloth: bench_clear_table episode 32,
session 19, a cloth laid back at x = 0.78 m was out of reach 10 mm at the observation
height and left on the table); DESCEND is one blind move through the point
`pregrasp_height` over the grasp (without a stop: `descend_via_speed`) to the grasp
height, on the estimate at the end of APPROACH; the fingers close with the hand still and
LIFT goes straight up. It sees the same camera latency as the servo (the same
`VisionPipeline`); on a still cloth it is the loop of before, on a moving one it grasps
where the cloth was.
"""

from __future__ import annotations

import numpy as np

from robot_app.arrays import FloatArray
from robot_app.control.arm_motion import ArmMotion
from robot_app.control.cloth_tracker import ClothTracker
from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.intercept import GraspPath
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.servo import CAMERA_FRAME

HOVER_STEP = 0.03  # [m] the hover is lowered by this while the arm cannot reach it
HOVER_MARGIN = 0.1  # [m] the cameras stay this much above `min_working_distance` over the cloth


class LookThenMoveStrategy:
    """APPROACH, DESCEND, GRASP and LIFT of the look-then-move loop.

    Args:
        arm: the commanded arm.
        tracker: the cloth as the loop knows it.
        settings: the loop's settings.
        table_z: height of the table top [m].
    """

    def __init__(self, arm: ArmMotion, tracker: ClothTracker, settings: LoopSettings, table_z: float) -> None:
        self.arm = arm
        self.tracker = tracker
        self.settings = settings
        self.table_z = float(table_z)
        q = arm.preferred_posture
        self.hover_z = float(arm.tcp_position(q)[2])
        self.camera_above_tcp = float(arm.frame_position(CAMERA_FRAME, q)[2] - self.hover_z)
        self.note = ""

    def approach(self) -> bool:
        """Servos the TCP over the latest estimate's grasp point at the observation height."""
        s = self.settings
        online = self.arm.start_online()
        self.tracker.start_tracking()
        start, fused = self.arm.cell.time, 0
        target: FloatArray | None = None
        while True:
            updates = self.tracker.poll(sample_truth=True)
            if self.tracker.lost:
                self.note = f"lost after {self.tracker.filter.consecutive_rejections} rejected recognitions"
                self.arm.end_online(online, to_rest=True)
                return False
            if any(u.accepted for u in updates):
                fused += sum(u.accepted for u in updates)
                target, joints = self._hover(self._grasp_position())
                online.set_target(joints)
            self.arm.step_online(online)
            if target is not None and fused >= s.min_accepted_updates and s.approach_blend > 0:
                off = float(np.linalg.norm(self.arm.tcp_position() - target))
                if off <= s.approach_blend:
                    self.note = (
                        f"{fused} fused recognitions; on into DESCEND {off * 1e3:.0f} mm before the hover"
                    )
                    self.arm.end_online(online, to_rest=False)
                    return True
            settled = fused >= s.min_accepted_updates and online.finished
            if (
                target is not None
                and settled
                and np.linalg.norm(self.arm.tcp_position() - target) <= s.approach_tolerance
            ):
                self.note = f"{fused} fused recognitions"
                self.arm.end_online(online, to_rest=False)
                return True
            if self.arm.cell.time - start > s.approach_timeout:
                self.note = f"no stable target within {s.approach_timeout:.1f} s"
                self.arm.end_online(online, to_rest=True)
                return False

    def come_over(self) -> None:
        """Straight to the hover over the estimate's grasp point, without tracking: the
        search used a frame taken before the arm went elsewhere (the clear-table job's look
        into a box), from where the cameras need not see the cloth. The IK starts from the
        observation posture, which the loop's IK keeps near."""
        _, joints = self._hover(self._grasp_position(), seed=self.arm.preferred_posture)
        self.arm.move_to_joints(joints)

    def _hover(self, grasp: FloatArray, seed: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
        """The TCP position over `grasp` at the observation height, or lower by `HOVER_STEP`s
        where the arm cannot reach it, and its joints (the IK from `seed`, default the
        commanded joints).

        Raises:
            EpisodeAbortError: IK_UNREACHABLE, not even with the cameras
                `min_working_distance` + `HOVER_MARGIN` over the cloth.
        """
        lowest = grasp[2] + self.settings.min_working_distance + HOVER_MARGIN - self.camera_above_tcp
        target = np.array([grasp[0], grasp[1], self.hover_z])
        while True:
            try:
                return target, self.arm.solve_tcp(target, seed=seed)
            except EpisodeAbortError as err:
                if err.outcome is not Outcome.IK_UNREACHABLE or target[2] - HOVER_STEP < lowest:
                    raise
                target[2] -= HOVER_STEP

    def descend(self) -> bool:
        """One blind move down onto the estimate's grasp point, through the pregrasp point
        without a stop (`loop.descend_via_speed`)."""
        s = self.settings
        self.tracker.stop()
        grasp = self._grasp_position()
        self._grasp_xyz = grasp
        pregrasp = self.arm.solve_tcp(grasp + np.array([0.0, 0.0, s.pregrasp_height]))
        self.arm.move_through(pregrasp, self.arm.solve_tcp(grasp, seed=pregrasp), s.descend_via_speed)
        return True

    def close(self) -> None:
        """Closes the fingers with the hand still."""
        self.arm.cell.set_gripper(0.0)
        self.arm.hold(self.settings.close_time)

    def lift(self) -> None:
        """Straight up over the grasp point."""
        grasp = self._grasp_xyz
        lifted = np.array([grasp[0], grasp[1], self.table_z + self.settings.lift_height])
        self.arm.move_to_joints(self.arm.solve_tcp(lifted))

    def _grasp_position(self) -> FloatArray:
        """TCP position for grasping the latest estimate (at its exposure time, not predicted)."""
        estimate = self.tracker.filter.estimate
        if estimate is None:
            raise RuntimeError("no filtered cloth pose: search first")
        point = GraspPath.from_estimate(estimate, self.tracker.grasp_point_model).position
        s = self.settings
        z = max(point[2] + s.grasp_height, self.table_z + s.min_table_clearance)
        return np.array([point[0], point[1], z])


__all__ = ["LookThenMoveStrategy"]
