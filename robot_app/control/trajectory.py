"""Jerk-limited joint trajectories with ruckig, offline and replanned online.

`plan_point_to_point` computes one time-optimal trajectory between two states;
`OnlineTrajectory` replans every control cycle toward a target that may move (the
pick-and-place loop's servo target). Both keep velocity, acceleration and jerk within a
`JointLimits`; position limits are enforced here because ruckig's community edition
ignores `min_position`/`max_position`: targets outside the range are rejected as invalid
input, and a trajectory whose position extrema leave the range (an overshoot from a
fast start) raises with ruckig's `ErrorPositionalLimits` code, as ruckig Pro would.
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
from robot_app.errors import TrajectoryError

RESULT_INVALID_INPUT = int(ruckig.Result.ErrorInvalidInput)
RESULT_POSITIONAL_LIMITS = int(ruckig.Result.ErrorPositionalLimits)
_ROUNDING = 1e-10  # [rad] position extrema may touch a limit this far beyond by rounding


class TrajectoryPlanningError(TrajectoryError):
    """Ruckig could not plan the requested motion.

    Attributes:
        code: ruckig's `Result` code (e.g. -100 invalid input, -102 positional limits).
    """

    def __init__(self, message: str, code: int) -> None:
        super().__init__(f"{message} (ruckig result {_result_name(code)} = {code})")
        self.code = code


class TrajectorySample(NamedTuple):
    """One commanded joint state: positions [rad], velocities [rad/s], accelerations
    [rad/s^2] and its time [s] since the trajectory (or online run) started."""

    q: FloatArray
    v: FloatArray
    a: FloatArray
    time: float


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
        return TrajectorySample(_frozen(q), _frozen(v), _frozen(a), t)

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
    request = _make_input(limits)
    _set_state(request, limits, q, v, a, "start")
    _set_target(request, limits, q_target, v_target)
    trajectory = ruckig.Trajectory(limits.dof)
    result = _call_ruckig(planner.calculate, request, trajectory)
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
    dt: float,
) -> JointTrajectory:
    """Time-optimal jerk-limited trajectory from a state to rest at `q_goal` (or to the
    goal state `v_goal`, `a_goal`: a move that another one continues without a stop).

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
    _check_period(dt)
    planner = ruckig.Ruckig(limits.dof, dt)
    request = _make_input(limits)
    request.duration_discretization = ruckig.DurationDiscretization.Discrete
    _set_state(request, limits, q_start, v_start, a_start, "start")
    _set_target(request, limits, q_goal, v_goal, a_goal)
    trajectory = ruckig.Trajectory(limits.dof)
    started = time.perf_counter()
    result = _call_ruckig(planner.calculate, request, trajectory)
    elapsed = time.perf_counter() - started
    if result != ruckig.Result.Working:
        raise TrajectoryPlanningError("ruckig failed to plan the point-to-point motion", int(result))
    _check_extrema(trajectory, limits)
    return JointTrajectory(float(trajectory.duration), elapsed, limits, trajectory)


