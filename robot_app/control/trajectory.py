"""Offline jerk-limited joint trajectories with ruckig.

`plan_point_to_point` computes one time-optimal trajectory between two states,
`plan_slowing_down` one that slows to other limits where the hand must go slowly, and
`time_optimal_duration` times a move without sampling it. Velocity, acceleration and jerk
stay within a `JointLimits`; position limits are enforced by `ruckig_input` (ruckig's
community edition ignores them): targets outside the range are rejected as invalid input,
and a trajectory whose position extrema leave the range (an overshoot from a fast start)
raises with ruckig's `ErrorPositionalLimits` code, as ruckig Pro would. The online
replanning toward a moving target is `online_trajectory.OnlineTrajectory`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import ruckig

from robot_app.arrays import FloatArray
from robot_app.control.limits import JointLimits
from robot_app.control.ruckig_input import (
    TrajectoryPlanningError,
    TrajectorySample,
    call_ruckig,
    check_extrema,
    check_period,
    frozen,
    make_input,
    set_state,
    set_target,
)


class TrajectorySamples(NamedTuple):
    """A sampled trajectory: times (K,) [s] and Q, V, A of shape (K, n)."""

    times: FloatArray
    Q: FloatArray
    V: FloatArray
    A: FloatArray


@dataclass(frozen=True)
class JointTrajectory:
    """An offline ruckig trajectory; read-only once planned.

    Attributes:
        duration: time to reach the goal [s] (a multiple of the planning period).
        calculation_time_s: wall time ruckig took to calculate it [s].
        limits: the limits it was planned with.
    """

    duration: float
    calculation_time_s: float
    limits: JointLimits
    _trajectory: ruckig.Trajectory = field(repr=False)

    def sample(self, t: float) -> TrajectorySample:
        """State at time `t` [s], clamped into [0, duration] (the goal is held after)."""
        if not np.isfinite(t):
            raise ValueError(f"sample time must be finite, got {t}")
        t = float(min(max(t, 0.0), self.duration))
        q, v, a = self._trajectory.at_time(t)
        return TrajectorySample(frozen(q), frozen(v), frozen(a), t)

    def samples(self, dt: float) -> TrajectorySamples:
        """Samples every `dt` [s] from 0 to the duration, the goal included."""
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"sampling period must be > 0 [s], got {dt}")
        count = int(np.floor(self.duration / dt + 1e-9))
        times = np.arange(count + 1, dtype=float) * dt
        if self.duration - times[-1] > 1e-9:
            times = np.append(times, self.duration)
        times[-1] = min(times[-1], self.duration)
        states = [self._trajectory.at_time(float(t)) for t in times]
        Q, V, A = (np.array([s[i] for s in states], dtype=float) for i in range(3))
        return TrajectorySamples(times, Q, V, A)


def time_optimal_duration(
    limits: JointLimits,
    q: npt.ArrayLike,
    v: npt.ArrayLike,
    a: npt.ArrayLike,
    q_target: npt.ArrayLike,
    v_target: npt.ArrayLike | None = None,
) -> float:
    """Shortest time [s] from a state (q [rad], v [rad/s], a [rad/s^2]) to a target
    position with a target velocity within `limits` (ruckig, not sampled).

    Raises:
        TrajectoryPlanningError: ruckig rejects the input or fails.
    """
    planner = ruckig.Ruckig(limits.dof)
    request = make_input(limits)
    set_state(request, limits, q, v, a, "start")
    set_target(request, limits, q_target, v_target)
    trajectory = ruckig.Trajectory(limits.dof)
    result = call_ruckig(planner.calculate, request, trajectory)
    if result != ruckig.Result.Working:
        raise TrajectoryPlanningError("ruckig failed to time the motion", int(result))
    return float(trajectory.duration)


def plan_point_to_point(
    q_start: npt.ArrayLike,
    q_goal: npt.ArrayLike,
    limits: JointLimits,
    *,
    v_start: npt.ArrayLike | None = None,
    a_start: npt.ArrayLike | None = None,
    v_goal: npt.ArrayLike | None = None,
    a_goal: npt.ArrayLike | None = None,
    straight: bool = False,
    dt: float,
) -> JointTrajectory:
    """Time-optimal jerk-limited trajectory from a state to rest at `q_goal` (or to the
    goal state `v_goal`, `a_goal`: a move that another one continues without a stop).
    `straight`: ruckig's phase synchronisation, a straight line in joint space where the
    start and goal states allow it (at rest, or moving along the line); its time
    synchronisation where not.

    Args:
        q_start: start positions (n,) [rad], within the limits.
        q_goal: goal positions (n,) [rad], within the limits.
        limits: joint limits to respect.
        v_start: start velocities (n,) [rad/s]; zero if None.
        a_start: start accelerations (n,) [rad/s^2]; zero if None.
        v_goal: goal velocities (n,) [rad/s]; zero (at rest) if None.
        a_goal: goal accelerations (n,) [rad/s^2]; zero if None.
        dt: control period [s]; the duration is rounded up to a multiple of it so that
            the last control sample lands on the goal.

    Raises:
        TrajectoryPlanningError: ruckig rejects the input or fails; start or goal outside
            the position limits (code -100); the motion would overshoot them (code -102).
    """
    check_period(dt)
    planner = ruckig.Ruckig(limits.dof, dt)
    request = make_input(limits)
    request.duration_discretization = ruckig.DurationDiscretization.Discrete
    if straight:
        request.synchronization = ruckig.Synchronization.Phase
    set_state(request, limits, q_start, v_start, a_start, "start")
    set_target(request, limits, q_goal, v_goal, a_goal)
    trajectory = ruckig.Trajectory(limits.dof)
    started = time.perf_counter()
    result = call_ruckig(planner.calculate, request, trajectory)
    elapsed = time.perf_counter() - started
    if result != ruckig.Result.Working:
        raise TrajectoryPlanningError("ruckig failed to plan the point-to-point motion", int(result))
    check_extrema(trajectory, limits)
    return JointTrajectory(float(trajectory.duration), elapsed, limits, trajectory)


class JoinedTrajectory(NamedTuple):
    """A move that hands over, without a stop, to (the rest of) another one.

    `fast` ends in the state `slow` has at `handover` [s] (a multiple of the control
    period; 0: `slow` starts where `fast` ends, `plan_through`); from there on the joined
    motion is `slow`'s own. `fast` None: `slow` alone.
    """

    fast: JointTrajectory | None
    slow: JointTrajectory
    handover: float

    @property
    def duration(self) -> float:
        """Time to reach the goal [s]."""
        fast = 0.0 if self.fast is None else self.fast.duration
        return fast + self.slow.duration - self.handover

    @property
    def calculation_time_s(self) -> float:
        """Ruckig's wall time for both plans [s]."""
        fast = 0.0 if self.fast is None else self.fast.calculation_time_s
        return fast + self.slow.calculation_time_s

    def sample(self, t: float) -> TrajectorySample:
        """State at time `t` [s] of the joined motion, clamped into [0, duration]."""
        if self.fast is None:
            return self.slow.sample(t)
        if t <= self.fast.duration:
            return self.fast.sample(t)
        state = self.slow.sample(self.handover + min(t, self.duration) - self.fast.duration)
        return state._replace(time=min(t, self.duration))


