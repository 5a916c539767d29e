"""Arm motions between pick-and-place episodes: the jerk-limited moves a job makes itself.

A job that runs `PickPlaceLoop` once per cloth also moves the arm on its own: it holds
still while it looks, lowers a cloth it should not have lifted back onto the table, goes
to another observation pose. `JobMotion` does that with the loop's means (ruckig
point-to-point plans within `JointLimits`, Pinocchio IK with the cameras looking
straight down, one command per control period, contact checks), starting from the last
commanded state of the cell (a `LoggedCell`), so the hand-over to and from the loop is
seamless; every motion ends at rest.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits
from robot_app.control.logged_cell import LoggedCell
from robot_app.control.trajectory import plan_point_to_point
from robot_app.errors import IKError
from robot_app.geometry import make_transform

StepCallback = Callable[[], None]


class JobMotion:
    """Moves the arm of a `LoggedCell` between episodes (inside one, the loop's `ArmMotion` does).

    Args:
        cell: the logged cell (its last command is where motions start).
        kinematics: the arm with its `tcp` frame.
        limits: joint limits of every commanded sample.
        observation_joints: the observation pose [rad]; its hand orientation is kept.
        on_step: called after every control step (video frames, stop requests).
        ik_time_budget: per IK solve [s]; ik_tolerance: [m] and [rad].
        collision_check_period: [s] between contact checks.
    """

    def __init__(
        self,
        cell: LoggedCell,
        kinematics: Kinematics,
        limits: JointLimits,
        observation_joints: npt.ArrayLike,
        *,
        on_step: StepCallback | None = None,
        ik_time_budget: float = 0.1,
        ik_tolerance: float = 1e-4,
        collision_check_period: float = 0.05,
    ) -> None:
        self.cell = cell
        self.kinematics = kinematics
        self.limits = limits
        self.observation_joints = np.array(observation_joints, dtype=float)
        self.tcp_rotation = kinematics.frame_pose(self.observation_joints, "tcp")[:3, :3].copy()
        self.on_step = on_step
        self.ik_time_budget = ik_time_budget
        self.ik_tolerance = ik_tolerance
        self.collision_check_period = collision_check_period
        self.collisions = 0
        self._next_check = cell.time

    @property
    def q(self) -> FloatArray:
        """Where motions start: the last commanded joints (measured before any command)."""
        last = self.cell.last_command
        return last if last is not None else np.array(self.cell.joint_positions(), dtype=float)

    def tcp_position(self, q: npt.ArrayLike | None = None) -> FloatArray:
        """TCP position [m] in Σ_W at `q` (default: the last command)."""
        return self.kinematics.frame_pose(self.q if q is None else np.asarray(q, dtype=float), "tcp")[
            :3, 3
        ].copy()

    def solve_tcp(self, position: npt.ArrayLike) -> FloatArray:
        """Joints putting the TCP at `position` [m] with the observation pose's orientation.

        Raises:
            IKError: no solution within the joint limits.
        """
        target = make_transform(self.tcp_rotation, np.asarray(position, dtype=float))
        result = None
        for budget in (self.ik_time_budget, 5 * self.ik_time_budget):
            result = self.kinematics.solve_ik(
                target,
                self.q,
                frame="tcp",
                time_budget=budget,
                position_tolerance=self.ik_tolerance,
                orientation_tolerance=self.ik_tolerance,
                preferred_posture=self.observation_joints,
            )
            if result.success and self.limits.contains(result.q):
                return np.array(result.q, dtype=float)
        where = ", ".join(f"{v:.3f}" for v in np.asarray(position, dtype=float))
        residual = float("nan") if result is None else result.position_error * 1e3
        raise IKError(
            f"no IK solution within the joint limits for the TCP at ({where}) m: residual {residual:.1f} mm"
        )

    def move_to_joints(self, q_goal: npt.ArrayLike, speed: float = 1.0) -> None:
        """Jerk-limited move from rest to rest at `q_goal` [rad], limits scaled by `speed` (0, 1]."""
        limits = self.limits if speed >= 1.0 else self.limits.scaled(speed)
        start = self.q
        trajectory = plan_point_to_point(start, np.asarray(q_goal, dtype=float), limits, dt=self.cell.dt)
        steps = round(trajectory.duration / self.cell.dt)
        for k in range(1, steps + 1):
            sample = trajectory.sample(k * self.cell.dt)
            self._send(sample.q, sample.v)

    def move_tcp(self, position: npt.ArrayLike, speed: float = 1.0) -> None:
        """Moves the TCP to `position` [m] (cameras looking down)."""
        self.move_to_joints(self.solve_tcp(position), speed)

    def hold(self, duration: float) -> None:
        """Holds the last command for `duration` [s] (rounded to control periods)."""
        q = self.q
        for _ in range(max(0, round(duration / self.cell.dt))):
            self._send(q, np.zeros_like(q))

    def _send(self, q: FloatArray, v: FloatArray) -> None:
        self.cell.command_joints(q, v)
        self.cell.step()
        if self.cell.time >= self._next_check:
            self._next_check += self.collision_check_period
            self.collisions += self.cell.collisions()
        if self.on_step is not None:
            self.on_step()


__all__ = ["JobMotion"]