class JoinedTrajectory(NamedTuple):
    """A fast move that hands over, without a stop, to the rest of a slow one.

    `fast` ends in the state `slow` has at `handover` [s] (a multiple of the control
    period); from there on the joined motion is `slow`'s own. `fast` None: `slow` alone.
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


class OnlineTrajectory:
    """Ruckig in online mode: call `step()` once per control cycle of `dt` [s].

    The target may change between steps (`set_target`); ruckig then replans from the
    current commanded state, so position, velocity and acceleration stay continuous
    and jerk stays bounded across replans.

    Attributes:
        limits: joint limits respected by every sample.
        dt: control period [s].
        finished: True once the commanded state has reached the current target.
        last_calculation_time_s: ruckig's own timing of its latest replan [s].
    """

    def __init__(self, limits: JointLimits, dt: float, q_init: npt.ArrayLike) -> None:
        _check_period(dt)
        self.limits = limits
        self.dt = float(dt)
        self._planner = ruckig.Ruckig(limits.dof, self.dt)
        self._input = _make_input(limits)
        self._output = ruckig.OutputParameter(limits.dof)
        self._calculation_times: list[float] = []
        self.last_calculation_time_s = 0.0
        self.reset(q_init)

    def reset(self, q: npt.ArrayLike, v: npt.ArrayLike | None = None, a: npt.ArrayLike | None = None) -> None:
        """Restarts from state (q [rad], v [rad/s], a [rad/s^2]); the target becomes q at rest."""
        _set_state(self._input, self.limits, q, v, a, "current")
        _set_target(self._input, self.limits, q, None)
        self._planner.reset()
        self._time = 0.0
        self.finished = not np.any(self._input.current_velocity) and not np.any(
            self._input.current_acceleration
        )

    def set_target(
        self,
        q_target: npt.ArrayLike,
        v_target: npt.ArrayLike | None = None,
        a_target: npt.ArrayLike | None = None,
        *,
        minimum_duration: float | None = None,
        synchronized: bool = True,
    ) -> None:
        """Sets the target positions [rad], velocities [rad/s] and accelerations [rad/s^2].

        A target at rest or moving at constant velocity needs no acceleration. A target
        that accelerates (e.g. a sinusoid) should pass it: a time-optimal replan toward a
        state whose acceleration it does not know chatters at the acceleration limit.
        Velocities and accelerations default to zero.

        `minimum_duration` [s] makes the plan take at least that long (ruckig's own
        option): a moving target state is then met when it is due, not as early as the
        limits allow (an intercept). None: time-optimal.

        `synchronized` (default) makes every joint arrive together (ruckig's time
        synchronisation: a straight-ish path in joint space). False lets each joint reach
        its own target state as fast as it can: for tracking a target that moves a little
        every period, where synchronising all joints to the slowest one's small correction
        bends the others' motion.
        """
        if minimum_duration is not None and not (np.isfinite(minimum_duration) and minimum_duration >= 0):
            raise ValueError(f"minimum_duration must be finite and >= 0 [s], got {minimum_duration}")
        if minimum_duration is not None and not synchronized:
            raise ValueError("a minimum_duration needs the joints synchronized")
        _set_target(self._input, self.limits, q_target, v_target, a_target)
        self._input.minimum_duration = None if minimum_duration is None else float(minimum_duration)
        self._input.synchronization = (
            ruckig.Synchronization.Time if synchronized else ruckig.Synchronization.No
        )
        self.finished = False

    def step(self) -> TrajectorySample:
        """Advances one period and returns the new commanded state.

        Raises:
            TrajectoryPlanningError: ruckig reports an error, or the replanned motion
                would leave the position limits (code -102); the state is not advanced.
        """
        self._clip_rounding_excess()
        try:
            result = _call_ruckig(self._planner.update, self._input, self._output)
        except TrajectoryPlanningError as err:
            if err.code != int(ruckig.Result.ErrorSynchronizationCalculation):
                raise
            # Step 2 also fails now and then on a state that sits at a limit to within a
            # few ulps without exceeding it (seen in the hypothesis test of the online
            # replanning); the same state pulled inside by 1e-12 relative replans.
            self._pull_inside(1e-12)
            result = _call_ruckig(self._planner.update, self._input, self._output)
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise TrajectoryPlanningError("ruckig failed to replan the online motion", int(result))
        if self._output.new_calculation:
            _check_extrema(self._output.trajectory, self.limits)
            self.last_calculation_time_s = self._output.calculation_duration * 1e-6  # ruckig gives [us]
            self._calculation_times.append(self.last_calculation_time_s)
        self._output.pass_to_input(self._input)
        self._time += self.dt
        self.finished = result == ruckig.Result.Finished
        return self.state

    def _clip_rounding_excess(self) -> None:
        # Ruckig's own output can sit one ulp beyond a velocity limit it drove at, and its
        # next synchronisation then fails ("error in step 2"); states only ever get here
        # through ruckig or the validated reset, so clipping moves them by rounding only.
        request = self._input
        bounds = {"current_velocity": self.limits.velocity, "current_acceleration": self.limits.acceleration}
        for name, bound in bounds.items():
            values = np.array(getattr(request, name), dtype=float)
            if np.any(np.abs(values) > bound):
                setattr(request, name, np.clip(values, -bound, bound).tolist())

    def _pull_inside(self, fraction: float) -> None:
        """Scales the current velocity and acceleration by (1 - fraction)."""
        request = self._input
        for name in ("current_velocity", "current_acceleration"):
            values = np.array(getattr(request, name), dtype=float)
            setattr(request, name, (values * (1.0 - fraction)).tolist())

    @property
    def state(self) -> TrajectorySample:
        """The latest commanded state (the initial one before any step)."""
        request = self._input
        return TrajectorySample(
            _frozen(request.current_position),
            _frozen(request.current_velocity),
            _frozen(request.current_acceleration),
            self._time,
        )

    @property
    def target(self) -> FloatArray:
        """Current target positions [rad]."""
        return _frozen(self._input.target_position)

    @property
    def time_to_target(self) -> float:
        """Time [s] the latest plan still needs to reach its target (0 before any step and
        once reached): when a command given now will have acted."""
        if self._time == 0.0 or self.finished:
            return 0.0
        return max(0.0, float(self._output.trajectory.duration) - float(self._output.time))

    @property
    def calculation_times(self) -> FloatArray:
        """Ruckig's calculation time of every replan so far [s] (for statistics)."""
        return _frozen(self._calculation_times)


