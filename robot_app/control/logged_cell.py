"""A `Cell` that keeps every joint command, for limit checks across several drivers.

A job that hands the arm from one driver to another (a pick-and-place loop per cloth,
motions of its own between them) must not jump at the hand-overs. `LoggedCell` passes
everything through to the cell it wraps and records each commanded sample (cell time,
position, velocity); `limit_report` checks all of them together: positions and the
commanded velocities directly, the velocity implied by consecutive positions (a jump at a
hand-over shows there), and accelerations and jerks as differences of the commanded
velocities (mean values over each control period: they exceed a limit only if the
command did).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.cell import Cell, StereoCapture
from robot_app.control.limits import JointLimits, LimitReport, check_limits


class LoggedCell:
    """Wraps a `Cell`; records every `command_joints` at the cell time it is sent.

    Args:
        cell: the cell to drive.
    """

    def __init__(self, cell: Cell) -> None:
        self.cell = cell
        self.dt = cell.dt
        self._times: list[float] = []
        self._q: list[FloatArray] = []
        self._v: list[FloatArray] = []

    @property
    def time(self) -> float:
        return self.cell.time

    @property
    def last_command(self) -> FloatArray | None:
        """The last commanded positions [rad] (a copy), or None before the first command."""
        return self._q[-1].copy() if self._q else None

    def step(self) -> None:
        self.cell.step()

    def joint_positions(self) -> FloatArray:
        return self.cell.joint_positions()

    def command_joints(self, q: npt.ArrayLike, dq: npt.ArrayLike) -> None:
        q_array, v_array = np.array(q, dtype=float), np.array(dq, dtype=float)
        self._times.append(self.cell.time)
        self._q.append(q_array)
        self._v.append(v_array)
        self.cell.command_joints(q_array, v_array)

    def capture(self) -> StereoCapture:
        return self.cell.capture()

    def set_gripper(self, opening: float) -> None:
        self.cell.set_gripper(opening)

    def grasp(self) -> int:
        return self.cell.grasp()

    def release(self) -> None:
        self.cell.release()

    def holding(self) -> bool:
        return self.cell.holding()

    def collisions(self) -> int:
        return self.cell.collisions()

    @property
    def samples(self) -> int:
        return len(self._times)

    def limit_report(self, limits: JointLimits, tol: float = 1e-6) -> LimitReport:
        """Every command so far against `limits` (see the module docstring).

        A command repeated at the same cell time (two drivers in one step) counts once,
        the later one.
        """
        if not self._times:
            return check_limits(
                np.zeros(0), np.zeros((0, limits.dof)), *(np.zeros((0, limits.dof)),) * 2, limits
            )
        times = np.asarray(self._times)
        keep = np.append(np.diff(times) > 0, True)
        times = times[keep]
        Q, V = np.asarray(self._q)[keep], np.asarray(self._v)[keep]
        if len(times) < 2:
            return check_limits(times, Q, V, np.zeros_like(V), limits, tol)
        intervals = np.diff(times)[:, None]
        A = np.vstack([np.diff(V, axis=0) / intervals, np.zeros((1, limits.dof))])
        A[-1] = A[-2]
        implied = np.vstack([np.diff(Q, axis=0) / intervals, np.zeros((1, limits.dof))])
        # the larger of the commanded and the implied velocity is what is checked
        V_checked = np.where(np.abs(implied) > np.abs(V), implied, V)
        return check_limits(times, Q, V_checked, A, limits, tol)


__all__ = ["LoggedCell"]