class TrajectoryTail(NamedTuple):
    """The rest of `trajectory` from `start` [s] on (a multiple of the control period): a
    move that another one arrived into midway, in its state there (`ArmMotion.arrive_lowering`)."""

    trajectory: JointTrajectory | JoinedTrajectory
    start: float

    @property
    def duration(self) -> float:
        """Time left to the goal [s]."""
        return max(0.0, self.trajectory.duration - self.start)

    @property
    def calculation_time_s(self) -> float:
        """Ruckig's wall time for the whole move [s] (counted once: the part arrived into is not)."""
        return self.trajectory.calculation_time_s

    def sample(self, t: float) -> TrajectorySample:
        """State at time `t` [s] after `start`, clamped into [0, duration]."""
        t = float(min(max(t, 0.0), self.duration))
        return self.trajectory.sample(self.start + t)._replace(time=t)


def plan_slowing_down(
    q_start: npt.ArrayLike,
    q_goal: npt.ArrayLike,
    limits: JointLimits,
    slow_limits: JointLimits,
    slow_from: Callable[[FloatArray], bool],
    *,
    v_start: npt.ArrayLike | None = None,
    a_start: npt.ArrayLike | None = None,
    dt: float,
) -> JoinedTrajectory:
    """A move to rest at `q_goal` that runs within `slow_limits` once it is where
    `slow_from(q)` holds, and within `limits` before, without a stop in between.

    The slow part is the slow move's own (`plan_point_to_point` within `slow_limits`
    from the start), from its first control sample where `slow_from` holds: there and
    after, the joined move is where the slow move would be, at the same velocity and
    acceleration. Up to that state the fast part is the time-optimal move within
    `limits`. The slow move alone where it starts where `slow_from` holds, where the fast
    part would gain nothing, and where the fast part would pass a sample where `slow_from`
    holds before the hand-over (it would be fast where the move must be slow).

    Raises:
        TrajectoryPlanningError: the slow move cannot be planned (the fast part that
            cannot is left out: the slow move alone).
    """
    slow = plan_point_to_point(q_start, q_goal, slow_limits, v_start=v_start, a_start=a_start, dt=dt)
    steps = round(slow.duration / dt)
    handover = next((k for k in range(steps + 1) if slow_from(slow.sample(k * dt).q)), steps)
    if handover == 0:
        return JoinedTrajectory(None, slow, 0.0)
    state = slow.sample(handover * dt)
    try:
        fast = plan_point_to_point(
            q_start, state.q, limits, v_start=v_start, a_start=a_start, v_goal=state.v, a_goal=state.a, dt=dt
        )
    except TrajectoryPlanningError:
        return JoinedTrajectory(None, slow, 0.0)
    fast_steps = round(fast.duration / dt)
    if fast_steps >= handover or any(slow_from(fast.sample(k * dt).q) for k in range(1, fast_steps)):
        return JoinedTrajectory(None, slow, 0.0)  # no gain, or it would be fast where it must be slow
    return JoinedTrajectory(fast, slow, handover * dt)