def _make_input(limits: JointLimits) -> ruckig.InputParameter:
    request = ruckig.InputParameter(limits.dof)
    request.max_velocity = limits.velocity.tolist()
    request.max_acceleration = limits.acceleration.tolist()
    request.max_jerk = limits.jerk.tolist()
    return request


def _set_state(
    request: ruckig.InputParameter,
    limits: JointLimits,
    q: npt.ArrayLike,
    v: npt.ArrayLike | None,
    a: npt.ArrayLike | None,
    what: str,
) -> None:
    q_arr = _vector(q, limits.dof, f"{what} positions")
    v_arr = np.zeros(limits.dof) if v is None else _vector(v, limits.dof, f"{what} velocities")
    a_arr = np.zeros(limits.dof) if a is None else _vector(a, limits.dof, f"{what} accelerations")
    _check_within(q_arr, limits, f"{what} positions")
    _check_bound(v_arr, limits.velocity, f"{what} velocities", limits)
    _check_bound(a_arr, limits.acceleration, f"{what} accelerations", limits)
    request.current_position = q_arr.tolist()
    request.current_velocity = v_arr.tolist()
    request.current_acceleration = a_arr.tolist()


def _set_target(
    request: ruckig.InputParameter,
    limits: JointLimits,
    q: npt.ArrayLike,
    v: npt.ArrayLike | None,
    a: npt.ArrayLike | None = None,
) -> None:
    q_arr = _vector(q, limits.dof, "target positions")
    v_arr = np.zeros(limits.dof) if v is None else _vector(v, limits.dof, "target velocities")
    a_arr = np.zeros(limits.dof) if a is None else _vector(a, limits.dof, "target accelerations")
    _check_within(q_arr, limits, "target positions")
    _check_bound(v_arr, limits.velocity, "target velocities", limits)
    _check_bound(a_arr, limits.acceleration, "target accelerations", limits)
    # The velocity the target state drifts to while its acceleration ramps to zero at the
    # jerk limit must be within the limit too, or no trajectory through it respects it.
    drift = v_arr + a_arr * np.abs(a_arr) / (2.0 * limits.jerk)
    _check_bound(drift, limits.velocity, "target velocity + drift while its acceleration ramps down", limits)
    request.target_position = q_arr.tolist()
    request.target_velocity = v_arr.tolist()
    request.target_acceleration = a_arr.tolist()


