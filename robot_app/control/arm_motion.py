"""The commanded arm: every joint sample the loop sends goes through `ArmMotion.send`.

It keeps the commanded state (positions, velocities, accelerations), sends it to the
`Cell` each control period, logs every sample for the limit check at the end, counts arm
contacts every `collision_check_period`, stops an episode past `max_episode_time`, and
solves the TCP's inverse kinematics (Pinocchio) with the hand's fixed orientation (the
cameras look straight down throughout).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import Cell
from robot_app.control.episode import EpisodeAbortError, Outcome
from robot_app.control.kinematics import Kinematics
from robot_app.control.limits import JointLimits, LimitReport, check_limits
from robot_app.control.loop_settings import LoopSettings
from robot_app.control.online_trajectory import OnlineTrajectory
from robot_app.control.trajectory import (
    JoinedTrajectory,
    JointTrajectory,
    TrajectoryPlanningError,
    TrajectorySample,
    TrajectoryTail,
    plan_point_to_point,
    plan_slowing_down,
    plan_through,
)
from robot_app.geometry import make_transform

TCP_FRAME = "tcp"


@dataclass
class Command:
    """Last commanded joint state (positions [rad], velocities [rad/s], accelerations [rad/s^2])."""

    q: FloatArray
    v: FloatArray
    a: FloatArray


class ArmMotion:
    """Jerk-limited motion of the arm through a `Cell`, with its logs.

    Args:
        cell: the robot cell.
        kinematics: arm kinematics with the `tcp` frame, poses in Σ_W.
        limits: joint limits every commanded sample must respect.
        settings: the loop's settings (IK budget and tolerance, collision period, episode time).
        tcp_rotation: (3, 3) orientation the TCP keeps in Σ_W.
        preferred_posture: joints [rad] the IK's null space pulls toward.
        after_step: called after every control step (observers; may raise InterruptError).
    """

    def __init__(
        self,
        cell: Cell,
        kinematics: Kinematics,
        limits: JointLimits,
        settings: LoopSettings,
        tcp_rotation: npt.ArrayLike,
        preferred_posture: npt.ArrayLike,
        after_step: Callable[[], None] | None = None,
    ) -> None:
        self.cell = cell
        self.kinematics = kinematics
        self.limits = limits
        self.settings = settings
        self.tcp_rotation = np.array(tcp_rotation, dtype=float).reshape(3, 3)
        self.preferred_posture = np.array(preferred_posture, dtype=float)
        self.after_step = after_step
        self.reset()

    def reset(self) -> None:
        """Starts an episode: the command is the measured arm at rest; the logs are emptied."""
        q0 = np.asarray(self.cell.joint_positions(), dtype=float)
        q0 = np.clip(q0, self.limits.lower, self.limits.upper)
        self.command = Command(q0, np.zeros(len(q0)), np.zeros(len(q0)))
        self._lowering: tuple[TrajectoryTail, FloatArray] | None = None
        self.start_time = self.cell.time
        self._next_collision_check = self.cell.time
        self.collisions = 0
        self.ruckig_times_us: list[float] = []
        self.ik_times_ms: list[float] = []
        self._times: list[float] = []
        self._Q: list[FloatArray] = []
        self._V: list[FloatArray] = []
        self._A: list[FloatArray] = []

    def resume_at(self, q: npt.ArrayLike) -> None:
        """Continues from joints `q` [rad] at rest: a phase callback moved the arm itself
        (its samples are in its own log, not in this one)."""
        q_rest = np.array(q, dtype=float)
        self.command = Command(q_rest, np.zeros(len(q_rest)), np.zeros(len(q_rest)))
        self._lowering = None

    # ------------------------------------------------------------------ kinematics
    def tcp_position(self, q: npt.ArrayLike | None = None) -> FloatArray:
        """(3,) TCP position [m] at `q` (default: the commanded joints)."""
        return self.kinematics.frame_pose(self.command.q if q is None else q, TCP_FRAME)[:3, 3]

    def tcp_velocity(self) -> FloatArray:
        """(3,) commanded TCP velocity [m/s]."""
        J = self.kinematics.frame_jacobian(self.command.q, TCP_FRAME, "local_world_aligned")
        return np.asarray(J[:3] @ self.command.v, dtype=float)

    def frame_position(self, frame: str, q: npt.ArrayLike | None = None) -> FloatArray:
        """(3,) position [m] of a kinematics frame at `q` (default: the commanded joints)."""
        return self.kinematics.frame_pose(self.command.q if q is None else q, frame)[:3, 3]

    def solve_tcp(self, position: npt.ArrayLike, seed: npt.ArrayLike | None = None) -> FloatArray:
        """Joints [rad] putting the TCP at `position` [m] with the hand's orientation.

        Raises:
            EpisodeAbortError: IK_UNREACHABLE, with the residual, if no solution within
                the joint limits is found (one retry with 5x the time budget).
        """
        s = self.settings
        target = make_transform(self.tcp_rotation, position)
        start = self.command.q if seed is None else np.asarray(seed, dtype=float)
        for budget in (s.ik_time_budget, 5 * s.ik_time_budget):
            result = self.kinematics.solve_ik(
                target,
                start,
                frame=TCP_FRAME,
                time_budget=budget,
                position_tolerance=s.ik_tolerance,
                orientation_tolerance=s.ik_tolerance,
                preferred_posture=self.preferred_posture,
            )
            self.ik_times_ms.append(result.time_s * 1e3)
            if result.success and self.limits.contains(result.q):
                return np.array(result.q)
        where = ", ".join(f"{v:.3f}" for v in np.asarray(position, dtype=float))
        raise EpisodeAbortError(
            Outcome.IK_UNREACHABLE,
            f"no IK solution within the joint limits for the TCP at ({where}) m: "
            f"residual {result.position_error * 1e3:.1f} mm, {np.rad2deg(result.orientation_error):.2f} deg",
        )

    # ------------------------------------------------------------------ motion
    def send(self, q: npt.ArrayLike, v: npt.ArrayLike, a: npt.ArrayLike) -> None:
        """Commands one joint sample for one control period, logs it, checks contacts."""
        if self.cell.time - self.start_time > self.settings.max_episode_time:
            raise EpisodeAbortError(
                Outcome.TIMEOUT, f"episode longer than {self.settings.max_episode_time:.0f} s"
            )
        self.command = Command(np.array(q, dtype=float), np.array(v, dtype=float), np.array(a, dtype=float))
        self.cell.command_joints(self.command.q, self.command.v)
        self.cell.step()
        self._times.append(self.cell.time)
        self._Q.append(self.command.q)
        self._V.append(self.command.v)
        self._A.append(self.command.a)
        if self.cell.time >= self._next_collision_check:
            self._next_collision_check += self.settings.collision_check_period
            self.collisions += self.cell.collisions()
        if self.after_step is not None:
            self.after_step()

    def hold(self, duration: float) -> None:
        """Holds the commanded joints still for `duration` [s] (an arm still moving, after
        `arrive_lowering`, is brought to rest first)."""
        if np.any(self.command.v) or np.any(self.command.a):
            self.move_to_joints(self.command.q)
        self._lowering = None
        for _ in range(round(duration / self.cell.dt)):
            self._send_still()

    def hold_until(self, time: float, while_waiting: Callable[[], None] | None = None) -> None:
        """Holds still until cell time `time` [s], calling `while_waiting` after each step."""
        while self.cell.time < time - 1e-9:
            self._send_still()
            if while_waiting is not None:
                while_waiting()

    def _send_still(self) -> None:
        zeros = np.zeros_like(self.command.q)
        self.send(self.command.q, zeros, zeros)

    def move_to_joints(self, q_goal: npt.ArrayLike, speed: float = 1.0) -> None:
        """Jerk-limited move to rest at `q_goal` [rad], the limits scaled by `speed` (0, 1]."""
        trajectory = plan_point_to_point(
            self.command.q,
            q_goal,
            self.limits if speed >= 1.0 else self.limits.scaled(speed),
            v_start=self.command.v,
            a_start=self.command.a,
            dt=self.cell.dt,
        )
        self._follow(trajectory)

    def move_through(self, q_via: npt.ArrayLike, q_goal: npt.ArrayLike, via_speed: float) -> None:
        """Jerk-limited move to rest at `q_goal` [rad] that passes `q_via` without a stop,
        the TCP then heading for the goal at about `via_speed` [m/s], and goes on along the
        straight line in joint space (`trajectory.plan_through`; 0: stops at `q_via`)."""
        via, goal = np.asarray(q_via, dtype=float), np.asarray(q_goal, dtype=float)
        metres = float(np.linalg.norm(self.tcp_position(goal) - self.tcp_position(via)))
        radians = float(np.linalg.norm(goal - via))
        joint_speed = via_speed * radians / metres if metres > 1e-9 else 0.0
        trajectory = plan_through(
            self.command.q,
            via,
            goal,
            self.limits,
            joint_speed,
            v_start=self.command.v,
            a_start=self.command.a,
            dt=self.cell.dt,
        )
        self._follow(trajectory)

    def move_slowing_down(self, q_goal: npt.ArrayLike, speed: float, below: float) -> None:
        """Jerk-limited move to rest at `q_goal` [rad] with the limits scaled by `speed` once
        the TCP is at or below the height `below` [m] (Σ_W z), at full limits above it,
        without a stop in between (`trajectory.plan_slowing_down`); after `arrive_lowering`
        into such a move to `q_goal`, the rest of that one."""
        if self._lowering is not None:
            tail, goal = self._lowering
            self._lowering = None
            if np.allclose(goal, np.asarray(q_goal, dtype=float), atol=1e-9):
                self._follow(tail)
                return
        trajectory = plan_slowing_down(
            self.command.q,
            q_goal,
            self.limits,
            self.limits.scaled(speed),
            lambda q: bool(self.tcp_position(q)[2] <= below),
            v_start=self.command.v,
            a_start=self.command.a,
            dt=self.cell.dt,
        )
        self._follow(trajectory)

    def arrive_lowering(
        self,
        q_over: npt.ArrayLike,
        q_low: npt.ArrayLike,
        speed: float,
        below: float,
        drops: tuple[float, ...],
        radius: float,
        dip: float,
    ) -> float | None:
        """Moves toward `q_over` [rad] without a stop there: arrives, moving, where the
        lowering from rest at `q_over` to `q_low` (`move_slowing_down(q_low, speed, below)`)
        has come down the first of `drops` [m] that allows it, in that lowering's state (the
        lowering is planned once for all); returns that drop; the next `move_slowing_down` to
        `q_low` goes on with the rest of it (any other move plans from the moving state).

        Only where the hand-over lies in the lowering's fast part and the arrival keeps the
        TCP no more than `dip` [m] below `q_over`'s height wherever it is more than `radius`
        [m] from `q_over`'s TCP horizontally (a hanging cloth crosses a box's wall about as
        high as after a stop: a move between two points at one height bows 1-2 mm down in
        joint space too); else nothing moves and it returns None.
        """
        dt = self.cell.dt
        over = self.tcp_position(q_over)
        lowering = plan_slowing_down(
            q_over,
            q_low,
            self.limits,
            self.limits.scaled(speed),
            lambda q: bool(self.tcp_position(q)[2] <= below),
            dt=dt,
        )
        if lowering.fast is None:
            return None
        fast_steps = round(lowering.fast.duration / dt)
        heights = [self.tcp_position(lowering.sample(k * dt).q)[2] for k in range(1, fast_steps + 1)]
        for drop in (d for d in drops if d > 0.0):
            handover = next((k for k, z in enumerate(heights, start=1) if z <= over[2] - drop), None)
            arrival = None if handover is None else self._arrival(lowering.sample(handover * dt))
            if handover is None or arrival is None or not self._keeps_height(arrival, over, radius, dip):
                continue
            self._follow(arrival, to_rest=False)
            self._lowering = (TrajectoryTail(lowering, handover * dt), np.array(q_low, dtype=float))
            return drop
        return None

    def _arrival(self, state: TrajectorySample) -> JointTrajectory | None:
        """The move from the commanded state into `state` (None: ruckig cannot plan it)."""
        try:
            return plan_point_to_point(
                self.command.q,
                state.q,
                self.limits,
                v_start=self.command.v,
                a_start=self.command.a,
                v_goal=state.v,
                a_goal=state.a,
                dt=self.cell.dt,
            )
        except TrajectoryPlanningError:
            return None

    def _keeps_height(self, move: JointTrajectory, over: FloatArray, radius: float, dip: float) -> bool:
        """Is the TCP along `move` no more than `dip` [m] below `over`'s height wherever it
        is more than `radius` [m] from `over` horizontally?"""
        for k in range(round(move.duration / self.cell.dt) + 1):
            tcp = self.tcp_position(move.sample(k * self.cell.dt).q)
            if float(np.hypot(*(tcp[:2] - over[:2]))) > radius and tcp[2] < over[2] - dip:
                return False
        return True

    def _follow(
        self, trajectory: JointTrajectory | JoinedTrajectory | TrajectoryTail, to_rest: bool = True
    ) -> None:
        """Send every control sample of `trajectory`, then hold the goal at rest (not
        `to_rest`: the last sample's state is where the next move starts)."""
        self._lowering = None
        self.ruckig_times_us.append(trajectory.calculation_time_s * 1e6)
        steps = round(trajectory.duration / self.cell.dt)
        for k in range(1, steps + 1):
            sample = trajectory.sample(k * self.cell.dt)
            self.send(sample.q, sample.v, sample.a)
        if to_rest:
            self.command.v[:] = 0.0
            self.command.a[:] = 0.0

    def start_online(self) -> OnlineTrajectory:
        """An online (replanning) trajectory from the commanded state."""
        online = OnlineTrajectory(self.limits, self.cell.dt, self.command.q)
        online.reset(self.command.q, self.command.v, self.command.a)
        return online

    def step_online(self, online: OnlineTrajectory) -> TrajectorySample:
        """One control period along `online` (after any `set_target`)."""
        sample = online.step()
        self.send(sample.q, sample.v, sample.a)
        return sample

    def end_online(self, online: OnlineTrajectory, *, to_rest: bool) -> None:
        """Keeps the online run's replan times; with `to_rest`, brings the arm to rest where
        it is heading (jerk-limited)."""
        self.ruckig_times_us.extend(t * 1e6 for t in online.calculation_times)
        if to_rest:
            self.move_to_joints(np.clip(self.command.q, self.limits.lower, self.limits.upper))

    # ------------------------------------------------------------------ logs
    @property
    def samples(self) -> int:
        return len(self._times)

    def limit_report(self) -> LimitReport:
        """Every commanded sample checked against the position, velocity, acceleration and jerk limits."""
        n, dof = len(self._times), self.limits.dof
        times = np.asarray(self._times) if n else np.zeros(0)
        Q = np.asarray(self._Q).reshape(n, dof)
        V = np.asarray(self._V).reshape(n, dof)
        A = np.asarray(self._A).reshape(n, dof)
        return check_limits(times, Q, V, A, self.limits, tol=1e-6)


__all__ = ["TCP_FRAME", "ArmMotion", "Command"]