def plan_through(
    q_start: npt.ArrayLike,
    q_via: npt.ArrayLike,
    q_goal: npt.ArrayLike,
    limits: JointLimits,
    via_speed: float,
    *,
    v_start: npt.ArrayLike | None = None,
    a_start: npt.ArrayLike | None = None,
    dt: float,
) -> JoinedTrajectory:
    """A move to rest at `q_goal` that passes `q_via` without a stop, heading straight for
    the goal at `via_speed` [rad/s] (joint space; less where a joint's velocity limit is
    nearer), and from there on along the straight line in joint space to the goal
    (`straight`, as the last leg of the two stops is too). Where that leg would not keep to
    the line (ruckig fell back to time synchronisation) or would pass the goal and come back
    (too fast to stop in the distance), or a leg at that speed cannot be planned within the
    limits, at half the speed; failing that, the two stops (`fast` at rest at `q_via`).

    Raises:
        TrajectoryPlanningError: the two stops cannot be planned either.
    """
    via = np.asarray(q_via, dtype=float)
    goal = np.asarray(q_goal, dtype=float)
    leg = goal - via
    length = float(np.linalg.norm(leg))
    speeds = [via_speed, via_speed / 2]
    if length > 0.0 and via_speed > 0.0:
        direction = leg / length
        ceiling = float(np.min(limits.velocity / np.maximum(np.abs(direction), 1e-12)))
        for speed in (min(s, 0.9 * ceiling) for s in speeds):
            v_via = direction * speed
            try:
                first = plan_point_to_point(
                    q_start, via, limits, v_start=v_start, a_start=a_start, v_goal=v_via, dt=dt
                )
                last = plan_point_to_point(via, goal, limits, v_start=v_via, straight=True, dt=dt)
            except TrajectoryPlanningError:
                continue  # e.g. an overshoot past a position limit at that speed
            if _keeps_to_leg(last, via, direction, length, dt):
                return JoinedTrajectory(first, last, 0.0)
    first = plan_point_to_point(q_start, via, limits, v_start=v_start, a_start=a_start, dt=dt)
    return JoinedTrajectory(first, plan_point_to_point(via, goal, limits, straight=True, dt=dt), 0.0)


def _keeps_to_leg(
    trajectory: JointTrajectory, start: FloatArray, direction: FloatArray, length: float, dt: float
) -> bool:
    """Every control sample of `trajectory` on the segment from `start` along `direction`
    for `length` [rad] (within 1e-6 rad): no detour, no overshoot."""
    for k in range(round(trajectory.duration / dt) + 1):
        offset = trajectory.sample(k * dt).q - start
        along = float(offset @ direction)
        if along < -1e-6 or along > length + 1e-6 or np.linalg.norm(offset - along * direction) > 1e-6:
            return False
    return True


__all__ = [
    "JoinedTrajectory",
    "JointTrajectory",
    "TrajectoryPlanningError",
    "TrajectorySample",
    "TrajectorySamples",
    "TrajectoryTail",
    "plan_point_to_point",
    "plan_slowing_down",
    "plan_through",
    "time_optimal_duration",
]
