"""Ruckig's input, checked: what every plan shares (offline `trajectory.py`, online
`online_trajectory.py`).

Ruckig's Python build throws on bad input and its community edition ignores position
limits, so the states and targets are checked here (finite, the right length, positions
within the range, velocities and accelerations within their limits) and each failure is a
`TrajectoryPlanningError` with the code ruckig (Pro) would return: -100 invalid input, -102
positional limits.
"""

from __future__ import annotations

from collections.abc import Callable
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


def make_input(limits: JointLimits) -> ruckig.InputParameter:
    """A ruckig request with the velocity, acceleration and jerk limits of `limits`."""
    request = ruckig.InputParameter(limits.dof)
    request.max_velocity = limits.velocity.tolist()
    request.max_acceleration = limits.acceleration.tolist()
    request.max_jerk = limits.jerk.tolist()
    return request


def set_state(
    request: ruckig.InputParameter,
    limits: JointLimits,
    q: npt.ArrayLike,
    v: npt.ArrayLike | None,
    a: npt.ArrayLike | None,
    what: str,
) -> None:
    """Sets the request's current state (v, a zero if None), checked against `limits`;
    `what` names it in errors ("start", "current").

    Raises:
        TrajectoryPlanningError: a position outside the range or a velocity or
            acceleration above its limit (code -100).
    """
    q_arr = _vector(q, limits.dof, f"{what} positions")
    v_arr = np.zeros(limits.dof) if v is None else _vector(v, limits.dof, f"{what} velocities")
    a_arr = np.zeros(limits.dof) if a is None else _vector(a, limits.dof, f"{what} accelerations")
    _check_within(q_arr, limits, f"{what} positions")
    _check_bound(v_arr, limits.velocity, f"{what} velocities", limits)
    _check_bound(a_arr, limits.acceleration, f"{what} accelerations", limits)
    request.current_position = q_arr.tolist()
    request.current_velocity = v_arr.tolist()
    request.current_acceleration = a_arr.tolist()


def set_target(
    request: ruckig.InputParameter,
    limits: JointLimits,
    q: npt.ArrayLike,
    v: npt.ArrayLike | None,
    a: npt.ArrayLike | None = None,
) -> None:
    """Sets the request's target state (v, a zero if None), checked against `limits`.

    Raises:
        TrajectoryPlanningError: as `set_state`, or a target whose velocity drifts past
            its limit while its acceleration ramps down (code -100).
    """
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


def check_extrema(trajectory: ruckig.Trajectory, limits: JointLimits) -> None:
    """Raises `TrajectoryPlanningError` (code -102) where the trajectory's position extrema
    leave the range: ruckig's community edition does not enforce position limits."""
    for i, extremum in enumerate(trajectory.position_extrema):
        if extremum.min < limits.lower[i] - _ROUNDING or extremum.max > limits.upper[i] + _ROUNDING:
            raise TrajectoryPlanningError(
                f"joint {_joint_name(limits, i)} would reach [{extremum.min:.4f}, {extremum.max:.4f}] rad, "
                f"outside its range [{limits.lower[i]:.4f}, {limits.upper[i]:.4f}] rad",
                RESULT_POSITIONAL_LIMITS,
            )


def call_ruckig(method: Callable[..., ruckig.Result], *args: object) -> ruckig.Result:
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


def check_period(dt: float) -> None:
    """Raises ValueError unless the control period `dt` [s] is finite and positive."""
    if not (np.isfinite(dt) and dt > 0.0):
        raise ValueError(f"control period dt must be > 0 [s], got {dt}")


def _joint_name(limits: JointLimits, index: int) -> str:
    return limits.names[index] if limits.names else str(index)


def _result_name(code: int) -> str:
    try:
        return ruckig.Result(code).name
    except ValueError:
        return "unknown"


def frozen(values: npt.ArrayLike) -> FloatArray:
    """A read-only float copy of `values` (states handed out cannot be changed)."""
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


__all__ = [
    "RESULT_INVALID_INPUT",
    "RESULT_POSITIONAL_LIMITS",
    "TrajectoryPlanningError",
    "TrajectorySample",
    "call_ruckig",
    "check_extrema",
    "check_period",
    "frozen",
    "make_input",
    "set_state",
    "set_target",
]