def _vector(value: npt.ArrayLike, dof: int, what: str) -> FloatArray:
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.shape != (dof,):
        raise ValueError(f"{what} must have {dof} values, got shape {np.shape(value)}")
    if not np.all(np.isfinite(array)):
        raise TrajectoryPlanningError(f"{what} must be finite, got {array.tolist()}", RESULT_INVALID_INPUT)
    return array


def _check_within(q: FloatArray, limits: JointLimits, what: str) -> None:
    outside = np.flatnonzero((q < limits.lower) | (q > limits.upper))
    if outside.size:
        i = int(outside[0])
        raise TrajectoryPlanningError(
            f"{what}: joint {_joint_name(limits, i)} at {q[i]:.4f} rad is outside "
            f"[{limits.lower[i]:.4f}, {limits.upper[i]:.4f}] rad",
            RESULT_INVALID_INPUT,
        )


def _check_bound(values: FloatArray, bound: FloatArray, what: str, limits: JointLimits) -> None:
    outside = np.flatnonzero(np.abs(values) > bound)
    if outside.size:
        i = int(outside[0])
        raise TrajectoryPlanningError(
            f"{what}: joint {_joint_name(limits, i)} has |{values[i]:.4f}| above its limit {bound[i]:.4f}",
            RESULT_INVALID_INPUT,
        )


def _check_extrema(trajectory: ruckig.Trajectory, limits: JointLimits) -> None:
    for i, extremum in enumerate(trajectory.position_extrema):
        if extremum.min < limits.lower[i] - _ROUNDING or extremum.max > limits.upper[i] + _ROUNDING:
            raise TrajectoryPlanningError(
                f"joint {_joint_name(limits, i)} would reach [{extremum.min:.4f}, {extremum.max:.4f}] rad, "
                f"outside its range [{limits.lower[i]:.4f}, {limits.upper[i]:.4f}] rad",
                RESULT_POSITIONAL_LIMITS,
            )


def _call_ruckig(method: Callable[..., ruckig.Result], *args: object) -> ruckig.Result:
    """Calls ruckig; its exceptions (thrown instead of negative results by the Python
    build) become `TrajectoryPlanningError` with the code ruckig would have returned."""
    try:
        return method(*args)
    except ruckig.RuckigError as err:
        message = str(err).strip().removeprefix("[ruckig]").strip()
        if message.startswith("error in step 1"):
            code, what = int(ruckig.Result.ErrorExecutionTimeCalculation), "calculation failed"
        elif message.startswith("error in step 2"):
            code, what = int(ruckig.Result.ErrorSynchronizationCalculation), "synchronisation failed"
        else:
            code, what = RESULT_INVALID_INPUT, "invalid trajectory input"
        raise TrajectoryPlanningError(f"{what}: {message.splitlines()[0]}", code) from err


def _check_period(dt: float) -> None:
    if not (np.isfinite(dt) and dt > 0.0):
        raise ValueError(f"control period dt must be > 0 [s], got {dt}")


def _joint_name(limits: JointLimits, index: int) -> str:
    return limits.names[index] if limits.names else str(index)


def _result_name(code: int) -> str:
    try:
        return ruckig.Result(code).name
    except ValueError:
        return "unknown"


def _frozen(values: npt.ArrayLike) -> FloatArray:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


__all__ = [
    "JoinedTrajectory",
    "JointTrajectory",
    "OnlineTrajectory",
    "TrajectoryPlanningError",
    "TrajectorySample",
    "TrajectorySamples",
    "plan_point_to_point",
    "plan_slowing_down",
    "time_optimal_duration",
]
