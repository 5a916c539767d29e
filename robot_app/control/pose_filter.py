"""Kalman filter on the cloth's pose in the world, with gating of bad recognitions.

The state is (x, y, z, yaw, vx, vy, vz, yaw_rate) in Σ_W [m, rad, m/s, rad/s] under a
constant-velocity model driven by continuous white-noise acceleration, discretised
exactly for each period: F and Q are rebuilt whenever the time between calls changes,
so two predictions of dt/2 give the same result as one of dt. A recognition is fused
only if its fitness reaches `min_fitness` and it is close to the prediction (position
and yaw jumps, and the innovation's Mahalanobis distance); others are rejected and
counted. After `max_consecutive_rejections` in a row the filter is *lost* and the next
recognition with enough fitness re-initialises it (the cloth was moved, e.g. grasped).
A recognition below `min_fitness` that passes the gates is not fused either, but does not
count toward being lost: a poor view of the cloth where it should be (the arm's shadow on
it, the cloth past the image's edge) is not a lost cloth.
A cloth pushed by a few centimetres, or turned, is followed sooner: `relocate_after`
trusted measurements in a row that the Mahalanobis or the yaw gate rejected (each within
`max_position_jump`) and that agree with each other (within `relocation_tolerance` and
`RELOCATION_YAW`, after the predicted motion between them) restart the estimate at the
newest of them with the velocity between the first and the newest (a pushed cloth on a
running belt moves on; one stopped at the belt's end does not). A plain square cloth
recognised a quarter turn round is the same case: its yaw is relocated.

A measured horizontal velocity (a conveyor's encoder, `belt_odometry.BeltOdometry`) is fused
into (vx, vy) by `fuse_velocities`, without gates or counters; `estimate_with_velocities`
predicts with such samples without changing the filter.

Yaw is an angle: the state's yaw is kept in [-pi, pi) and the measured yaw is moved to
the branch nearest the prediction before fusing, so a cloth at 179 deg measured at
-179 deg has a 2 deg innovation, not 358 deg. The cloth's tilt is not estimated.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, NamedTuple

import numpy as np
import numpy.typing as npt
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter
from pydantic import Field

from robot_app.arrays import FloatArray
from robot_app.config import StrictModel
from robot_app.geometry import is_rotation, make_transform, rotation_about_z, wrap_angle, yaw_of

_YAW = 3  # index of yaw in the state and the measurement
RELOCATION_YAW = math.radians(10.0)  # rejected measurements agreeing in yaw to relocate onto them
_Z_DOWN = np.diag([1.0, -1.0, -1.0])  # Σ_M's z points into the table (docs/architecture.md)
_VELOCITY_H = np.hstack([np.zeros((2, 4)), np.eye(2), np.zeros((2, 2))])  # (vx, vy) of the state


class PoseFilterSettings(StrictModel):
    """Noise model and gates of `PoseFilter`.

    Attributes:
        position_process_psd: spectral density of the white-noise acceleration of x, y,
            z [m^2/s^3]; 1e-4 lets the velocity wander 1 cm/s per sqrt(s). At 10 Hz the
            steady-state position std is then ~0.6 x the measurement std.
        yaw_process_psd: the same for yaw [rad^2/s^3]; 1e-3 is 1.8 deg/s per sqrt(s).
        measurement_std_xy: std of a recognised x and y [m]; the paper's +-10 mm (3 sigma).
        measurement_std_z: std of a recognised z [m] (stereo depth is coarser).
        measurement_std_yaw: std of a recognised yaw [rad]; the paper's +-10 deg (3 sigma).
        initial_velocity_std: std of the unknown velocity at (re)initialisation [m/s].
        initial_yaw_rate_std: std of the unknown yaw rate at (re)initialisation [rad/s].
        gate_chi2: largest accepted squared Mahalanobis distance of the innovation [-];
            18.47 is the 99.9 % quantile of chi-square with 4 degrees of freedom.
        max_position_jump: largest accepted distance of a measurement from the predicted
            position [m], whatever the covariance says.
        max_yaw_jump: largest accepted |yaw innovation| [rad].
        min_fitness: recognitions with a lower normalised fitness are rejected [-];
            the paper's clean, occluded and two-cloth scenes scored 0.85, 0.32, 0.79.
        max_consecutive_rejections: rejections in a row after which the filter is lost.
        relocate_after: trusted Mahalanobis or yaw rejections in a row, agreeing with each
            other, that move the estimate onto the newest (0: never).
        relocation_tolerance: how close [m] consecutive rejected measurements must agree.
        untrusted_std_scale: a recognition the decision does not trust (`trusted=False`:
            not `found`) is fused with its measurement standard deviations times this.
    """

    position_process_psd: Annotated[float, Field(gt=0.0)] = 1e-4
    yaw_process_psd: Annotated[float, Field(gt=0.0)] = 1e-3
    measurement_std_xy: Annotated[float, Field(gt=0.0)] = 0.0035
    measurement_std_z: Annotated[float, Field(gt=0.0)] = 0.006
    measurement_std_yaw: Annotated[float, Field(gt=0.0)] = math.radians(3.5)
    initial_velocity_std: Annotated[float, Field(gt=0.0)] = 0.05
    initial_yaw_rate_std: Annotated[float, Field(gt=0.0)] = 0.2
    gate_chi2: Annotated[float, Field(gt=0.0)] = 18.47
    max_position_jump: Annotated[float, Field(gt=0.0)] = 0.05
    max_yaw_jump: Annotated[float, Field(gt=0.0, le=math.pi)] = math.radians(20.0)
    min_fitness: float = 0.3
    max_consecutive_rejections: Annotated[int, Field(ge=1)] = 5
    relocate_after: Annotated[int, Field(ge=0)] = 2
    untrusted_std_scale: Annotated[float, Field(ge=1.0)] = 3.0
    relocation_tolerance: Annotated[float, Field(gt=0.0)] = 0.008


class PoseXYZYaw(NamedTuple):
    """A cloth pose on the table: position in Σ_W [m] and yaw about world z [rad]."""

    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class PoseEstimate:
    """The filtered cloth pose at `time`.

    Attributes:
        x, y, z: position of Σ_M's origin in Σ_W [m].
        yaw: heading of Σ_M's x axis in the world x-y plane, atan2(R[1,0], R[0,0]) [rad].
        velocity: (vx, vy, vz) [m/s], read-only.
        yaw_rate: [rad/s].
        covariance: (8, 8) state covariance, order (x, y, z, yaw, vx, vy, vz, yaw_rate).
        time: [s].
    """

    x: float
    y: float
    z: float
    yaw: float
    velocity: FloatArray
    yaw_rate: float
    covariance: FloatArray
    time: float

    @property
    def position(self) -> FloatArray:
        """(x, y, z) [m]."""
        return np.array([self.x, self.y, self.z])

    def as_transform(self, *, z_down: bool = True) -> FloatArray:
        """4x4 pose of the cloth in Σ_W, its tilt ignored (the cloth lies flat).

        Args:
            z_down: Σ_M's z axis points into the table (docs/architecture.md: away from the camera
                that looks down on it), so the rotation is Rz(yaw) Rx(pi); False gives
                Rz(yaw) with z up.
        """
        rotation = rotation_about_z(self.yaw)
        return make_transform(rotation @ _Z_DOWN if z_down else rotation, self.position)


class UpdateReason(enum.StrEnum):
    """Why a measurement was or was not fused."""

    ACCEPTED = "accepted"
    INITIALISED = "initialised"
    REINITIALISED = "reinitialised after being lost"
    LOW_FITNESS = "fitness below min_fitness"
    LOW_FITNESS_CONSISTENT = "fitness below min_fitness, where the prediction is"
    POSITION_JUMP = "position jump beyond max_position_jump"
    YAW_JUMP = "yaw jump beyond max_yaw_jump"
    MAHALANOBIS = "Mahalanobis distance beyond gate_chi2"
    RELOCATED = "relocated onto agreeing rejected measurements"
    LOOK_ALIKE = "far from the prediction, which fits the frame as well: not fused"
    TOO_CLOSE = "exposed closer to the cloth than the working distance: not fused"


@dataclass(frozen=True)
class FilterUpdate:
    """The outcome of `PoseFilter.update`.

    Attributes:
        accepted: True if the measurement was fused (or (re)initialised the filter).
        reason: why.
        nis: normalised innovation squared y^T S^-1 y [-]; nan if not computed (the
            filter was not initialised, or the fitness was too low).
        estimate: the estimate after the update, None if the filter is not initialised.
        distance: horizontal distance of the measured position from the prediction at
            its time [m] (the innovation's x-y length, whatever the gates decided); nan
            if there was no prediction.
    """

    accepted: bool
    reason: UpdateReason
    nis: float
    estimate: PoseEstimate | None
    distance: float = math.nan


class PoseFilter:
    """Constant-velocity Kalman filter (filterpy) on (x, y, z, yaw) with gating.

    Times are absolute [s] and must not decrease between calls.

    Args:
        settings: the noise model and gates.
        symmetry_angles: yaws [rad] under which the tracked cloth looks the same
            (`ClothModel.symmetry_angles`); a measurement turned by one of them is the
            same pose, not a yaw jump.

    Attributes:
        settings: the noise model and gates.
        accepted_count: measurements fused or used to (re)initialise.
        rejected_count: measurements rejected, for any reason.
        consecutive_rejections: rejections since the last accepted measurement.
    """

    def __init__(
        self, settings: PoseFilterSettings | None = None, symmetry_angles: tuple[float, ...] = ()
    ) -> None:
        self.settings = settings or PoseFilterSettings()
        # a measured yaw and these turns of it are the same cloth pose (a plain rectangle
        # looks the same half turned): the update takes the one nearest the prediction
        self._yaw_turns = np.unique(np.round([0.0, *symmetry_angles, *(-a for a in symmetry_angles)], 12))
        s = self.settings
        self._kf = KalmanFilter(dim_x=8, dim_z=4)
        self._kf.H = np.hstack([np.eye(4), np.zeros((4, 4))])
        std = [s.measurement_std_xy, s.measurement_std_xy, s.measurement_std_z, s.measurement_std_yaw]
        self._kf.R = np.diag(np.square(std))
        psd = np.array([s.position_process_psd] * 3 + [s.yaw_process_psd])
        self._psd_scale = np.sqrt(np.outer(np.tile(psd, 2), np.tile(psd, 2)))
        self._period = math.nan
        self._time = math.nan
        self.initialised = False
        self.accepted_count = 0
        self.rejected_count = 0
        self.consecutive_rejections = 0
        self._jumps: list[tuple[FloatArray, float]] = []  # agreeing Mahalanobis rejections (z, t)

    @property
    def lost(self) -> bool:
        """True once `max_consecutive_rejections` measurements in a row were rejected."""
        return self.initialised and self.consecutive_rejections >= self.settings.max_consecutive_rejections

    @property
    def period(self) -> float:
        """The period [s] that F and Q were last built for (nan before any prediction)."""
        return self._period

    @property
    def transition_matrix(self) -> FloatArray:
        """F of the last period, (8, 8), a copy."""
        return np.array(self._kf.F, dtype=float)

    @property
    def process_noise(self) -> FloatArray:
        """Q of the last period, (8, 8), a copy."""
        return np.array(self._kf.Q, dtype=float)

    @property
    def estimate(self) -> PoseEstimate | None:
        """The current estimate, None before initialisation."""
        return self._estimate(self._kf.x, self._kf.P, self._time) if self.initialised else None

    def reset(self, pose: PoseXYZYaw | npt.ArrayLike, t: float) -> PoseEstimate:
        """(Re)starts the filter at `pose` (x, y, z, yaw or a 4x4 world pose) at time `t`
        [s], with the measurement covariance and an unknown velocity; counters are kept."""
        z = _measurement_vector(pose)
        s = self.settings
        self._kf.x = np.concatenate([z, np.zeros(4)]).reshape(8, 1)
        velocity_var = [s.initial_velocity_std**2] * 3 + [s.initial_yaw_rate_std**2]
        self._kf.P = np.diag(np.concatenate([np.diag(self._kf.R), velocity_var]))
        self._time = _finite_time(t)
        self.initialised = True
        self.consecutive_rejections = 0
        self._jumps.clear()
        return self._estimate(self._kf.x, self._kf.P, self._time)

    def reset_from_two(
        self,
        first: PoseXYZYaw | npt.ArrayLike,
        t_first: float,
        second: PoseXYZYaw | npt.ArrayLike,
        t_second: float,
    ) -> PoseEstimate:
        """(Re)starts the filter at `second` with the velocity the two measurements give
        ((second - first) / (t_second - t_first), yaw on the nearest branch) and that
        difference's covariance (2 R / dt^2 for the velocity, R / dt for the cross terms).

        Raises:
            ValueError: the times are not increasing.
        """
        dt = _finite_time(t_second) - _finite_time(t_first)
        if not dt > 0.0:
            raise ValueError(f"two measurements need increasing times, got {t_first} s and {t_second} s")
        a, b = _measurement_vector(first), _measurement_vector(second)
        change = b - a
        change[_YAW] = wrap_angle(change[_YAW])
        R = np.asarray(self._kf.R, dtype=float)
        self._kf.x = np.concatenate([b, change / dt]).reshape(8, 1)
        self._kf.P = np.block([[R, R / dt], [R / dt, 2.0 * R / dt**2]])
        self._time = float(t_second)
        self.initialised = True
        self.consecutive_rejections = 0
        self._jumps.clear()
        return self._estimate(self._kf.x, self._kf.P, self._time)

    def predict(self, t: float) -> PoseEstimate:
        """Propagates the state to time `t` [s] and returns the prediction.

        Raises:
            InputError: not initialised, or `t` is before the filter's time.
        """
        dt = self._elapsed(t)
        if dt > 0.0:
            self._set_period(dt)
            self._kf.predict()
            self._kf.x[_YAW, 0] = wrap_angle(self._kf.x[_YAW, 0])
            self._time = float(t)
        return self._estimate(self._kf.x, self._kf.P, self._time)

    def estimate_at(self, t: float) -> PoseEstimate:
        """The prediction for time `t` [s] without changing the filter (e.g. to aim the
        hand where the cloth will be); the covariance includes the process noise."""
        dt = self._elapsed(t)
        F, Q = self._matrices(dt)
        x = F @ self._kf.x
        x[_YAW, 0] = wrap_angle(x[_YAW, 0])
        return self._estimate(x, F @ self._kf.P @ F.T + Q, float(t) if dt > 0.0 else self._time)

    def update(
        self, measurement: PoseXYZYaw | npt.ArrayLike, fitness: float, t: float, *, trusted: bool = True
    ) -> FilterUpdate:
        """Predicts to `t` [s] and fuses a recognised pose unless a gate rejects it.

        Args:
            measurement: (x, y, z, yaw) [m, rad] or the 4x4 pose of Σ_M in Σ_W.
            fitness: the recognition's normalised fitness [-].
            t: capture time of the recognised images [s].
            trusted: the recogniser decided the cloth is there (`found`); only trusted
                measurements can relocate the estimate, and untrusted ones count for less
                (`untrusted_std_scale`).

        Raises:
            InputError: malformed measurement, non-finite fitness or a time going back.
        """
        z = _measurement_vector(measurement)
        if not math.isfinite(fitness):
            raise ValueError(f"recognition fitness must be finite, got {fitness}")
        if fitness < self.settings.min_fitness:
            if not self.initialised:
                return self._reject(UpdateReason.LOW_FITNESS, math.nan)
            self.predict(t)
            distance = self._distance(z)
            if not self.lost and self._consistent(z):  # a poor view of the cloth where it should be
                self.rejected_count += 1
                return FilterUpdate(
                    False, UpdateReason.LOW_FITNESS_CONSISTENT, math.nan, self.estimate, distance
                )
            return self._reject(UpdateReason.LOW_FITNESS, math.nan, distance)
        if not self.initialised or self.lost:
            reason = UpdateReason.REINITIALISED if self.initialised else UpdateReason.INITIALISED
            if self.initialised:
                self._elapsed(t)  # a re-initialisation may not go back in time either
            self.reset(z, t)
            return self._accept(reason, math.nan)
        self.predict(t)
        distance = self._distance(z)
        kf = self._kf
        # the nearest branch, and the nearest of the cloth's symmetric yaws
        z[_YAW] = kf.x[_YAW, 0] + min(
            (float(wrap_angle(z[_YAW] + turn - kf.x[_YAW, 0])) for turn in self._yaw_turns), key=abs
        )
        innovation = z - (kf.H @ kf.x).ravel()
        R = kf.R if trusted else kf.R * self.settings.untrusted_std_scale**2
        S = kf.H @ kf.P @ kf.H.T + R
        nis = float(innovation @ np.linalg.solve(S, innovation))
        if np.linalg.norm(innovation[:3]) > self.settings.max_position_jump:
            return self._reject(UpdateReason.POSITION_JUMP, nis, distance)
        jump = None
        if abs(innovation[_YAW]) > self.settings.max_yaw_jump:
            jump = UpdateReason.YAW_JUMP
        elif nis > self.settings.gate_chi2:
            jump = UpdateReason.MAHALANOBIS
        if jump is not None:
            if not trusted:
                self._jumps.clear()
            elif self._relocates(z, float(t)):
                return self._relocate(z, nis, distance)
            return self._reject(jump, nis, distance)
        kf.update(z, R=R)
        kf.x[_YAW, 0] = wrap_angle(kf.x[_YAW, 0])
        return self._accept(UpdateReason.ACCEPTED, nis, distance)

    def fuse_velocities(self, samples: Sequence[tuple[float, FloatArray]], std: float) -> None:
        """Fuses measured horizontal velocities (a belt encoder's) in time order: each
        sample (t [s], (vx, vy) [m/s]) after the filter's time is predicted to and fused with
        `std` [m/s] per axis; older samples are skipped. No gate, no counter changes (an
        encoder is not a recognition), the filter's time ends at the last fused sample.

        Raises:
            RuntimeError: not initialised.
        """
        self._elapsed(self._time)  # initialised
        x, P, t = self._with_velocities(samples, std, self._kf.x, self._kf.P, self._time)
        self._kf.x, self._kf.P, self._time = x, P, t

    def estimate_with_velocities(
        self, samples: Sequence[tuple[float, FloatArray]], std: float, t: float
    ) -> PoseEstimate:
        """The prediction for time `t` [s] with the velocity samples up to `t` fused on the
        way (`fuse_velocities`), without changing the filter."""
        dt = self._elapsed(t)
        if dt <= 0.0:
            return self.estimate_at(t)
        kept = [(ts, v) for ts, v in samples if ts <= t]
        x, P, t_last = self._with_velocities(kept, std, self._kf.x, self._kf.P, self._time)
        F, Q = self._matrices(float(t) - t_last)
        x = F @ x
        x[_YAW, 0] = wrap_angle(x[_YAW, 0])
        return self._estimate(x, F @ P @ F.T + Q, float(t))

    def _with_velocities(
        self,
        samples: Sequence[tuple[float, FloatArray]],
        std: float,
        x: FloatArray,
        P: FloatArray,
        t: float,
    ) -> tuple[FloatArray, FloatArray, float]:
        """State, covariance and time after predicting to and fusing each later sample."""
        if not (math.isfinite(std) and std > 0.0):
            raise ValueError(f"a velocity's std must be finite and > 0 [m/s], got {std}")
        x, P = np.array(x, dtype=float), np.array(P, dtype=float)
        R = np.eye(2) * std**2
        for ts, velocity in samples:
            if not ts > t:
                continue
            F, Q = self._matrices(float(ts) - t)
            x, P, t = F @ x, F @ P @ F.T + Q, float(ts)
            innovation = np.asarray(velocity, dtype=float).reshape(2, 1) - _VELOCITY_H @ x
            S = _VELOCITY_H @ P @ _VELOCITY_H.T + R
            K = P @ _VELOCITY_H.T @ np.linalg.inv(S)
            x = x + K @ innovation
            I_KH = np.eye(8) - K @ _VELOCITY_H
            P = I_KH @ P @ I_KH.T + K @ R @ K.T  # Joseph form: stays symmetric and positive
        x[_YAW, 0] = wrap_angle(x[_YAW, 0])
        return x, P, t

    def _distance(self, z: FloatArray) -> float:
        """The measurement's horizontal distance from the current prediction [m]."""
        return float(np.hypot(z[0] - self._kf.x[0, 0], z[1] - self._kf.x[1, 0]))

    def _consistent(self, z: FloatArray) -> bool:
        """True if a measurement passes the position, yaw and Mahalanobis gates (not fused)."""
        kf = self._kf
        z = z.copy()
        z[_YAW] = kf.x[_YAW, 0] + wrap_angle(z[_YAW] - kf.x[_YAW, 0])
        innovation = z - (kf.H @ kf.x).ravel()
        S = kf.H @ kf.P @ kf.H.T + kf.R
        nis = float(innovation @ np.linalg.solve(S, innovation))
        s = self.settings
        return bool(
            np.linalg.norm(innovation[:3]) <= s.max_position_jump
            and abs(innovation[_YAW]) <= s.max_yaw_jump
            and nis <= s.gate_chi2
        )

    def _relocates(self, z: FloatArray, t: float) -> bool:
        """Keeps the run of agreeing rejected measurements; True once it is long enough."""
        s = self.settings
        if s.relocate_after == 0:
            return False
        velocity = self._kf.x[4:7, 0]
        if self._jumps:
            previous, t_previous = self._jumps[-1]
            expected = previous[:3] + velocity * (t - t_previous)
            turned = abs(float(wrap_angle(z[_YAW] - previous[_YAW])))
            if np.linalg.norm(z[:3] - expected) > s.relocation_tolerance or turned > RELOCATION_YAW:
                self._jumps.clear()
        self._jumps.append((z.copy(), t))
        return len(self._jumps) >= s.relocate_after

    def _relocate(self, z: FloatArray, nis: float, distance: float) -> FilterUpdate:
        """Restarts from the run of agreeing rejected measurements: at the newest, with the
        velocity between the first and the newest (a push leaves the belt running; a belt
        that stopped, or a cloth stopped at the belt's end, no longer moves)."""
        (first, t_first), (_, t_last) = self._jumps[0], self._jumps[-1]
        if t_last > t_first:
            self.reset_from_two(first, t_first, z, t_last)
        else:  # a run of one (relocate_after=1): the position only, the velocity kept
            velocity = self._kf.x[4:8, 0].copy()
            self.reset(z, t_last)
            self._kf.x[4:8, 0] = velocity
        return self._accept(UpdateReason.RELOCATED, nis, distance)

    def _accept(self, reason: UpdateReason, nis: float, distance: float = math.nan) -> FilterUpdate:
        self.accepted_count += 1
        self.consecutive_rejections = 0
        if reason is not UpdateReason.RELOCATED:
            self._jumps.clear()
        return FilterUpdate(True, reason, nis, self.estimate, distance)

    def _reject(self, reason: UpdateReason, nis: float, distance: float = math.nan) -> FilterUpdate:
        self.rejected_count += 1
        self.consecutive_rejections += 1
        if reason not in (UpdateReason.MAHALANOBIS, UpdateReason.YAW_JUMP):
            self._jumps.clear()
        return FilterUpdate(False, reason, nis, self.estimate, distance)

    def _elapsed(self, t: float) -> float:
        if not self.initialised:
            raise RuntimeError("the pose filter is not initialised: reset() it or update() it first")
        dt = _finite_time(t) - self._time
        if dt < 0.0:
            raise ValueError(
                f"pose filter time went back from {self._time:.6f} s to {t:.6f} s; "
                "give measurements and predictions in time order"
            )
        return dt

    def _set_period(self, dt: float) -> None:
        if dt != self._period:  # rebuild F and Q only when the period changes
            self._kf.F, self._kf.Q = self._matrices(dt)
            self._period = dt

    def _matrices(self, dt: float) -> tuple[FloatArray, FloatArray]:
        F = np.eye(8)
        F[:4, 4:] = dt * np.eye(4)
        Q = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=1.0, block_size=4, order_by_dim=False)
        return F, np.asarray(Q, dtype=float) * self._psd_scale

    @staticmethod
    def _estimate(x: FloatArray, P: FloatArray, t: float) -> PoseEstimate:
        state = np.asarray(x, dtype=float).ravel()
        velocity = state[4:7].copy()
        covariance = np.array(P, dtype=float)
        velocity.setflags(write=False)
        covariance.setflags(write=False)
        return PoseEstimate(
            float(state[0]),
            float(state[1]),
            float(state[2]),
            float(state[3]),
            velocity,
            float(state[7]),
            covariance,
            t,
        )


def _measurement_vector(pose: PoseXYZYaw | npt.ArrayLike) -> FloatArray:
    """(x, y, z, yaw) of a pose given as 4 numbers or a 4x4 world transform."""
    array = np.asarray(pose, dtype=float)
    if array.shape == (4, 4):
        if not (is_rotation(array[:3, :3], tol=1e-4) and np.allclose(array[3], [0, 0, 0, 1])):
            raise ValueError("a 4x4 cloth pose needs a rotation block and a last row (0, 0, 0, 1)")
        vector = np.array([*array[:3, 3], yaw_of(array[:3, :3])])
    elif array.shape == (4,):
        vector = array.copy()
    else:
        raise ValueError(f"a cloth pose is (x, y, z, yaw) or a 4x4 transform, got shape {array.shape}")
    if not np.all(np.isfinite(vector)):
        raise ValueError(f"a cloth pose must be finite, got {vector.tolist()}")
    vector[_YAW] = wrap_angle(vector[_YAW])
    return vector


def _finite_time(t: float) -> float:
    if not math.isfinite(t):
        raise ValueError(f"time must be finite [s], got {t}")
    return float(t)


__all__ = [
    "FilterUpdate",
    "PoseEstimate",
    "PoseFilter",
    "PoseFilterSettings",
    "PoseXYZYaw",
    "UpdateReason",
]
