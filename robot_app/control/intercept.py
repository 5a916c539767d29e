"""Servo maths: where the grasp point will be, and joint targets that follow it.

`GraspPath` is the Kalman filter's prediction of the grasp point on the cloth: the
filtered pose of Σ_M carried forward at its estimated velocity and yaw rate (the point
turns with the cloth about its centre). The loop aims at `path.at(now + time_to_go)`,
the place the cloth will be when the arm gets there (the intercept), with the cloth's
velocity as the target velocity, so the hand arrives moving with the cloth.

`JointFollower` turns such a moving TCP target into joint targets every control period
without an IK solve each time: Gauss-Newton steps from the previous joint target, so the
redundant arm's joint targets stay continuous (see the class).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.control.kinematics import Kinematics
from robot_app.control.pose_filter import PoseEstimate

DAMPING = 1e-6  # damped least squares on the 6 x 7 Jacobian (well conditioned in the range)
NEWTON_STEPS = 3  # per period; one suffices for a period's motion, the rest for jumps
JACOBIAN_STEP = 1e-3  # [s] along the joint velocity for the Jacobian's rate of change
LIMIT_EPSILON = 1e-9  # [rad] a joint this close to its limit is at it
CURVE_HORIZON = 0.1  # [s] a smoothed track's acceleration is extrapolated over


@dataclass(frozen=True)
class GraspPath:
    """The predicted track of the grasp point on the table.

    Attributes:
        position: (3,) the grasp point in Σ_W at `time` [m].
        velocity: (3,) its horizontal velocity [m/s] (z: 0; the cloth lies on the table).
        time: [s].
    """

    position: FloatArray
    velocity: FloatArray
    time: float

    @classmethod
    def from_estimate(cls, estimate: PoseEstimate, grasp_point_model: npt.ArrayLike) -> GraspPath:
        """The grasp point (Σ_M, [m]) under the filtered pose, moving with the cloth."""
        pose = estimate.as_transform()
        arm = pose[:3, :3] @ np.asarray(grasp_point_model, dtype=float).reshape(3)
        position = pose[:3, 3] + arm
        velocity = np.array(
            [
                estimate.velocity[0] - estimate.yaw_rate * arm[1],
                estimate.velocity[1] + estimate.yaw_rate * arm[0],
                0.0,
            ]
        )
        return cls(position, velocity, estimate.time)

    def at(self, t: float) -> FloatArray:
        """(3,) the grasp point at time `t` [s] (straight-line prediction)."""
        return self.position + self.velocity * (t - self.time)

    @property
    def speed(self) -> float:
        return float(np.linalg.norm(self.velocity))


class TrackFilter:
    """A smooth copy of the grasp point's predicted track, for the arm to follow.

    A fused recognition moves the filter's prediction by a step (a millimetre, a few
    mm/s). Followed as is, each step is answered by a time-optimal, jerk-limited
    correction that overshoots it. This copy (position, velocity, acceleration) follows the
    prediction through critically damped third-order error dynamics (e = copy minus
    prediction; e''' + 3w e'' + 3w^2 e' + w^3 e = 0), integrated every control period: its
    acceleration is continuous, a step is taken up in about 4/w seconds, and a prediction
    moving at constant velocity is followed without lag.

    Args:
        bandwidth: w [rad/s].
    """

    def __init__(self, bandwidth: float = 20.0) -> None:
        if not bandwidth > 0:
            raise ValueError(f"bandwidth must be > 0 [rad/s], got {bandwidth}")
        self.bandwidth = float(bandwidth)
        self.position = np.zeros(3)
        self.velocity = np.zeros(3)
        self.acceleration = np.zeros(3)
        self.time = math.nan

    def reset(self, path: GraspPath, now: float) -> None:
        """Starts on the prediction at `now` [s] (its position and velocity, no acceleration)."""
        self.position = path.at(now)
        self.velocity = path.velocity.copy()
        self.acceleration = np.zeros(3)
        self.time = float(now)

    def advance(self, path: GraspPath, now: float) -> None:
        """Integrates the copy up to `now` [s] toward the prediction `path`."""
        if not math.isfinite(self.time):
            self.reset(path, now)
            return
        w = self.bandwidth
        steps = max(1, math.ceil((now - self.time) * w / 0.1))  # w * step <= 0.1: stable, accurate
        h = (now - self.time) / steps
        for k in range(steps):
            t = self.time + k * h  # the copy's time before this step
            error = self.position - path.at(t)
            jerk = -3.0 * w * self.acceleration - 3.0 * w * w * (self.velocity - path.velocity) - w**3 * error
            self.acceleration = self.acceleration + h * jerk
            self.velocity = self.velocity + h * self.acceleration
            self.position = self.position + h * self.velocity
        self.time = float(now)

    def at(self, t: float) -> FloatArray:
        """(3,) the copy's position extrapolated to `t` [s] (its acceleration only over the
        next CURVE_HORIZON: a curvature carried farther would be invented)."""
        ahead = t - self.time
        curve = min(ahead, CURVE_HORIZON)
        return self.position + self.velocity * ahead + 0.5 * self.acceleration * curve * curve

    def velocity_at(self, t: float) -> FloatArray:
        """(3,) the copy's velocity extrapolated to `t` [s]."""
        return self.velocity + self.acceleration * min(t - self.time, CURVE_HORIZON)

    def acceleration_at(self, t: float) -> FloatArray:
        """(3,) the copy's acceleration at `t` [s] (0 beyond CURVE_HORIZON)."""
        return self.acceleration.copy() if t - self.time <= CURVE_HORIZON else np.zeros(3)


def hanging_reach(points_model: npt.ArrayLike, grasp_point_model: npt.ArrayLike) -> float:
    """Farthest a cloth point lies from the grasp point in the cloth's plane [m]: how far
    the cloth hangs below the fingers once lifted."""
    P = np.asarray(points_model, dtype=float)
    g = np.asarray(grasp_point_model, dtype=float).reshape(3)
    return float(np.max(np.linalg.norm(P[:, :2] - g[:2], axis=1)))


class JointFollower:
    """Joint targets (q, dq, ddq) for a TCP target that moves, continuous from period to period.

    Each call starts from the previous joint target and takes damped Gauss-Newton steps on
    the TCP's 6-D error (position and the hand's fixed orientation): the joints move by the
    smallest change that follows the target, so a redundant arm does not jump between
    IK solutions of the same TCP pose (each jump is a joint-space transient that the
    TCP shows as a detour). A joint a step would push past its limit is held at the limit
    and the others take its share (7 joints for a 6-D task leave one to spare). The IK
    (`solve`) is used for the first target and whenever the steps leave a residual (a jump
    of the target far beyond one period's motion, or a pose the held joints cannot reach).

    Args:
        kinematics: arm kinematics.
        solve: position (3,) [m], seed joints or None -> joints [rad] with the TCP there
            within the joint limits (the IK; raises when unreachable).
        rotation: (3, 3) orientation the followed frame keeps in Σ_W.
        lower, upper: joint position limits [rad] (default: the kinematics').
        frame: the followed frame ("tcp").
        tolerance: residual above which the IK is called [m] (the orientation error counts as
            the offset it makes 0.1 m from the frame: a held joint must not tilt the hand).
    """

    def __init__(
        self,
        kinematics: Kinematics,
        solve: Callable[[FloatArray, FloatArray | None], FloatArray],
        rotation: npt.ArrayLike,
        lower: npt.ArrayLike | None = None,
        upper: npt.ArrayLike | None = None,
        frame: str = "tcp",
        tolerance: float = 1e-4,
    ) -> None:
        self.kinematics = kinematics
        self.solve = solve
        self.rotation = np.asarray(rotation, dtype=float).reshape(3, 3)
        self.lower = np.asarray(kinematics.lower if lower is None else lower, dtype=float)
        self.upper = np.asarray(kinematics.upper if upper is None else upper, dtype=float)
        self.frame = frame
        self.tolerance = tolerance
        self._q: FloatArray | None = None
        self.ik_calls = 0

    def reset(self) -> None:
        """Forgets the last target (the next one is solved by the IK)."""
        self._q = None

    def joints(
        self,
        position: npt.ArrayLike,
        velocity: npt.ArrayLike,
        acceleration: npt.ArrayLike | None = None,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Joint positions [rad], velocities [rad/s] and accelerations [rad/s^2] for the TCP
        at `position` [m] moving at `velocity` [m/s] and accelerating at `acceleration`
        [m/s^2] (default 0), the hand's orientation kept, within the joint limits.

        The joint acceleration includes the Jacobian's own change along the motion
        (q'' = J^+ (x'' - J' q')): a target moving straight at constant speed still asks
        the joints to accelerate, and an online trajectory that is not told so lags it.
        """
        p = np.asarray(position, dtype=float).reshape(3)
        v = np.asarray(velocity, dtype=float).reshape(3)
        a = np.zeros(3) if acceleration is None else np.asarray(acceleration, dtype=float).reshape(3)
        q = self._q
        residual = np.inf
        if q is not None:
            for _ in range(NEWTON_STEPS):
                error = self._error(q, p)
                residual = self._residual(error)
                if residual <= self.tolerance * 0.1:
                    break
                q = self._step(q, error)
            residual = self._residual(self._error(q, p))
        if q is None or residual > self.tolerance:
            q = np.clip(np.asarray(self.solve(p, q), dtype=float), self.lower, self.upper)
            self.ik_calls += 1
        self._q = q
        free = self._free(q, np.zeros_like(q))
        J = self._jacobian(q)
        pinv = self._pinv(J, free)
        dq = pinv[:, :3] @ v
        free = self._free(q, dq)  # a joint at a limit that would move out of range stays
        pinv = self._pinv(J, free)
        dq = pinv[:, :3] @ v
        drift = (self._jacobian(q + dq * JACOBIAN_STEP) - J) @ dq / JACOBIAN_STEP  # J' q'
        ddq = pinv @ (np.concatenate([a, np.zeros(3)]) - drift)
        return q.copy(), dq, ddq

    def _step(self, q: FloatArray, error: FloatArray) -> FloatArray:
        """One Gauss-Newton step on `error`, joints it would push past a limit held there."""
        J = self._jacobian(q)
        free = self._free(q, np.zeros_like(q))
        for _ in range(len(q)):
            step = self._pinv(J, free) @ error
            beyond = free & ((q + step < self.lower) | (q + step > self.upper))
            if not beyond.any():
                break
            free &= ~beyond
        return np.clip(q + step, self.lower, self.upper)

    def _free(self, q: FloatArray, direction: FloatArray) -> npt.NDArray[np.bool_]:
        """Joints not held: all but those at a limit that `direction` would push past it."""
        held = ((q <= self.lower + LIMIT_EPSILON) & (direction < 0.0)) | (
            (q >= self.upper - LIMIT_EPSILON) & (direction > 0.0)
        )
        return np.asarray(~held, dtype=bool)

    @staticmethod
    def _residual(error: FloatArray) -> float:
        """Position error [m], or the orientation error as the offset it makes 0.1 m out."""
        return max(float(np.linalg.norm(error[:3])), 0.1 * float(np.linalg.norm(error[3:])))

    def _error(self, q: FloatArray, position: FloatArray) -> FloatArray:
        """6-D error (position [m]; rotation vector [rad]) from the frame at q to the target."""
        pose = self.kinematics.frame_pose(q, self.frame)
        R = self.rotation @ pose[:3, :3].T
        angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))
        axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        rotation = 0.5 * axis if angle < 1e-9 else axis * (angle / (2.0 * math.sin(angle)))
        return np.concatenate([position - pose[:3, 3], rotation])

    def _jacobian(self, q: FloatArray) -> FloatArray:
        return np.asarray(self.kinematics.frame_jacobian(q, self.frame, "local_world_aligned"), dtype=float)

    @staticmethod
    def _pinv(J: FloatArray, free: npt.NDArray[np.bool_]) -> FloatArray:
        """Damped pseudo-inverse (n, 6) using only the `free` joints (held ones get 0)."""
        Jf = J[:, free]
        pinv = np.zeros((J.shape[1], 6))
        pinv[free] = Jf.T @ np.linalg.inv(Jf @ Jf.T + DAMPING * np.eye(6))
        return pinv


__all__ = ["GraspPath", "JointFollower", "TrackFilter", "hanging_reach"]
